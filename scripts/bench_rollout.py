"""Throughput of the rollout layer on this machine (docs/benchmarks.md, section "Rollout").

1. Runner overhead per step: a bare LIBERO loop (env.step with the no-op action) and the runner's
   episode loop (noop policy through the policy protocol, contact and phase tracking, action
   validation) on the same task, same resolution, same number of steps, alternated in one process.
2. Episodes per hour: `run_eval` on the local process pool with 1 and then 2 workers, full-length
   LIBERO episodes (noop never succeeds: 10 wait + 220 steps on libero_spatial at 256 px).

Usage: .venv/bin/python scripts/bench_rollout.py [--episodes 4] [--steps 100] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path


def bare_loop(task, state, steps: int, resolution: int) -> float:
    from vpro_assets.libero.env import NOOP_ACTION, make_env

    env = make_env(task, resolution)
    try:
        env.reset()
        env.set_init_state(state)
        t = time.perf_counter()
        for _ in range(steps):
            env.step(NOOP_ACTION)
        return (time.perf_counter() - t) / steps
    finally:
        env.close()


class _TimedEnv:
    """Delegates to LIBERO's env and adds up the time spent in its step()."""

    def __init__(self, env, acc: dict):
        self._env, self._acc = env, acc

    def step(self, action):
        t = time.perf_counter()
        try:
            return self._env.step(action)
        finally:
            self._acc["env_step"] = self._acc.get("env_step", 0.0) + time.perf_counter() - t

    def __getattr__(self, name):
        return getattr(self._env, name)


def runner_loop_timed(case, steps: int, resolution: int) -> tuple[float, float]:
    """Per-step time of the runner's loop (run_episode, from the policy's first call) and, within
    it, per-step time spent inside LIBERO's env.step; the difference is the runner's own cost."""
    from vpro_assets.rollout import episode as ep
    from vpro_assets.rollout.case_env import release_cached_envs
    from vpro_assets.rollout.policies.reference import NoopPolicy

    stamps = {}
    original = ep.env_for_case

    def timed_env_for_case(*args, **kwargs):
        cenv = original(*args, **kwargs)
        cenv.env = _TimedEnv(cenv.env, stamps)
        return cenv

    class Stamp(NoopPolicy):
        def act(self, obs):
            stamps.setdefault("first_act", time.perf_counter())
            return super().act(obs)

    settings = ep.EpisodeSettings(resolution=resolution, wait_steps=0, max_steps_override=steps)
    ep.env_for_case = timed_env_for_case
    try:
        ep.run_episode(case, 0, Stamp(), settings)
        end = time.perf_counter()
    finally:
        ep.env_for_case = original
        release_cached_envs()
    # run_episode's tail after the loop (timeline, state digest, env back to the cache) is included.
    return (end - stamps["first_act"]) / steps, stamps["env_step"] / steps


def episodes_per_hour(cases, trials: int, workers: int, resolution: int) -> dict:
    from vpro_assets.rollout.episode import EpisodeSettings
    from vpro_assets.rollout.runner import run_eval

    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        summary = run_eval(
            cases,
            results=Path(tmp) / "b.sqlite",
            policy_spec="noop",
            trials=trials,
            workers=workers,
            settings=EpisodeSettings(resolution=resolution),
            retries=0,
        )
        elapsed = time.perf_counter() - t
    n = sum(summary.counts.values())
    return {
        "workers": workers,
        "episodes": n,
        "seconds": elapsed,
        "episodes_per_hour": 3600 * n / elapsed,
        "counts": summary.counts,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=4, help="episodes per worker-count measurement")
    parser.add_argument("--steps", type=int, default=100, help="steps per overhead measurement")
    parser.add_argument("--rounds", type=int, default=2, help="alternations of bare and runner loops")
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.libero.env import libero_init_states
    from vpro_assets.libero.tasks import get_task

    catalog = load_catalog(paths.catalog_path())
    case = find_case(catalog, "libero_spatial-00/normal")
    task = get_task(case["task"])
    state = libero_init_states(task)[0]
    load_start = os.getloadavg()
    bare, runner, inside, own = [], [], [], []
    for _ in range(args.rounds):
        bare.append(bare_loop(task, state, args.steps, args.resolution))
        total, env_step = runner_loop_timed(case, args.steps, args.resolution)
        runner.append(total)
        inside.append(env_step)
        own.append(total - env_step)
    ms = lambda xs: round(1000 * statistics.median(xs), 2)  # noqa: E731
    out = {
        "load_average_start": load_start,
        "cpus": os.cpu_count(),
        "resolution": args.resolution,
        "overhead": {
            "steps": args.steps,
            "rounds": args.rounds,
            "bare_step_s": bare,
            "runner_step_s": runner,
            "runner_env_step_s": inside,
            "runner_own_s": own,
            "bare_median_ms": ms(bare),
            "runner_median_ms": ms(runner),
            "runner_env_step_median_ms": ms(inside),
            "runner_own_median_ms": ms(own),
            "difference_median_ms": ms(runner) - ms(bare),
        },
    }
    cases = [find_case(catalog, f"libero_spatial-0{i}/normal") for i in range(2)]
    trials = max(1, args.episodes // len(cases))
    out["throughput"] = [episodes_per_hour(cases, trials, w, args.resolution) for w in (1, 2)]
    out["load_average_end"] = os.getloadavg()
    text = json.dumps(out, indent=1)
    if args.json:
        args.json.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
