"""Never lose work: a `vpro eval` killed with SIGKILL mid-run resumes to the same rows as an
uninterrupted run, without duplicates; the store never overwrites a result."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vpro_assets.rollout.store import ResultsStore

TRIALS = 3
ARGS = [
    "--policy",
    "random",
    "--select",
    "normal",
    "--select",
    "libero_object-02",
    "--trials",
    str(TRIALS),
    "--max-steps",
    "4",
    "--wait-steps",
    "1",
    "--resolution",
    "32",
    "--run-id",
    "r",
    "--no-progress",
]
KEY = ("case_id", "trial", "seed", "policy_id", "status", "success", "steps", "contact", "final_state")


def _vpro(*args) -> list[str]:
    return [sys.executable, "-m", "vpro_assets.cli", "eval", *args]


def _rows(db: Path) -> set[tuple]:
    return {tuple(r[k] for k in KEY) for r in ResultsStore(db).episodes("r")}


def _count(db: Path) -> int:
    if not db.exists():
        return 0
    try:
        con = sqlite3.connect(str(db), timeout=30)
        try:
            return con.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]
        finally:
            con.close()
    except sqlite3.OperationalError:  # tables not created yet
        return 0


def test_kill_9_then_resume_gives_the_rows_of_an_uninterrupted_run(tmp_path):
    env = dict(os.environ)
    reference, killed = tmp_path / "reference.sqlite", tmp_path / "killed.sqlite"

    proc = subprocess.Popen(_vpro(*ARGS, "--results", str(killed)), env=env, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while _count(killed) < 1 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    proc.stderr.close()
    after_kill = _count(killed)
    assert 1 <= after_kill < TRIALS, "the run must be killed mid-way"
    time.sleep(3)
    assert _count(killed) == after_kill  # the workers died with the runner: nothing more is written

    resumed = subprocess.run(
        _vpro(*ARGS, "--results", str(killed), "--resume"), env=env, capture_output=True, text=True, timeout=600
    )
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert f"{after_kill} episode(s) already recorded" in resumed.stderr

    # The uninterrupted run, in this process (the rows do not depend on the backend).
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.rollout.episode import EpisodeSettings
    from vpro_assets.rollout.runner import run_eval

    case = find_case(load_catalog(paths.catalog_path()), "libero_object-02/normal")
    run_eval(
        [case],
        results=reference,
        policy_spec="random",
        trials=TRIALS,
        run_id="r",
        backend="inline",
        settings=EpisodeSettings(resolution=32, wait_steps=1, max_steps_override=4),
    )

    assert _count(killed) == TRIALS == _count(reference)
    assert _rows(killed) == _rows(reference)
    assert all(r[4] == "ok" for r in _rows(reference))


def test_a_result_is_never_overwritten_and_an_error_is(tmp_path):
    db = tmp_path / "r.sqlite"
    with ResultsStore(db) as store:
        store.create_run("r", "noop", "noop", {}, [], 1, {}, None)
        base = {"run_id": "r", "case_id": "c", "trial": 0, "policy_id": "noop"}
        assert store.record(dict(base, status="error", error="server down", attempts=3))
        assert store.record(dict(base, status="ok", success=True, steps=5, attempts=4))
        assert not store.record(dict(base, status="error", error="late duplicate"))
        (row,) = store.episodes("r")
        assert row["status"] == "ok" and row["success"] == 1 and row["error"] is None and row["attempts"] == 4
        assert store.db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_resume_refuses_other_options(tmp_path):
    from vpro_assets.core.errors import VProError
    from vpro_assets.rollout.episode import EpisodeSettings
    from vpro_assets.rollout.runner import run_eval

    db = tmp_path / "r.sqlite"
    with ResultsStore(db) as store:
        store.create_run("r", "noop", "noop", EpisodeSettings().to_json(), [], 1, {}, None)
    with pytest.raises(VProError, match="resume it with the same options"):
        run_eval([], results=db, policy_spec="random", run_id="r", resume=True)
    with pytest.raises(VProError, match="exists; continue it with --resume"):
        run_eval([], results=db, policy_spec="noop", run_id="r")
