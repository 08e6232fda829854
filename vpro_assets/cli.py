"""`vpro`: the toolkit's command line. Each subcommand lives in the module of its concept and
registers itself through `add_parser(subparsers)`; this file only wires them and turns
VProError into a one-line message and exit code 2."""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys

from vpro_assets.core import mjlog
from vpro_assets.core.errors import VProError

# Modules that contribute subcommands, in the order `vpro --help` lists them.
COMMAND_MODULES = (
    "vpro_assets.commands.tasks_cmd",
    "vpro_assets.commands.taxonomy_cmd",
    "vpro_assets.commands.catalog_cmd",
    "vpro_assets.commands.env_cmd",
    "vpro_assets.commands.build_cmd",
    "vpro_assets.commands.validate_cmd",
    "vpro_assets.commands.pack_cmd",
    "vpro_assets.commands.import_cmd",
    "vpro_assets.commands.eval_cmd",
    "vpro_assets.commands.certify_cmd",
    "vpro_assets.commands.report_cmd",
    "vpro_assets.commands.preview_cmd",
    "vpro_assets.commands.bench_cmd",
    "vpro_assets.commands.settle_cmd",
    "vpro_assets.commands.drift_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vpro",
        description="LIBERO-VPro: closed-loop visual robustness benchmark on LIBERO "
        "(4 dimensions, 12 categories, 96 settings, 3,296 cases over 40 tasks).",
        epilog="Ids: tasks are <suite>-<index> (libero_goal-03); settings are vpro/<category>/<name>-v<N>; "
        "cases are <task>/<category>/<name>-v<N>. `vpro COMMAND --help` explains each command.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = (logging.WARNING, logging.INFO, logging.DEBUG)[min(args.verbose, 2)]
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    if not args.verbose:
        # robosuite warns about its private macro file on every import; not the user's concern.
        logging.getLogger("robosuite").setLevel(logging.ERROR)
        os.environ.setdefault("PYTHONWARNINGS", "ignore")
    mjlog.route_warnings()
    try:
        return int(args.run(args) or 0)
    except VProError as exc:
        print(f"vpro {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"vpro {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
