"""`vpro pack`, `vpro pack verify`: frozen scene packs for LIBERO forks."""

from __future__ import annotations

import sys
from pathlib import Path

from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import describe, select_cases
from vpro_assets.core import paths
from vpro_assets.packs.manifest import PackError
from vpro_assets.packs.writer import verify_pack, write_pack


def add_parser(sub) -> None:
    p = sub.add_parser(
        "pack",
        help="write a versioned pack of cases for LIBERO forks, or verify one",
        description="`vpro pack --select FILTER --out DIR|FILE.tar.gz` writes the selected cases (all by default) in "
        "LIBERO's layout (bddl_files/, init_files/, assets/), each case's spec, the taxonomy and a manifest with "
        "the sha256 and size of every file. Same selection, same bytes. `vpro pack verify PACK` checks every "
        "file against the manifest and names each missing, extra or changed one (exit 1 on any).",
    )
    p.add_argument("action", nargs="?", choices=["verify"], help="`verify PACK`: check a pack against its manifest")
    p.add_argument("pack", nargs="?", type=Path, help="the pack folder or archive to verify")
    p.add_argument(
        "--select",
        action="append",
        metavar="FILTER",
        help="case id, setting, category, dimension, suite or task (repeatable; none means all)",
    )
    p.add_argument("--out", type=Path, help="pack folder to write, or FILE.tar.gz for an archive")
    p.add_argument("--catalog", type=Path, default=None, help="catalog to read (default: catalog.json)")
    p.set_defaults(run=run_pack)


def run_pack(args) -> int:
    if args.action == "verify":
        if args.pack is None:
            raise PackError("`vpro pack verify` needs the pack folder or archive to check")
        manifest, mismatch = verify_pack(args.pack)
        for line in mismatch.lines():
            print(line, file=sys.stderr)
        if mismatch:
            print(f"{args.pack}: does not match its manifest", file=sys.stderr)
            return 1
        print(
            f"{args.pack}: OK, {len(manifest['files'])} files match the manifest "
            f"({len(manifest['cases'])} cases, pack_id {manifest['pack_id'][:12]})"
        )
        return 0
    if args.out is None:
        raise PackError("`vpro pack` needs --out DIR or --out FILE.tar.gz")
    catalog_file = args.catalog or paths.catalog_path()
    catalog = load_catalog(catalog_file)
    cases = select_cases(catalog, args.select)
    out = write_pack(cases, args.out, catalog, catalog_file)
    print(f"wrote {out}: {describe(cases)}")
    return 0
