"""Render-free against rendered oracle episodes, side by side in one run.

For each case, the oracle's episodes of every trial run through `run_episode` with LIBERO's
offscreen renderer at 256x256 (both cameras, as `vpro eval` by default), then the same trials
render-free (`EpisodeSettings(render=False)`: no renderer, no camera observations). Each block
reuses its env between trials as a `vpro eval` worker does, so trial 0 includes building the env
and later trials are the steady state. Both must give the same success, steps and final-state
fingerprint; the table gives each one's wall time and the ratio.

    .venv/bin/python scripts/bench_render_free.py --select libero_goal-07 --select libero_spatial-00 --trials 2
"""

from __future__ import annotations

import argparse
import statistics
import time

from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--select", action="append", default=[], help="cases (as vpro eval --select); Normal baselines")
    p.add_argument("--trials", type=int, default=2)
    p.add_argument("--resolution", type=int, default=256)
    args = p.parse_args()
    cases = [
        c
        for c in select_cases(load_catalog(paths.catalog_path()), args.select + ["normal"])
        if not c.get("setting") and any(s in c["id"] for s in args.select)
    ]
    print("| episode | steps | success | rendered s | render-free s | ratio | same final state |")
    print("|---|---|---|---|---|---|---|")
    ratios, steady = [], []
    for case in cases:
        out: dict[str, list] = {"rendered": [], "free": []}
        for name, render in (("rendered", True), ("free", False)):
            for trial in range(args.trials):
                t0 = time.perf_counter()
                row = run_episode(
                    case, trial, OraclePolicy(), EpisodeSettings(resolution=args.resolution, render=render)
                )
                out[name].append((time.perf_counter() - t0, row))
        for trial in range(args.trials):
            (tr, rr), (tf, rf) = out["rendered"][trial], out["free"][trial]
            ratios.append(tr / tf)
            if trial:
                steady.append(tr / tf)
            same = (rr["final_state"], rr["steps"], rr["success"]) == (rf["final_state"], rf["steps"], rf["success"])
            print(
                f"| {case['id']} t{trial}{' (env built)' if trial == 0 else ''} | {rf['steps']} | {rf['success']} | "
                f"{tr:.1f} | {tf:.1f} | {tr / tf:.2f} | {same} |",
                flush=True,
            )
    print(
        f"\nmedian ratio rendered / render-free: {statistics.median(ratios):.2f} over {len(ratios)} episode pairs"
        + (f"; {statistics.median(steady):.2f} with the env reused" if steady else "")
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
