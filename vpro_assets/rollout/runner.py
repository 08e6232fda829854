"""`vpro eval`: plan the (case, trial) episodes of a run, dispatch them, record every row.

A run is identified by its run id and fixed at creation: policy spec, episode settings, selection
and trial count. `resume=True` continues a run: episodes with a row are skipped (and episodes that
ended in an infrastructure error are attempted again when `retry_errors`), so a run killed with
kill -9 ends, after resuming, with the same set of rows as an uninterrupted one.
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from vpro_assets.benchmark.catalog import library_versions
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.rollout.backends import run_jobs
from vpro_assets.rollout.episode import EpisodeSettings
from vpro_assets.rollout.jobs import make_job
from vpro_assets.rollout.spec import check_spec, policy_label
from vpro_assets.rollout.store import ResultsStore

log = logging.getLogger(__name__)


@dataclass
class RunSummary:
    run_id: str
    planned: int
    skipped: int
    recorded: int
    counts: dict
    elapsed: float


def new_run_id(policy_id: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in policy_id)[:40]
    return f"{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}-{safe}"


def _catalog_sha(path: Path | None) -> str | None:
    if path is None or not Path(path).is_file():
        return None
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _open_run(
    store: ResultsStore,
    results,
    run_id: str | None,
    resume: bool,
    policy_spec: str,
    pid: str,
    settings: EpisodeSettings,
    selection: Sequence[str],
    trials: int,
) -> str:
    """The run to record into: the one to resume (same options), or a new one."""
    if resume:
        run_id = run_id or store.latest_run_id()
        run = store.run(run_id) if run_id else None
        if run is None or run_id is None:
            raise VProError(f"{results}: no run {run_id!r} to resume" if run_id else f"{results}: no run to resume")
        if run["policy_spec"] != policy_spec or run["settings"] != settings.to_json():
            raise VProError(
                f"run {run_id} was started with policy {run['policy_spec']!r} and settings "
                f"{run['settings']}; resume it with the same options"
            )
    else:
        run_id = run_id or new_run_id(pid)
        if store.run(run_id) is not None:
            raise VProError(f"{results}: run {run_id!r} exists; continue it with --resume")
        create_run(store, run_id, policy_spec, pid, settings, selection, trials)
    return run_id


def create_run(
    store: ResultsStore,
    run_id: str,
    policy_spec: str,
    pid: str,
    settings: EpisodeSettings,
    selection: Sequence[str],
    trials: int,
) -> None:
    """Record a new run with the library versions and the catalog it runs on."""
    store.create_run(
        run_id,
        policy_spec,
        pid,
        settings.to_json(),
        list(selection),
        trials,
        library_versions(),
        _catalog_sha(paths.catalog_path()),
    )


def _pending_jobs(
    store: ResultsStore, run_id: str, cases: Sequence[dict], trials: int, retry_errors: bool, job_args: tuple
) -> list[dict]:
    """The episodes not recorded yet, those of one task side by side."""
    done = store.done_keys(run_id, include_errors=not retry_errors)
    jobs = []
    for case in cases:
        for trial in range(trials):
            if (case["id"], trial) in done:
                continue
            job = make_job(run_id, case, trial, *job_args)
            job["prior_attempts"] = store.attempts(run_id, case["id"], trial)
            jobs.append(job)
    # Episodes of one task side by side: a worker reuses its env between them (reset, as LIBERO does).
    order = {t: i for i, t in reversed(list(enumerate(c["task"] for c in cases)))}
    jobs.sort(key=lambda j: order[j["case"]["task"]])
    return jobs


def run_eval(
    cases: Sequence[dict],
    *,
    results: Path | str,
    policy_spec: str,
    policy_options: dict | None = None,
    settings: EpisodeSettings | None = None,
    trials: int = 10,
    run_id: str | None = None,
    resume: bool = False,
    retry_errors: bool = False,
    backend: str = "local",
    workers: int = 1,
    address: str | None = None,
    retries: int = 2,
    retry_delay: float = 2.0,
    selection: Sequence[str] = (),
    on_row: Callable[[dict], None] | None = None,
    on_plan: Callable[[int, int], None] | None = None,
) -> RunSummary:
    policy_options = dict(policy_options or {})
    settings = settings or EpisodeSettings()
    if trials < 1:
        raise VProError(f"--trials must be at least 1, got {trials}")
    for case in cases:
        if trials > len(case["trial_seeds"]):
            raise VProError(f"--trials {trials}: case {case['id']} has {len(case['trial_seeds'])} trials")
    check_spec(policy_spec)  # fail fast on a bad spec, before any worker starts
    pid = policy_label(policy_spec, policy_options)
    started = time.monotonic()
    with ResultsStore(results) as store:
        run_id = _open_run(store, results, run_id, resume, policy_spec, pid, settings, selection, trials)
        jobs = _pending_jobs(
            store, run_id, cases, trials, retry_errors, (policy_spec, policy_options, settings, retries, retry_delay)
        )
        skipped = len(cases) * trials - len(jobs)
        log.info("run %s: %d episode(s) to run, %d already recorded", run_id, len(jobs), skipped)
        if on_plan:
            on_plan(len(jobs), skipped)
        recorded = 0
        for row in run_jobs(jobs, backend, workers, address):
            if store.record(row):
                recorded += 1
            if on_row:
                on_row(row)
        counts = store.count(run_id)
    return RunSummary(run_id, len(jobs), skipped, recorded, counts, time.monotonic() - started)
