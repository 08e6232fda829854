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
    from vpro_assets.env import NOOP_ACTION, make_env

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


def runner_loop_timed(case, steps: int, resolution: int) -> float:
    """Per-step time of the runner's loop: run_episode with a policy that stamps its first call."""
    from vpro_assets.rollout import episode as ep
    from vpro_assets.rollout.case_env import release_cached_envs
    from vpro_assets.rollout.reference import NoopPolicy

    stamps = {}

    class Stamp(NoopPolicy):
        def act(self, obs):
            stamps.setdefault("first_act", time.perf_counter())
            return super().act(obs)

    settings = ep.EpisodeSettings(resolution=resolution, wait_steps=0, max_steps_override=steps)
    try:
        ep.run_episode(case, 0, Stamp(), settings)
        end = time.perf_counter()
    finally:
        release_cached_envs()
    # run_episode's tail after the loop (timeline, state digest, env close to cache) is tiny.
    return (end - stamps["first_act"]) / steps


def episodes_per_hour(cases, trials: int, workers: int, resolution: int) -> dict:
    from vpro_assets.rollout.episode import EpisodeSettings
    from vpro_assets.rollout.runner import run_eval

    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        summary = run_eval(cases, results=Path(tmp) / "b.sqlite", policy_spec="noop", trials=trials, workers=workers,
                           settings=EpisodeSettings(resolution=resolution), retries=0)
        elapsed = time.perf_counter() - t
    n = sum(summary.counts.values())
    return {"workers": workers, "episodes": n, "seconds": elapsed, "episodes_per_hour": 3600 * n / elapsed,
            "counts": summary.counts}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=4, help="episodes per worker-count measurement")
    parser.add_argument("--steps", type=int, default=100, help="steps per overhead measurement")
    parser.add_argument("--rounds", type=int, default=2, help="alternations of bare and runner loops")
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    from vpro_assets import paths
    from vpro_assets.catalog import find_case, load_catalog
    from vpro_assets.env import libero_init_states
    from vpro_assets.tasks import get_task

    catalog = load_catalog(paths.catalog_path())
    case = find_case(catalog, "libero_spatial-00/normal")
    task = get_task(case["task"])
    state = libero_init_states(task)[0]
    bare, runner = [], []
    for _ in range(args.rounds):
        bare.append(bare_loop(task, state, args.steps, args.resolution))
        runner.append(runner_loop_timed(case, args.steps, args.resolution))
    out = {"load_average_start": os.getloadavg(), "cpus": os.cpu_count(), "resolution": args.resolution,
           "overhead": {"steps": args.steps, "rounds": args.rounds, "bare_step_s": bare, "runner_step_s": runner,
                        "bare_median_ms": 1000 * statistics.median(bare),
                        "runner_median_ms": 1000 * statistics.median(runner),
                        "overhead_ms": 1000 * (statistics.median(runner) - statistics.median(bare))}}
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
