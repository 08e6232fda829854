"""`vpro tasks`: the 40 base tasks, parsed from LIBERO's BDDL."""

from __future__ import annotations

import json

from vpro_assets.core.errors import UnknownIdError
from vpro_assets.libero.bridge import SUITES
from vpro_assets.libero.tasks import get_task, load_tasks


def add_parser(sub) -> None:
    p = sub.add_parser(
        "tasks",
        help="list the 40 base tasks (LIBERO order) with target and receptacle",
        description="List the 40 base tasks of libero_spatial, libero_object, libero_goal and "
        "libero_10 in LIBERO's order, as parsed from LIBERO's BDDL files.",
    )
    p.add_argument("task", nargs="?", help="show one task's full record (key like libero_goal-03, or LIBERO name)")
    p.add_argument("--suite", help="only this suite")
    p.add_argument("--json", action="store_true", help="print JSON records instead of a table")
    p.set_defaults(run=run_tasks)


def run_tasks(args) -> int:
    if args.task:
        print(json.dumps(get_task(args.task).to_json(), indent=2))
        return 0
    tasks = [t for t in load_tasks() if not args.suite or t.suite == args.suite]
    if args.suite and not tasks:
        raise UnknownIdError("suite", args.suite, SUITES)
    if args.json:
        print(json.dumps([t.to_json() for t in tasks], indent=2))
        return 0
    print(f"{'task':<18} {'target':<22} {'receptacle':<22} language")
    for t in tasks:
        print(f"{t.key:<18} {t.target or '-':<22} {t.receptacle or '-':<22} {t.language}")
    return 0
