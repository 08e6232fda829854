"""`vpro bench build`: the scene build and validation, robosuite's path against the render-free one,
side by side in one process.

For each selected scene case, in rounds: the case is built (`build_case(force=True)`, base scene
measured again) and validated once on the reference path (`physics.reference()`: every reset
compiles the model, every step is robosuite's own) and once on the render-free path (model cache,
physics-only step), the order alternating between rounds (render-free first) so a drift of the
machine's load falls on both. Every build is timed per stage, with the seconds MuJoCo itself spent in it (compiling the
scene model, mj_step, mj_forward: `physics.metered()`), and its files are checked equal between
the paths and against the lock. Generated objects are made once before the rounds (mesh work is
the same on both paths and is cached by content; a case already built in `--work` is not built again). The process's peak memory is read at the end.
"""

from __future__ import annotations

import contextlib
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from tqdm import tqdm

from vpro_assets.benchmark import lock
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.core.memory import peak_rss_mb
from vpro_assets.libero import physics
from vpro_assets.scene import base_scene, build
from vpro_assets.scene.stages import StageClock
from vpro_assets.scene.validate import validate_case

PATHS = ("reference", "render-free")
STAGES = ("base_scene", "generate", "bddl", "variant_env", "settle", "validate")


def add_parser(bsub, select_help: str) -> None:
    q = bsub.add_parser(
        "build",
        help="scene build and validation: robosuite's path against the render-free one, per stage",
        description="Build and validate each selected scene case on robosuite's own path (every reset "
        "compiles, robosuite's step) and on the render-free path (model cache, physics-only step), "
        "alternating in one process; report seconds per stage on each path, their ratio, the seconds "
        "MuJoCo needed in each stage, the peak memory, and whether the files equal each other and the lock.",
    )
    q.add_argument("--select", action="append", metavar="FILTER", required=True, help=select_help)
    q.add_argument("--rounds", type=int, default=1, help="builds per path and case (default 1)")
    q.add_argument("--out", type=Path, required=True, metavar="FILE.json", help="JSON file to write")
    q.add_argument(
        "--work", type=Path, default=None, help="out/ folder to build into (default: a new temporary folder)"
    )
    q.add_argument("--catalog", type=Path, default=None, help="catalog to read (default: catalog.json)")
    q.set_defaults(run=run_bench_build)


def _run_once(case: dict, path: str) -> dict:
    """Build and validate one case on one path; seconds and MuJoCo seconds per stage."""
    base_scene.base_scene.cache_clear()
    physics.clear_model_cache()
    clock = StageClock()
    with physics.metered(), physics.reference() if path == "reference" else contextlib.nullcontext():
        result = build.build_case(case, force=True)
        if result.status != "built":
            raise VProError(f"case {case['id']}: build failed on the {path} path: {result.error}")
        with clock.stage("validate"):
            valid = validate_case(case)
    stages = {k: v for k, v in result.stages.items() if k in STAGES} | clock.wall
    return {
        "path": path,
        "seconds": {k: round(v, 3) for k, v in stages.items()},
        "physics_seconds": {k: round(v, 3) for k, v in (result.physics | clock.physics).items()},
        "files": result.files,
        "valid": valid.ok,
    }


def bench(cases: list[dict], rounds: int) -> list[dict]:
    recorded = lock.load()
    rows = []
    with tqdm(total=len(cases) * (1 + 2 * rounds), desc="bench build", unit="build", file=sys.stderr) as bar:
        for case in cases:
            build.build_case(case)  # generated objects made once (kept from an earlier run in --work)
            bar.update(1)
            runs = []
            for r in range(rounds):
                # The render-free path first in the first round: what a cold start costs falls on it.
                for path in PATHS[::-1] if r % 2 == 0 else PATHS:
                    runs.append(_run_once(case, path))
                    bar.update(1)
            files = [run.pop("files") for run in runs]
            rows.append(
                {
                    "case": case["id"],
                    "runs": runs,
                    "same_files": all(f == files[0] for f in files),
                    "matches_lock": case["id"] in recorded and files[0] == recorded[case["id"]]["files"],
                }
            )
    return rows


def summary(rows: list[dict]) -> dict:
    """Per stage: seconds summed over cases (median over rounds) on each path, ratio, MuJoCo seconds."""
    out = {}
    for stage in STAGES:
        per: dict[str, Any] = {}
        for path in PATHS:
            wall, phys = 0.0, 0.0
            for row in rows:
                runs = [r for r in row["runs"] if r["path"] == path]
                wall += statistics.median(r["seconds"].get(stage, 0.0) for r in runs)
                phys += statistics.median(r["physics_seconds"].get(stage, 0.0) for r in runs)
            per[path] = {"seconds": round(wall, 2), "mujoco_seconds": round(phys, 2)}
        new = per["render-free"]["seconds"]
        per["ratio"] = round(per["reference"]["seconds"] / new, 2) if new else None
        out[stage] = per
    return out


def markdown(rows: list[dict], meta: dict) -> str:
    s = summary(rows)
    lines = [
        f"`{meta['command']}`, {meta['date']} ({meta['load']}; {meta['cases']} cases, {meta['rounds']} round(s), "
        f"peak memory of the process {meta['peak_rss_mb']} MB). Files equal on both paths: "
        f"{meta['same_files']}; equal to the lock: {meta['matches_lock']}.",
        "",
        "| stage | reference s | render-free s | ratio | MuJoCo s (reference) | MuJoCo s (render-free) "
        "| MuJoCo share (render-free) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for stage, per in s.items():
        ref, new = per["reference"], per["render-free"]
        share = f"{new['mujoco_seconds'] / new['seconds']:.0%}" if new["seconds"] else ""
        ratio = f"{per['ratio']:.2f}" if per["ratio"] else ""
        lines.append(
            f"| {stage} | {ref['seconds']:.1f} | {new['seconds']:.1f} | {ratio} | {ref['mujoco_seconds']:.1f} "
            f"| {new['mujoco_seconds']:.1f} | {share} |"
        )
    return "\n".join(lines) + "\n"


def run_bench_build(args) -> int:
    from vpro_assets.commands.build_cmd import scene_cases  # the build command's selection

    if args.rounds < 1:
        raise VProError(f"--rounds must be at least 1, got {args.rounds}")
    cases = scene_cases(args)
    if not cases:
        raise VProError(f"--select {' '.join(args.select)} selects no scene case")
    work = args.work or Path(tempfile.mkdtemp(prefix="vpro-bench-build-"))
    os.environ["VPRO_OUT"] = str(work)
    load0, t0 = os.getloadavg()[0], time.time()
    rows = bench(cases, args.rounds)
    meta = {
        "command": "vpro " + " ".join(sys.argv[1:]),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t0)),
        "load": f"load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end",
        "cases": len(rows),
        "rounds": args.rounds,
        "wall_seconds": round(time.time() - t0, 1),
        "peak_rss_mb": round(peak_rss_mb()),
        "same_files": f"{sum(r['same_files'] for r in rows)}/{len(rows)}",
        "matches_lock": f"{sum(r['matches_lock'] for r in rows)}/{len(rows)}",
    }
    write_text_atomic(args.out, json.dumps({"meta": meta, "summary": summary(rows), "cases": rows}, indent=1) + "\n")
    print(markdown(rows, meta))
    return 0 if all(r["same_files"] for r in rows) else 1
