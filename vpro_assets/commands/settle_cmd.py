"""`vpro settle`: settle the selected cases' starts without rendering and report what the first
policy frame would show (objects off the table or out of view, speed, broken :init relations), and
pose differences against another run's JSON (docs/simulator.md)."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from tqdm import tqdm

from vpro_assets.benchmark import fingerprints as fp
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.libero.bridge import simulator_label, simulator_versions
from vpro_assets.libero.settled import pose_difference
from vpro_assets.rollout.case_env import case_inputs
from vpro_assets.rollout.episode import WAIT_STEPS
from vpro_assets.rollout.settle import SPEED_LIMIT_M_S, settle_trial, trial_problems
from vpro_assets.scene.build import worker_init


def add_parser(sub) -> None:
    p = sub.add_parser(
        "settle",
        help="settle cases' starts (no rendering) and report objects off the table, "
        "out of view, moving, broken :init relations",
        description="For each selected case and trial: seed, reset, set LIBERO's (or the scene "
        "case's) initial state and run the wait steps an episode runs before the policy's first "
        "frame, without rendering; then report per trial the objects that left the table or the "
        "third-person view, the fastest object at the first frame, and the BDDL :init relations "
        "that no longer hold (docs/simulator.md).",
    )
    p.add_argument(
        "--select",
        action="append",
        default=[],
        metavar="FILTER",
        help="case id, setting, category, suite, task or 'normal' (repeatable; default: normal)",
    )
    p.add_argument("--trials", type=int, default=3, help="trials per case, from the first (default 3)")
    p.add_argument(
        "--wait-steps", type=int, default=WAIT_STEPS, help=f"no-op steps before the first frame (default {WAIT_STEPS})"
    )
    p.add_argument(
        "-j", "--jobs", type=int, default=1, help="processes settling cases in parallel (default 1; ~3 GB each)"
    )
    p.add_argument("--json", type=Path, metavar="OUT.json", help="write every trial's measurements (poses included)")
    p.add_argument(
        "--compare",
        type=Path,
        metavar="OTHER.json",
        help="a --json file of another run (e.g. another MuJoCo): report pose differences per case",
    )
    p.add_argument(
        "--fingerprints",
        type=Path,
        nargs="?",
        const=fp.fingerprints_path(),
        default=None,
        metavar="FILE",
        help=f"record the settled poses as the cases' fingerprints (default file: {fp.FILE_NAME} beside "
        "the catalog; cases already there under the same simulator are kept, and cases whose trials are "
        "all there with the same inputs are not settled again, so an interrupted run resumes; the file "
        "is written after every case)",
    )
    p.set_defaults(run=run_settle)


def read_settle_json(path: Path) -> dict:
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise VProError(f"{path}: not a readable settle JSON ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("records"), list):
        raise VProError(f"{path}: not a `vpro settle --json` file (no 'records' list)")
    return data


def run_settle(args) -> int:
    if args.trials < 1:
        raise VProError(f"--trials must be at least 1, got {args.trials}")
    if args.jobs < 1:
        raise VProError(f"--jobs must be at least 1, got {args.jobs}")
    if args.wait_steps < 0:
        raise VProError(f"--wait-steps must be at least 0, got {args.wait_steps}")
    other = read_settle_json(args.compare) if args.compare else None
    cases = select_cases(load_catalog(paths.catalog_path()), args.select or ["normal"])
    if not cases:
        raise VProError("the selection is empty")
    for case in cases:
        if args.trials > len(case["trial_seeds"]):
            raise VProError(f"--trials {args.trials}: case {case['id']} has {len(case['trial_seeds'])} trials")
    versions = simulator_versions()
    base = _fingerprint_base(args.fingerprints, versions, args.wait_steps)
    print(f"settling {len(cases)} case(s) under {simulator_label(versions)}, {args.wait_steps} wait steps")
    print("| case | trial | off table | out of view | fastest (m/s) | :init relations not holding |")
    print("|---|---|---|---|---|---|")
    records = []
    for case_records in _settle_cases(cases, args.trials, args.wait_steps, args.jobs, base):
        records += case_records
        for rec in case_records:  # as each case finishes: a run of hours shows its findings as it goes
            print(_table_row(rec), flush=True)
        if args.fingerprints:
            base = fp.build(case_records, versions, args.wait_steps, base)
            fp.write(args.fingerprints, base)
    bad = sum(bool(trial_problems(rec)) for rec in records)
    print(
        f"{bad} of {len(records)} trial(s) start with an object off the table or out of view, moving faster "
        f"than {SPEED_LIMIT_M_S} m/s, or an :init relation broken"
    )
    if other is not None:
        _print_comparison(records, other, versions)
    if args.json:
        write_text_atomic(
            args.json,
            json.dumps({"simulator": versions, "wait_steps": args.wait_steps, "records": records}, sort_keys=True)
            + "\n",
        )
        print(f"wrote {args.json}")
    if args.fingerprints:
        print(f"wrote fingerprints of {len(records)} trial(s) to {args.fingerprints}")
    return 0


def _table_row(rec: dict) -> str:
    objs = rec["objects"]
    fastest = max(objs.items(), key=lambda kv: kv[1]["speed"]) if objs else ("-", {"speed": 0.0})
    return (
        f"| {rec['case']} | {rec['trial']} | {', '.join(n for n, o in objs.items() if o['left_table']) or '-'} "
        f"| {', '.join(n for n, o in objs.items() if o['out_of_view']) or '-'} "
        f"| {fastest[1]['speed']:.3f} {fastest[0] if fastest[1]['speed'] > SPEED_LIMIT_M_S else ''} "
        f"| {'; '.join(r['relation'] for r in rec['relations'] if not r['holds']) or '-'} |"
    )


def _fingerprint_base(path: Path | None, versions: dict, wait_steps: int) -> dict | None:
    """The fingerprints already recorded in `path` under this simulator and wait (None: start afresh)."""
    if not path or not Path(path).exists():
        return None
    base = fp.load(path)
    return base if base["simulator"] == dict(sorted(versions.items())) and base["wait_steps"] == wait_steps else None


def _settle_case(case: dict, trials: int, wait_steps: int) -> list[dict]:
    return [settle_trial(case, t, wait_steps) for t in range(trials)]


def _settle_cases(
    cases: list[dict], trials: int, wait_steps: int, jobs: int, base: dict | None
) -> Iterator[list[dict]]:
    """Each case's settled trials, in catalog order, `jobs` processes in parallel. A case whose first
    `trials` trials are already in `base` with its current inputs is skipped (resuming a run)."""
    todo = []
    for case in cases:
        entry = (base or {}).get("cases", {}).get(case["id"])
        if not (
            entry and all(str(t) in entry["trials"] for t in range(trials)) and entry["inputs"] == case_inputs(case)
        ):
            todo.append(case)
    if len(todo) < len(cases):
        print(
            f"{len(cases) - len(todo)} case(s) already fingerprinted under this simulator; settling {len(todo)}",
            file=sys.stderr,
        )
    bar = tqdm(total=len(todo), desc="settle", unit="case", file=sys.stderr, disable=None)
    if jobs <= 1:
        for case in todo:
            yield _settle_case(case, trials, wait_steps)
            bar.update(1)
    else:
        with ProcessPoolExecutor(max_workers=jobs, initializer=worker_init) as pool:
            for done in pool.map(_settle_case, todo, [trials] * len(todo), [wait_steps] * len(todo)):
                yield done
                bar.update(1)
    bar.close()


def _print_comparison(records: list[dict], other: dict, versions: dict) -> None:
    theirs = {(r["case"], r["trial"]): r for r in other["records"]}
    print(
        f"\npose differences: this run ({simulator_label(versions)}) against "
        f"{simulator_label(other.get('simulator', {}))}; largest over the trials compared"
    )
    print("| case | trials | displacement (cm) | object | tilt change (deg) | object | joint change |")
    print("|---|---|---|---|---|---|---|")
    per_case: dict[str, list[dict]] = {}
    for rec in records:
        if (rec["case"], rec["trial"]) in theirs:
            per_case.setdefault(rec["case"], []).append(pose_difference(rec, theirs[(rec["case"], rec["trial"])]))
    for cid, diffs in per_case.items():
        d = max(diffs, key=lambda x: x["displacement_cm"])
        t = max(diffs, key=lambda x: x["tilt_deg"])
        j = max(diffs, key=lambda x: x["joint_change"])
        print(
            f"| {cid} | {len(diffs)} | {d['displacement_cm']:.2f} | {d['object'] or '-'} | {t['tilt_deg']:.1f} "
            f"| {t['tilt_object'] or '-'} | {j['joint_change']:.4f} {j['joint'] or ''} |"
        )
    missing = len(records) - sum(len(v) for v in per_case.values())
    if missing:
        print(f"{missing} trial(s) not in the other file")
