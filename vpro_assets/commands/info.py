"""`vpro tasks` and `vpro taxonomy`: what the benchmark contains."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.libero.tasks import get_task
from vpro_assets.libero.tasks import load_tasks


def add_parser(sub) -> None:
    p = sub.add_parser("tasks", help="list the 40 base tasks (LIBERO order) with target and receptacle",
                       description="List the 40 base tasks of libero_spatial, libero_object, libero_goal and "
                       "libero_10 in LIBERO's order, as parsed from LIBERO's BDDL files.")
    p.add_argument("task", nargs="?", help="show one task's full record (key like libero_goal-03, or LIBERO name)")
    p.add_argument("--suite", help="only this suite")
    p.add_argument("--json", action="store_true", help="print JSON records instead of a table")
    p.set_defaults(run=run_tasks)

    p = sub.add_parser("taxonomy", help="list dimensions, categories and settings; write docs/taxonomy.md",
                       description="Print the 96 settings with their parameters, or write the generated "
                       "taxonomy document (settings, parameters, applicability rules, case counts per suite).")
    p.add_argument("--category", help="only this category's settings")
    p.add_argument("--json", action="store_true", help="print the settings as JSON")
    p.add_argument("--doc", type=Path, metavar="FILE", help="write the Markdown taxonomy document to FILE")
    p.set_defaults(run=run_taxonomy)


def run_tasks(args) -> int:
    if args.task:
        print(json.dumps(get_task(args.task).to_json(), indent=2))
        return 0
    tasks = [t for t in load_tasks() if not args.suite or t.suite == args.suite]
    if args.suite and not tasks:
        from vpro_assets.core.errors import UnknownIdError
        from vpro_assets.libero.bridge import SUITES

        raise UnknownIdError("suite", args.suite, SUITES)
    if args.json:
        print(json.dumps([t.to_json() for t in tasks], indent=2))
        return 0
    print(f"{'task':<18} {'target':<22} {'receptacle':<22} language")
    for t in tasks:
        print(f"{t.key:<18} {t.target or '-':<22} {t.receptacle or '-':<22} {t.language}")
    return 0


def run_taxonomy(args) -> int:
    if args.doc:
        from vpro_assets.benchmark.taxonomy_doc import write_taxonomy_doc

        write_taxonomy_doc(args.doc)
        print(f"wrote {args.doc}", file=sys.stderr)
        return 0
    settings = tx.settings_of(args.category) if args.category else tx.SETTINGS
    if args.json:
        print(json.dumps([s.to_json() for s in settings], indent=2, sort_keys=True))
        return 0
    for cat in tx.CATEGORIES:
        rows = [s for s in settings if s.category == cat.id]
        if rows:
            print(f"\n{cat.title} [{cat.dimension}; {cat.indicator}; {len(rows)} settings]")
            for s in rows:
                params = ", ".join(f"{k}={v}" for k, v in s.params if v is not None and k != "rule")
                print(f"  {s.id:<62} {params}")
    return 0
