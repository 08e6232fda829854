"""Generate deformed target objects with the default coacd search and record per-stage times,
shape measures and a drop test, one JSON line per object (for docs/benchmarks.md).

    .venv/bin/python scripts/geometry_benchmark.py --out out/objects --results out/geometry_bench.jsonl \
        [--category akita_black_bowl ...] [--severity 3 ...] [--deformation taper ...]

Objects already generated with the same inputs are reported as cached (the warm-rebuild figure).
"""
from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

from generators.target_geometry import UP_AXES, generate_deformed_object
from vpro_assets.deform import DEFORMATIONS
from vpro_assets.mjcf_object import drop_test


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("out/objects"), help="objects folder (the build's cache)")
    parser.add_argument("--results", type=Path, default=Path("out/geometry_bench.jsonl"), help="JSON lines appended here")
    parser.add_argument("--category", action="append", help="target category (repeatable; default: all measured)")
    parser.add_argument("--deformation", action="append", choices=sorted(DEFORMATIONS), help="repeatable; default all")
    parser.add_argument("--severity", action="append", type=int, choices=(1, 2, 3), help="repeatable; default all")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    args.results.parent.mkdir(parents=True, exist_ok=True)
    for severity in args.severity or (3, 2, 1):
        for category in args.category or sorted(UP_AXES):
            for deformation in args.deformation or list(DEFORMATIONS):
                start = time.perf_counter()
                row = {"category": category, "deformation": deformation, "severity": severity}
                try:
                    obj = generate_deformed_object(category, deformation, severity, args.out)
                    drop = drop_test(obj.xml_path, UP_AXES[category])
                    row.update(name=obj.name, cached=obj.cached, timings=obj.timings,
                               measures=obj.record["measures"], repair=[r["method"] for r in obj.record["repair"]],
                               drop={"rests": drop.rests(), "speed": drop.speed, "tilt": drop.tilt,
                                     "warnings": drop.warnings},
                               bytes=sum((args.out / f.path).stat().st_size for f in obj.files))
                except Exception as exc:  # recorded, and the run goes on to the next object
                    row.update(error=f"{type(exc).__name__}: {exc}")
                row["seconds"] = time.perf_counter() - start
                with open(args.results, "a") as handle:
                    handle.write(json.dumps(row, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
