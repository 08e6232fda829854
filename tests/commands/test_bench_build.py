"""`vpro bench build`: the per-stage summary pairs the two paths of the same cases, and bad input is
one line."""

from __future__ import annotations

import pytest

from vpro_assets.cli import main
from vpro_assets.commands.bench_build import markdown, summary


def _run(path: str, settle: float, mujoco: float) -> dict:
    return {
        "path": path,
        "seconds": {"variant_env": 2.0 if path == "reference" else 1.0, "settle": settle},
        "physics_seconds": {"settle": mujoco},
        "valid": True,
    }


def test_summary_sums_cases_takes_the_median_round_and_divides_reference_by_render_free():
    rows = [
        {
            "case": f"c{i}",
            "runs": [_run("reference", 8.0, 3.0), _run("render-free", 6.0, 3.0), _run("render-free", 4.0, 3.0)],
            "same_files": True,
            "matches_lock": True,
        }
        for i in range(2)
    ]
    s = summary(rows)
    assert s["settle"]["reference"] == {"seconds": 16.0, "mujoco_seconds": 6.0}
    assert s["settle"]["render-free"] == {"seconds": 10.0, "mujoco_seconds": 6.0}  # median of 6 and 4, two cases
    assert s["settle"]["ratio"] == 1.6 and s["variant_env"]["ratio"] == 2.0
    assert s["validate"]["ratio"] is None  # not measured: no ratio, not a division by zero
    meta = {
        "command": "vpro bench build",
        "date": "d",
        "load": "l",
        "cases": 2,
        "rounds": 1,
        "peak_rss_mb": 900,
        "same_files": "2/2",
        "matches_lock": "2/2",
    }
    assert "| settle | 16.0 | 10.0 | 1.60 | 6.0 | 6.0 | 60% |" in markdown(rows, meta)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--select", "libero_goal-03/normal", "--out", "x.json"], "selects no scene case"),
        (["--select", "libero_goal-03", "--rounds", "0", "--out", "x.json"], "--rounds must be at least 1, got 0"),
    ],
)
def test_bad_input_is_one_line(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["bench", "build", *argv]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
