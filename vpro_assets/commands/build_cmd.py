"""`vpro build`: scene cases as files in out/, content-addressed, parallel, resumable."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from vpro_assets.benchmark import lock
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import describe, select_cases
from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.scene.build import build

SELECT_HELP = (
    "case id, setting id, category, dimension, suite or task (repeatable; several are a union; "
    "none means every case). Only scene cases have artifacts; others are skipped."
)


def add_parser(sub) -> None:
    b = sub.add_parser(
        "build",
        help="generate scene cases (BDDL, objects, frozen initial states) into out/",
        description="Generate the artifacts of the selected scene cases into out/scene/<case id>/: "
        "the variant BDDL, 10 settled initial states (LIBERO .pruned_init and .npz) and meta.json; "
        "generated objects go to out/objects/. Content-addressed: a case whose inputs did not "
        "change is not rebuilt. Cases are written atomically, so an interrupted build resumes. "
        "The artifact hashes are recorded in scene_artifacts.lock.json for `vpro catalog build`.",
    )
    b.add_argument("--select", action="append", metavar="FILTER", help=SELECT_HELP)
    b.add_argument("-j", "--jobs", type=int, default=1, help="worker processes (default 1; a case takes ~10-25 s)")
    b.add_argument("--force", action="store_true", help="rebuild even when the inputs are unchanged")
    b.add_argument("--no-record", action="store_true", help="do not record the hashes in the lock file")
    b.add_argument(
        "--timings",
        type=Path,
        default=None,
        metavar="FILE.json",
        help="write every case's status, seconds and per-stage split (mesh work, settling...) to FILE.json",
    )
    b.add_argument("--catalog", type=Path, default=None, help="catalog to read (default: catalog.json)")
    b.set_defaults(run=run_build)


def scene_cases(args, catalog: dict | None = None) -> list[dict]:
    """The selected scene cases of the catalog (read from `--catalog` unless given)."""
    catalog = catalog or load_catalog(args.catalog or paths.catalog_path())
    return [c for c in select_cases(catalog, args.select) if c.get("level") == "scene"]


def run_build(args) -> int:
    catalog = load_catalog(args.catalog or paths.catalog_path())
    cases = scene_cases(args, catalog)
    print(f"building {describe(cases)} into {paths.out_dir() / 'scene'} with {args.jobs} job(s)", file=sys.stderr)
    started = time.perf_counter()
    results = build(cases, jobs=args.jobs, force=args.force, progress=True)
    failed = [r for r in results if r.status == "failed"]
    built = sum(r.status == "built" for r in results)
    unchanged = sum(r.status == "unchanged" for r in results)
    if not args.no_record:
        in_catalog = {c["id"] for c in catalog["cases"] if c.get("level") == "scene"}
        lock.record([r for r in results if r.status != "failed"], in_catalog)
    for r in failed:
        print(f"FAILED {r.error}", file=sys.stderr)
    stages: dict[str, float] = {}
    for r in results:
        for k, v in r.stages.items():
            stages[k] = stages.get(k, 0.0) + v
    split = ", ".join(f"{k} {v:.1f} s" for k, v in stages.items())
    wall = time.perf_counter() - started
    peak = max((r.peak_rss_mb for r in results), default=0.0)
    child_peak = max((r.peak_child_rss_mb for r in results), default=0.0)
    print(f"{built} built, {unchanged} unchanged, {len(failed)} failed in {wall:.1f} s ({split})", file=sys.stderr)
    if peak:
        child = f" (of the child generating a deformed object: {child_peak:.0f} MB)" if child_peak else ""
        print(f"peak memory of a worker: {peak:.0f} MB{child}", file=sys.stderr)
    if args.timings:
        write_text_atomic(
            args.timings,
            json.dumps(
                {
                    "wall_seconds": round(wall, 1),
                    "jobs": args.jobs,
                    "stage_seconds": {k: round(v, 1) for k, v in stages.items()},
                    "peak_rss_mb_per_worker": round(peak),
                    "peak_rss_mb_per_generation_child": round(child_peak),
                    "cases": [
                        {
                            "case": r.case_id,
                            "status": r.status,
                            "seconds": round(r.seconds, 2),
                            "stages": {k: round(v, 2) for k, v in r.stages.items()},
                            "peak_rss_mb": round(r.peak_rss_mb),
                            "peak_child_rss_mb": round(r.peak_child_rss_mb),
                            "error": r.error,
                        }
                        for r in results
                    ],
                },
                indent=1,
            )
            + "\n",
        )
    return 1 if failed else 0
