"""`vpro bench perturb` and `vpro preview` plumbing that needs no renderer: setting selection, the
section-aware Markdown writer, and the shared `preview` command."""

from __future__ import annotations

import pytest

from vpro_assets.cli import build_parser
from vpro_assets.commands.bench_cmd import markdown_table, observation_settings, update_markdown_section
from vpro_assets.core.errors import VProError


def test_selection_of_settings():
    assert len(observation_settings(None)) == 74
    picked = observation_settings(["camera_staleness"])
    assert len(picked) == 10 and all(s.category == "camera_staleness" for s in picked)
    assert [s.id for s in observation_settings(["vpro/view_unavailability/wrist-constant-v1"])] == [
        "vpro/view_unavailability/wrist-constant-v1"
    ]
    with pytest.raises(VProError):
        observation_settings(["task_relevant_distractors"])  # scene settings have no perturbation


def test_markdown_section_is_replaced_and_others_kept(tmp_path):
    doc = tmp_path / "benchmarks.md"
    doc.write_text("# Benchmarks\n\nintro\n\n<!-- BEGIN bench:other -->\nother table\n<!-- END bench:other -->\n")
    row = {
        "setting": "vpro/x",
        "category": "c",
        "task": "t",
        "steps": 3,
        "needs_extra_render": False,
        "clean_step_ms": 1.0,
        "perturbed_step_ms": 1.0,
        "ratio": 1.0,
        "active_steps": 3,
        "meets_goal": True,
    }
    meta = {"date": "d", "machine": "m", "steps": 3, "resolution": 64}
    update_markdown_section(doc, "perturb", markdown_table([row], meta))
    update_markdown_section(doc, "perturb", markdown_table([dict(row, ratio=1.5, meets_goal=False)], meta))
    text = doc.read_text()
    assert text.count("<!-- BEGIN bench:perturb -->") == 1 and "| 1.500 |" in text and "| 1.000 |" not in text
    assert "other table" in text and text.startswith("# Benchmarks\n\nintro\n")


def test_preview_and_bench_commands_are_registered():
    parser = build_parser()
    args = parser.parse_args(["preview", "libero_goal-03/camera_staleness/wrist-freeze-v1", "--out", "x.png"])
    assert callable(args.run)
    args = parser.parse_args(["bench", "perturb", "--out", "x.json", "--select", "camera_staleness", "--steps", "5"])
    assert args.steps == 5 and args.select == ["camera_staleness"]
