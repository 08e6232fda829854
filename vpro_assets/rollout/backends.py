"""Where jobs run: in this process, a local process pool (default), or a Ray cluster.

Every backend yields the rows of `execute_job` as episodes finish, in completion order; the runner
writes each one before asking for the next, so no result waits in memory.

The local pool starts `workers` spawn-context processes that build their envs themselves. Each
worker dies with its parent (PR_SET_PDEATHSIG on Linux, plus a parent-pid check), so a killed run
leaves no orphan simulating into the void. A worker that dies mid-episode (a simulator crash)
yields an error row for the episode it held and is replaced.

Rendering: Mesa's llvmpipe renders on every core by default; with several workers each renders on
one thread (`LP_NUM_THREADS=1`) so they do not fight over the cores.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import queue
from collections.abc import Iterable, Iterator
from typing import Any

from vpro_assets.core import numerics
from vpro_assets.core.errors import VProError
from vpro_assets.core.lifetime import die_with_parent
from vpro_assets.rollout.case_env import release_cached_envs
from vpro_assets.rollout.jobs import base_row, execute_job
from vpro_assets.rollout.store import utc_now

log = logging.getLogger(__name__)

BACKENDS = ("local", "inline", "ray")


def worker_env(workers: int) -> dict[str, str]:
    """Environment of a worker process: the pinned numpy kernels (a Ray worker loads numpy before our
    code runs) and, beside other workers, one thread each."""
    return (numerics.PINNED if numerics.X86_64 else {}) | ({"LP_NUM_THREADS": "1"} if workers > 1 else {})


def run_inline(jobs: Iterable[dict]) -> Iterator[dict]:
    try:
        for job in jobs:
            yield execute_job(job)
    finally:
        release_cached_envs()


def _worker_main(tasks, results, send_lock, parent_pid: int, env: dict) -> None:
    die_with_parent(parent_pid)
    os.environ.update(env)
    logging.getLogger("robosuite").setLevel(logging.ERROR)
    while True:
        try:
            job = tasks.get(timeout=1.0)
        except queue.Empty:
            if os.getppid() != parent_pid:
                return
            continue
        if job is None:
            release_cached_envs()
            return
        with send_lock:
            results.send(("start", (job["case"]["id"], job["trial"]), os.getpid()))
        row = execute_job(job)
        with send_lock:
            results.send(("row", row, os.getpid()))


def _rows_of_dead_workers(procs: dict, in_flight: dict, remaining: set, by_key: dict) -> Iterator[dict]:
    """Forget workers that died; the episode each was running becomes an error row."""
    for pid, proc in list(procs.items()):
        if proc.is_alive():
            continue
        del procs[pid]
        key = in_flight.pop(pid, None)
        if key is not None and key in remaining:
            remaining.discard(key)
            row = base_row(by_key[key])
            row.update(
                status="error",
                error_kind="WorkerDied",
                attempts=1,
                finished_at=utc_now(),
                error=f"worker process {pid} died (exit code {proc.exitcode}) during the episode",
            )
            yield row


def run_local(jobs: Iterable[dict], workers: int) -> Iterator[dict]:
    jobs = list(jobs)
    if not jobs:
        return
    workers = max(1, min(workers, len(jobs)))
    ctx = mp.get_context("spawn")
    # Results through one pipe that workers write to under a lock: `send` writes at once (a Queue
    # would hand it to a feeder thread), so the "start" note of a worker that crashes a moment later
    # is never lost, and the parent can wait on it with a timeout (`poll`) to notice dead workers.
    tasks = ctx.Queue()
    results, results_writer = ctx.Pipe(duplex=False)
    send_lock = ctx.Lock()
    by_key = {(j["case"]["id"], j["trial"]): j for j in jobs}
    for job in jobs:
        tasks.put(job)
    env = worker_env(workers)

    def start():
        p = ctx.Process(target=_worker_main, args=(tasks, results_writer, send_lock, os.getpid(), env), daemon=True)
        p.start()
        return p

    procs = {p.pid: p for p in (start() for _ in range(workers))}
    in_flight: dict[int, tuple] = {}
    remaining = set(by_key)
    try:
        while remaining:
            if not results.poll(1.0):  # quiet for a second: look for workers that died
                yield from _rows_of_dead_workers(procs, in_flight, remaining, by_key)
                while remaining and len(procs) < workers:
                    new = start()
                    procs[new.pid] = new
                continue
            kind, payload, pid = results.recv()
            if kind == "start":
                in_flight[pid] = payload
            else:
                in_flight.pop(pid, None)
                key = (payload["case_id"], payload["trial"])
                if key in remaining:
                    remaining.discard(key)
                    yield payload
    finally:
        for _ in procs:
            tasks.put(None)
        for proc in procs.values():
            proc.join(timeout=5)
            if proc.is_alive():
                proc.kill()
        tasks.cancel_join_thread()
        results.close()
        results_writer.close()


def run_ray(jobs: Iterable[dict], workers: int, address: str | None = None) -> Iterator[dict]:
    try:
        import ray
    except ImportError:
        raise VProError("--backend ray needs Ray: pip install 'ray==2.60.0'") from None
    jobs = list(jobs)
    if not jobs:
        return
    started_here = False
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "configure_logging": False,
            "runtime_env": {"env_vars": worker_env(max(workers, 2))},
        }
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=max(1, workers), **kwargs)
        started_here = True
    try:
        remote = ray.remote(num_cpus=1, max_retries=0)(execute_job)
        limit = max(1, workers) * 2
        pending: dict[Any, dict] = {}  # Ray object ref -> job
        queue_ = list(reversed(jobs))
        while queue_ or pending:
            while queue_ and len(pending) < limit:
                job = queue_.pop()
                pending[remote.remote(job)] = job
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                job = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except Exception as exc:  # the Ray worker died or the task could not run
                    row = base_row(job)
                    row.update(
                        status="error",
                        error_kind="RayTaskError",
                        attempts=1,
                        finished_at=utc_now(),
                        error=f"Ray task failed: {type(exc).__name__}: {str(exc).splitlines()[0][:300]}",
                    )
                    yield row
    finally:
        if started_here:
            ray.shutdown()


def run_jobs(jobs: list[dict], backend: str = "local", workers: int = 1, address: str | None = None) -> Iterator[dict]:
    if backend == "inline":
        return run_inline(jobs)
    if backend == "local":
        return run_local(jobs, workers)
    if backend == "ray":
        return run_ray(jobs, workers, address)
    raise VProError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
