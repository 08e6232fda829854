"""`vpro taxonomy`: the 96 settings with their parameters; the generated docs/taxonomy.md."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.taxonomy_doc import write_taxonomy_doc


def add_parser(sub) -> None:
    p = sub.add_parser(
        "taxonomy",
        help="list dimensions, categories and settings; write docs/taxonomy.md",
        description="Print the 96 settings with their parameters, or write the generated "
        "taxonomy document (settings, parameters, applicability rules, case counts per suite).",
    )
    p.add_argument("--category", help="only this category's settings")
    p.add_argument("--json", action="store_true", help="print the settings as JSON")
    p.add_argument("--doc", type=Path, metavar="FILE", help="write the Markdown taxonomy document to FILE")
    p.set_defaults(run=run_taxonomy)


def run_taxonomy(args) -> int:
    if args.doc:
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
