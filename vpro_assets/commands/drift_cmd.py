"""`vpro drift`: re-settle the selected cases in this environment and compare them with the
committed settled-scene fingerprints; exit 1 when a case drifted beyond the tolerances."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vpro_assets.benchmark import fingerprints as fp
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.core.images import write_png
from vpro_assets.libero import settled
from vpro_assets.libero.settled import simulator_label, simulator_versions
from vpro_assets.rollout.settle import first_frames, settle_trial


def add_parser(sub) -> None:
    p = sub.add_parser(
        "drift",
        help="re-settle cases here and compare with the committed settled-scene fingerprints",
        description="Settle the selected cases' trials in this environment (no rendering) and compare "
        "every object's pose and every articulated joint with the fingerprints recorded beside the "
        "catalog (settle_fingerprints.json, with the simulator they were taken with). Prints one row "
        "per case; writes the recorded and current first frames side by side for each drifted case; "
        f"exits 1 when a case moved more than {fp.TOLERANCES['displacement_cm']} cm, tilted more than "
        f"{fp.TOLERANCES['tilt_deg']} degrees or a joint changed more than {fp.TOLERANCES['joint_change']} "
        "(docs/simulator.md).",
    )
    p.add_argument(
        "--select",
        action="append",
        default=[],
        metavar="FILTER",
        help="case id, setting, category, suite, task or 'normal' (repeatable; default: every fingerprinted case)",
    )
    p.add_argument(
        "--trials", type=int, default=None, help="trials per case, from the first (default: all fingerprinted)"
    )
    p.add_argument(
        "--fingerprints",
        type=Path,
        default=None,
        metavar="FILE",
        help=f"fingerprint file (default: {fp.FILE_NAME} beside the catalog)",
    )
    p.add_argument(
        "--pictures",
        type=Path,
        default=None,
        metavar="DIR",
        help="where the first-frame pictures of drifted cases go (default: out/drift/)",
    )
    p.add_argument("--no-pictures", action="store_true", help="do not render the drifted cases' first frames")
    p.set_defaults(run=run_drift)


def run_drift(args) -> int:
    prints = fp.load(args.fingerprints)
    catalog = load_catalog(paths.catalog_path())
    if args.select:
        cases = select_cases(catalog, args.select)
    else:
        cases = [c for c in select_cases(catalog, ["normal"]) if c["id"] in prints["cases"]]
    if not cases:
        raise VProError("the selection is empty")
    if args.trials is not None and args.trials < 1:
        raise VProError(f"--trials must be at least 1, got {args.trials}")
    versions = simulator_versions()
    records = []
    for case in tqdm(cases, desc="drift", unit="case", file=sys.stderr, disable=None):
        entry = prints["cases"].get(case["id"])
        trials = sorted(int(t) for t in entry["trials"]) if entry else [0]
        records += [settle_trial(case, t, prints["wait_steps"]) for t in trials[: args.trials]]
    rows = fp.compare(prints, records)
    print(f"fingerprints: {simulator_label(prints['simulator'])}; this environment: {simulator_label(versions)}")
    print("\n".join(settled.table_lines(rows)))
    drifted = [r for r in rows if r["status"] == "drifted"]
    unchecked = [r for r in rows if r["status"] in ("stale", "missing")]
    if drifted and not args.no_pictures:
        out = args.pictures or paths.out_dir() / "drift"
        by_id = {c["id"]: c for c in cases}
        for row in drifted:
            trial = row["worst_trial"] if row["worst_trial"] is not None else 0
            recorded = prints["cases"][row["case"]]["trials"][str(trial)]
            then, now = first_frames(by_id[row["case"]], trial, recorded, wait_steps=prints["wait_steps"])
            path = Path(out) / f"{row['case'].replace('/', '__')}-trial{trial}.png"
            path.parent.mkdir(parents=True, exist_ok=True)
            write_png(
                path,
                np.concatenate([then, now], axis=1),
                labels=(
                    f"recorded: mujoco {prints['simulator'].get('mujoco')}",
                    f"now: mujoco {versions.get('mujoco')}",
                ),
            )
            print(f"picture: {path}")
    print("\n".join(settled.summary_lines(rows)))
    return 1 if drifted or unchecked else 0
