"""Fixtures shared by the rollout tests."""

from __future__ import annotations

import pytest

from vpro_assets.rollout.runner import run_eval
from vpro_assets.rollout.store import ResultsStore


@pytest.fixture
def eval_on_server(tmp_path):
    """`run(case, port, settings, trials=1, retries=0, **options)`: `vpro eval`'s runner, inline, with
    the openpi policy at 127.0.0.1:port, into a fresh results file; returns the run's episode rows."""

    def run(case, port: int, settings, *, trials: int = 1, retries: int = 0, **options) -> list[dict]:
        db = tmp_path / "r.sqlite"
        summary = run_eval(
            [case],
            results=db,
            policy_spec=f"openpi:127.0.0.1:{port}",
            settings=settings,
            trials=trials,
            backend="inline",
            retries=retries,
            retry_delay=0,
            **options,
        )
        return ResultsStore(db).episodes(summary.run_id)

    return run
