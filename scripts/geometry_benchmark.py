"""Generate deformed target objects with the default coacd search and record per-stage times,
shape measures and a drop test, one JSON line per object (for docs/benchmarks.md).

    .venv/bin/python scripts/geometry_benchmark.py --out out/objects --results out/geometry_bench.jsonl \
        [--category akita_black_bowl ...] [--severity 3 ...] [--deformation taper ...]

Objects already generated with the same inputs are reported as cached (the warm-rebuild figure).
`--shape-only` measures volume and extent changes of every object without coacd or files (fast);
`--doc docs/benchmarks.md` writes the "geometry" section of that file from the results.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

import numpy as np

from vpro_assets.geometry import deform
from vpro_assets.geometry.deform import DEFORMATIONS
from vpro_assets.objects.deformed import (
    REFINE_FRACTION,
    UP_AXES,
    generate_deformed_object,
    geometry_setting,
    libero_object_xml,
)
from vpro_assets.objects.mjcf import drop_test


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("out/objects"), help="objects folder (the build's cache)")
    parser.add_argument(
        "--results", type=Path, default=Path("out/geometry_bench.jsonl"), help="JSON lines appended here"
    )
    parser.add_argument("--category", action="append", help="target category (repeatable; default: all measured)")
    parser.add_argument("--deformation", action="append", choices=sorted(DEFORMATIONS), help="repeatable; default all")
    parser.add_argument("--severity", action="append", type=int, choices=(1, 2, 3), help="repeatable; default all")
    parser.add_argument("--shape-only", action="store_true", help="only shape measures (no coacd, no files)")
    parser.add_argument("--no-drop", action="store_true", help="skip the drop test (for the warm-rebuild figure)")
    parser.add_argument("--doc", type=Path, help="write the 'geometry' section of this Markdown file and exit")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    if args.doc:
        from vpro_assets.commands.bench_cmd import update_markdown_section

        update_markdown_section(args.doc, "geometry", summary(args.results, args.results.with_suffix(".shape.jsonl")))
        return
    args.results.parent.mkdir(parents=True, exist_ok=True)
    if args.shape_only:
        shape_measures(args)
        return
    for severity in args.severity or (3, 2, 1):
        for category in args.category or sorted(UP_AXES):
            for deformation in args.deformation or list(DEFORMATIONS):
                start = time.perf_counter()
                row = {"category": category, "deformation": deformation, "severity": severity}
                try:
                    obj = generate_deformed_object(category, deformation, severity, args.out)
                    row["generate_seconds"] = time.perf_counter() - start
                    row.update(
                        name=obj.name,
                        cached=obj.cached,
                        timings=obj.timings,
                        measures=obj.record["measures"],
                        repair=[r["method"] for r in obj.record["repair"]],
                        bytes=sum((args.out / f.path).stat().st_size for f in obj.files),
                    )
                    if not args.no_drop:
                        drop = drop_test(obj.xml_path, UP_AXES[category])
                        row["drop"] = {
                            "rests": drop.rests(),
                            "speed": drop.speed,
                            "tilt": drop.tilt,
                            "warnings": drop.warnings,
                        }
                except Exception as exc:  # recorded, and the run goes on to the next object
                    row.update(error=f"{type(exc).__name__}: {exc}")
                row["seconds"] = time.perf_counter() - start
                with open(args.results, "a") as handle:
                    handle.write(json.dumps(row, sort_keys=True) + "\n")


def shape_measures(args) -> None:
    """Volume, extents and displacement of every deformed solid, by the generator's own steps."""
    from vpro_assets.geometry.meshes import load_libero_object
    from vpro_assets.geometry.solid import manifold_arrays, repair_part, union

    out = args.results.with_suffix(".shape.jsonl")
    for category in args.category or sorted(UP_AXES):
        start = time.perf_counter()
        source = load_libero_object(category, libero_object_xml(category))
        solid0 = union([repair_part(p.name, p.corners)[0] for p in source.parts])
        v0, _f0 = manifold_arrays(solid0)
        extent = float((v0.max(axis=0) - v0.min(axis=0)).max())
        solid0 = solid0.refine_to_length(extent * REFINE_FRACTION)
        v0, f0 = manifold_arrays(solid0)
        import trimesh

        frame = deform.upright_frame(UP_AXES[category], v0, trimesh.Trimesh(v0, f0, process=False).center_mass)
        up0 = frame.to_upright(v0)
        ext0 = up0.max(axis=0) - up0.min(axis=0)
        repair_s = time.perf_counter() - start
        for deformation in args.deformation or list(DEFORMATIONS):
            for severity in args.severity or (1, 2, 3):
                t = time.perf_counter()
                params = geometry_setting(deformation, severity).param_dict
                amount = deform.amount_of(deformation, params)
                warp = deform.deformation_map(deformation, amount, frame, **deform.extra_params_of(deformation, params))
                solid = solid0.warp_batch(lambda p, warp=warp: warp(np.asarray(p)))
                v1, _f1 = manifold_arrays(solid)
                up1 = frame.to_upright(v1)
                ext1 = up1.max(axis=0) - up1.min(axis=0)
                row = {
                    "category": category,
                    "deformation": deformation,
                    "severity": severity,
                    "volume_ratio": solid.volume() / solid0.volume(),
                    "extent_ratios": (ext1 / ext0).tolist(),
                    "mean_displacement": deform.displacement_measure(v0, warp, float(np.linalg.norm(ext0))),
                    "max_radius_ratio": float(
                        np.linalg.norm(up1[:, :2], axis=1).max() / np.linalg.norm(up0[:, :2], axis=1).max()
                    ),
                    "repair_seconds": repair_s,
                    "deform_seconds": time.perf_counter() - t,
                }
                with open(out, "a") as handle:
                    handle.write(json.dumps(row, sort_keys=True) + "\n")


def _read(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.is_file() else []


def summary(results: Path, shapes: Path) -> str:
    """The Markdown section: per-stage times, shape changes, hull counts, drop tests."""
    import statistics as st

    rows = [r for r in _read(results) if "error" not in r]
    errors = [r for r in _read(results) if "error" in r]
    latest = {}  # a re-measured object replaces its earlier cold row
    for r in rows:
        if not r["cached"]:
            latest[(r["category"], r["deformation"], r["severity"])] = r
    cold = list(latest.values())
    warm = [r for r in rows if r["cached"]]
    lines = [
        "## Target geometry generation (`vpro_assets/objects/deformed.py`)",
        "",
        "Measured with `scripts/geometry_benchmark.py` on this machine (2 cores shared with other jobs, "
        "so times are upper bounds), default coacd search (`vpro_assets.geometry.convex.CoacdParams`).",
        "",
    ]
    if cold:
        lines += [
            f"Cold generation of {len(cold)} objects ({len({r['category'] for r in cold})} categories); "
            "seconds per object:",
            "",
            "| stage | median | mean | max | total |",
            "|---|---:|---:|---:|---:|",
        ]
        for stage in ("manifold_repair", "deformation", "coacd", "write"):
            values = [r["timings"][stage] for r in cold]
            lines.append(
                f"| {stage} | {st.median(values):.1f} | {st.mean(values):.1f} | {max(values):.1f} | {sum(values):.0f} |"
            )
        totals = [r["seconds"] for r in cold]
        lines.append(
            f"| whole object (incl. drop test) | {st.median(totals):.1f} | {st.mean(totals):.1f} | "
            f"{max(totals):.1f} | {sum(totals):.0f} |"
        )
        lines += [
            "",
            "Per category (cold; median seconds of coacd and of the whole object, hulls, repair):",
            "",
            "| category | objects | repair | coacd s | total s | hulls (min-max) | hull/solid volume | MB per object (texture incl.) |",
            "|---|---:|---|---:|---:|---|---:|---:|",
        ]
        for category in sorted({r["category"] for r in cold}):
            rs = [r for r in cold if r["category"] == category]
            hulls = [r["measures"]["hull_count"] for r in rs]
            lines.append(
                f"| {category} | {len(rs)} | {'+'.join(rs[0]['repair'])} | "
                f"{st.median(r['timings']['coacd'] for r in rs):.1f} | {st.median(r['seconds'] for r in rs):.1f} | "
                f"{min(hulls)}-{max(hulls)} | {st.median(r['measures']['hull_volume_ratio'] for r in rs):.2f} | "
                f"{st.median(r['bytes'] for r in rs) / 1e6:.1f} |"
            )
        lines += [
            "",
            "Hulls and coacd seconds per setting (min / median / max over the categories measured):",
            "",
            "| setting | objects | hulls | coacd s |",
            "|---|---:|---|---|",
        ]
        for deformation in DEFORMATIONS:
            for severity in (1, 2, 3):
                rs = [r for r in cold if r["deformation"] == deformation and r["severity"] == severity]
                if rs:
                    hulls = sorted(r["measures"]["hull_count"] for r in rs)
                    secs = sorted(r["timings"]["coacd"] for r in rs)
                    lines.append(
                        f"| {deformation}-s{severity} | {len(rs)} | {hulls[0]} / {st.median(hulls):g} / "
                        f"{hulls[-1]} | {secs[0]:.1f} / {st.median(secs):.1f} / {secs[-1]:.1f} |"
                    )
        dropped = [r for r in cold if "drop" in r]
        per_category = {
            c: st.mean(r.get("generate_seconds", r["seconds"]) for r in cold if r["category"] == c)
            for c in {r["category"] for r in cold}
        }
        overall = st.mean(per_category.values())
        estimate = sum(12 * per_category.get(c, overall) for c in UP_AXES)
        lines += [
            "",
            f"Cold generation of all {12 * len(UP_AXES)} geometry objects ({len(UP_AXES)} target categories x "
            f"12 settings), estimated from the per-category means above (categories not measured at the mean): "
            f"{estimate / 60:.0f} min in one process on this machine; objects are independent, so the build "
            "divides this by its worker count.",
        ]
        rests = sum(r["drop"]["rests"] and not r["drop"]["warnings"] for r in dropped)
        lines += [
            "",
            f"Drop test (2 s on a table-top box, LIBERO's contact parameters): {rests} of {len(dropped)} objects "
            "compile without MuJoCo warning and rest (tilt under 5 degrees, drift under 1 mm and turn under "
            f"1 degree over the last 0.5 s); largest speed over the last 0.5 s "
            f"{max(r['drop']['speed'] for r in dropped):.4f} m/s, largest tilt "
            f"{max(r['drop']['tilt'] for r in dropped):.1f} degrees.",
        ]
    if warm:
        seconds = [r.get("generate_seconds", r["seconds"]) for r in warm]
        lines += [
            "",
            f"Warm rebuild (inputs unchanged: the input key matches and every file's sha256 is verified): "
            f"{len(warm)} objects in {sum(seconds):.1f} s, median {st.median(seconds):.2f} s each.",
        ]
    if errors:
        lines += [
            "",
            f"Failures: {len(errors)}: "
            + "; ".join(f"{r['category']} {r['deformation']} s{r['severity']}: {r['error']}" for r in errors),
        ]
    lines += [
        "",
        "Stated bands, checked by `tests/objects/test_deformed_objects.py`: solid volume within 0.75-1.30 of the "
        "original closed solid, height unchanged (every map moves points horizontally), horizontal extents "
        "within 0.70-2.00 for the default-run target; 1 to 64 hulls per object (coacd merges down to 48; "
        "cutting the supporting hulls into quadrants adds a few). Hull/solid volume above 1 is the convex hulls' "
        "cover of concave parts (a bowl's inside; the moka pot's solid is a hollow shell whose open seams keep its inside empty, its hulls fill it).",
    ]
    shape = _read(shapes)
    if shape:
        lines += [
            "",
            f"Shape changes over {len({r['category'] for r in shape})} target categories "
            "(deformed / original closed solid; extents in the upright frame, horizontal ones pooled; "
            "height is unchanged by every map; mean displacement is the mean vertex displacement over the "
            "original bounding-box diagonal):",
            "",
            "| setting | amount | volume ratio min / median / max | horizontal extent ratio min / max | "
            "max radius ratio min / max | mean displacement median |",
            "|---|---:|---|---|---|---:|",
        ]
        for deformation in DEFORMATIONS:
            for severity in (1, 2, 3):
                rs = [r for r in shape if r["deformation"] == deformation and r["severity"] == severity]
                if not rs:
                    continue
                vol = [r["volume_ratio"] for r in rs]
                ext = [x for r in rs for x in r["extent_ratios"][:2]]
                amount = deform.amount_of(deformation, geometry_setting(deformation, severity).param_dict)
                rad = [r["max_radius_ratio"] for r in rs]
                lines.append(
                    f"| {deformation}-s{severity} | {amount:g} | {min(vol):.3f} / {st.median(vol):.3f} / "
                    f"{max(vol):.3f} | {min(ext):.3f} / {max(ext):.3f} | {min(rad):.3f} / {max(rad):.3f} | "
                    f"{st.median(r['mean_displacement'] for r in rs):.4f} |"
                )
        widest = max(shape, key=lambda r: max(r["extent_ratios"][:2]))
        lines += [
            "",
            f"Widest axis-aligned extent change: {widest['category']} {widest['deformation']}-"
            f"s{widest['severity']} ({max(widest['extent_ratios'][:2]):.2f}x): a twist turns an elongated "
            "cross-section, so its thin side's extent grows while volume, height and largest radius stay.",
        ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
