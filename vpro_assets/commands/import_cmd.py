"""`vpro import`: copy a pack into a LIBERO fork's checkout."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from vpro_assets.packs.manifest import PackError
from vpro_assets.packs.writer import open_pack, verify_pack


def add_parser(sub) -> None:
    i = sub.add_parser(
        "import",
        help="copy a pack into a LIBERO fork's checkout",
        description="Copy a pack into a LIBERO checkout: the pack goes to FORK_DIR/vpro_packs/<name>/ and its "
        "BDDL and initial-state files into the fork's libero/libero/bddl_files/<suite>/ and init_files/<suite>/. "
        "Register its objects and suites with `vpro_libero_fork.register(<copied pack>)` in the fork.",
    )
    i.add_argument("pack", type=Path, help="pack folder or archive")
    i.add_argument("--into", type=Path, required=True, metavar="FORK_DIR", help="root of the LIBERO checkout")
    i.set_defaults(run=run_import)


def _fork_libero_root(fork: Path) -> Path:
    for candidate in (fork / "libero" / "libero", fork):
        if (candidate / "bddl_files").is_dir() and (candidate / "init_files").is_dir():
            return candidate
    raise PackError(f"{fork}: not a LIBERO checkout (no libero/libero/bddl_files and init_files)")


def run_import(args) -> int:
    fork_root = _fork_libero_root(args.into)
    with tempfile.TemporaryDirectory(prefix="vpro-import-") as tmp:
        _, mismatch = verify_pack(args.pack)
        if mismatch:
            raise PackError(f"{args.pack}: does not match its manifest ({'; '.join(mismatch.lines()[:5])})")
        src = open_pack(args.pack, Path(tmp))
        name = args.pack.name.removesuffix(".tar.gz")
        dest = args.into / "vpro_packs" / name
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(src, dest)
    for kind in ("bddl_files", "init_files"):
        for suite_dir in sorted((dest / kind).iterdir()):
            shutil.copytree(suite_dir, fork_root / kind / suite_dir.name, dirs_exist_ok=True)
    print(f"copied the pack to {dest} and its suites into {fork_root}/bddl_files and init_files")
    print(
        f"in the fork: import sys; sys.path.insert(0, {str(dest)!r}); import vpro_libero_fork; "
        f"vpro_libero_fork.register({str(dest)!r})"
    )
    return 0
