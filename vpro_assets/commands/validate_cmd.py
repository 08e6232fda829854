"""`vpro validate`: built scene cases checked (MJCF, LIBERO env, initial states at rest)."""

from __future__ import annotations

import sys
from pathlib import Path

from tqdm import tqdm

from vpro_assets.commands.build_cmd import SELECT_HELP, scene_cases
from vpro_assets.scene.validate import validate


def add_parser(sub) -> None:
    v = sub.add_parser(
        "validate",
        help="check built scene cases: MJCF, LIBERO env, initial states at rest",
        description="For each selected built scene case: the BDDL parses and keeps the task; "
        "generated objects compile; LIBERO builds the env; the scene MJCF compiles with no MuJoCo "
        "warning; every initial state loads; one second of zero actions leaves every object at rest.",
    )
    v.add_argument("--select", action="append", metavar="FILTER", help=SELECT_HELP)
    v.add_argument("-j", "--jobs", type=int, default=1, help="worker processes (default 1; a case takes ~10 s)")
    v.add_argument("--catalog", type=Path, default=None, help="catalog to read (default: catalog.json)")
    v.set_defaults(run=run_validate)


def run_validate(args) -> int:
    cases = scene_cases(args)
    bad = 0
    for v in validate(cases, args.jobs):
        bad += not v.ok
        lines = (
            [f"OK     {v.case_id} ({v.seconds:.1f} s)"] if v.ok else [f"FAILED {v.case_id}: {p}" for p in v.problems]
        )
        for line in lines:
            tqdm.write(line, file=sys.stdout)  # above the progress bar, not inside it
    print(f"{len(cases) - bad} of {len(cases)} case(s) valid", file=sys.stderr)
    return 1 if bad else 0
