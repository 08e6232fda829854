"""`vpro catalog build|verify|show`."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from vpro_assets.benchmark import certificate as cert
from vpro_assets.benchmark.catalog import build_catalog, find_case, load_catalog, verify_catalog, write_catalog
from vpro_assets.benchmark.lock import check_built
from vpro_assets.core import paths

MAX_SHOWN = 20


def add_parser(sub) -> None:
    p = sub.add_parser(
        "catalog",
        help="build, verify or inspect catalog.json",
        description="The catalog lists every case (task x setting) with its parameters, trial "
        "seeds, initial-state references and artifact hashes.",
    )
    csub = p.add_subparsers(dest="catalog_command", metavar="ACTION", required=True)
    b = csub.add_parser(
        "build",
        help="rebuild the catalog from LIBERO and the taxonomy and write it",
        description="Rebuild the catalog from LIBERO's task files and the taxonomy; the output is "
        "byte-identical for identical inputs.",
    )
    b.add_argument("--out", type=Path, default=None, help="where to write (default: the repository's catalog.json)")
    b.set_defaults(run=run_build)
    v = csub.add_parser(
        "verify",
        help="rebuild in memory and compare with the committed catalog",
        description="Rebuild in memory and compare with the catalog file; on a difference, name "
        "the case and field and exit 1.",
    )
    v.add_argument("--catalog", type=Path, default=None, help="catalog to check (default: catalog.json)")
    v.add_argument(
        "--artifacts",
        action="store_true",
        help="also check every scene artifact built in out/ against the sha256 the catalog records",
    )
    v.add_argument(
        "--certificate",
        type=Path,
        default=None,
        help="solvability certificate to check against the catalog (default: solvability.json, when present)",
    )
    v.set_defaults(run=run_verify)
    s = csub.add_parser("show", help="print one case's record", description="Print one case (or Normal baseline).")
    s.add_argument("case", help="case id, e.g. libero_goal-03/camera_staleness/wrist-delay2-v1")
    s.add_argument("--catalog", type=Path, default=None, help="catalog to read (default: catalog.json)")
    s.set_defaults(run=run_show)


def run_build(args) -> int:
    out = args.out or paths.catalog_path()
    catalog = build_catalog()
    write_catalog(catalog, out)
    t = catalog["header"]["totals"]
    print(
        f"wrote {out}: {t['cases']} cases, {t['settings']} settings, {t['categories']} categories, "
        f"{t['dimensions']} dimensions, {t['tasks']} tasks",
        file=sys.stderr,
    )
    return 0


def run_verify(args) -> int:
    path = args.catalog or paths.catalog_path()
    committed, diffs = verify_catalog(path)
    if getattr(args, "artifacts", False):
        artifact_diffs, checked, missing = check_built(committed)
        diffs = diffs + artifact_diffs
        print(
            f"artifacts: {checked} built file(s) checked against recorded sha256, {missing} not built in "
            f"{paths.out_dir()}",
            file=sys.stderr,
        )
    diffs = diffs + certificate_problems(committed, path, getattr(args, "certificate", None))
    if diffs:
        for line in diffs[:MAX_SHOWN]:
            print(f"DIFFERS {line}", file=sys.stderr)
        if len(diffs) > MAX_SHOWN:
            print(f"... and {len(diffs) - MAX_SHOWN} more differences", file=sys.stderr)
        print(f"{path}: {len(diffs)} difference(s) from a rebuild", file=sys.stderr)
        return 1
    t = committed["header"]["totals"]
    print(
        f"{path}: OK, identical to a rebuild ({t['cases']} cases, {t['settings']} settings, "
        f"{t['categories']} categories, {t['dimensions']} dimensions, {t['tasks']} tasks)"
    )
    return 0


def certificate_problems(catalog: dict, catalog_file: Path, given: Path | None) -> list[str]:
    """Why the solvability certificate does not belong to this catalog (none: it does, or there is none)."""
    path = given or cert.certificate_path()
    if given is None and not path.is_file():
        return []
    problems = cert.check(cert.load(path), catalog, catalog_file)
    if problems:
        return [f"{path}: {p}" for p in problems] + [f"{path}: refused; certify again with `vpro certify --resume`"]
    certified, total = cert.coverage(cert.load(path), catalog)
    print(f"{path}: belongs to this catalog ({certified} of {total} certifiable cases certified)", file=sys.stderr)
    return []


def run_show(args) -> int:
    catalog = load_catalog(args.catalog or paths.catalog_path())
    print(json.dumps(find_case(catalog, args.case), indent=2, sort_keys=True))
    return 0
