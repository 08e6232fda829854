"""Deterministic tar.gz archives of a pack folder, and safe extraction.

Same folder, same bytes: entries sorted by path, every timestamp 0, owner root, modes 0644/0755,
gzip header without file name or time. Extraction refuses absolute paths, `..` and links.
"""

from __future__ import annotations

import gzip
import io
import tarfile
from pathlib import Path

from vpro_assets.core.atomic import write_bytes_atomic
from vpro_assets.packs.manifest import PackError

ARCHIVE_SUFFIX = ".tar.gz"


def _info(name: str, size: int | None) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.mtime = 0
    info.uid = info.gid = 0
    info.uname = info.gname = ""
    if size is None:
        info.type, info.mode = tarfile.DIRTYPE, 0o755
    else:
        info.size, info.mode = size, 0o644
    return info


def write_archive(folder: Path, archive: Path, top: str) -> None:
    """Archive `folder` under the single top folder `top` (named by content, not by the archive's
    file name, so the same pack written to two names has the same bytes)."""
    folder = Path(folder)
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w", format=tarfile.PAX_FORMAT) as tar:
        tar.addfile(_info(top, None))
        for path in sorted(folder.rglob("*"), key=lambda p: p.relative_to(folder).as_posix()):
            name = f"{top}/{path.relative_to(folder).as_posix()}"
            if path.is_dir():
                tar.addfile(_info(name, None))
            else:
                data = path.read_bytes()
                tar.addfile(_info(name, len(data)), io.BytesIO(data))
    packed = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=packed, mtime=0, compresslevel=6) as gz:
        gz.write(raw.getvalue())
    write_bytes_atomic(archive, packed.getvalue())


def extract_archive(archive: Path, dest: Path) -> Path:
    """Extract into `dest` and return the pack folder inside it."""
    try:
        with tarfile.open(archive, mode="r:gz") as tar:
            members = tar.getmembers()
            for m in members:
                parts = Path(m.name).parts
                if m.name.startswith("/") or ".." in parts or not (m.isfile() or m.isdir()):
                    raise PackError(f"{archive}: unsafe entry {m.name!r} (absolute, '..' or a link)")
            tops = {Path(m.name).parts[0] for m in members}
            if len(tops) != 1:
                raise PackError(f"{archive}: expected one top folder, found {sorted(tops)[:5]}")
            tar.extractall(dest, members=members, filter="data")
    except (tarfile.TarError, EOFError, OSError, gzip.BadGzipFile) as exc:
        raise PackError(f"{archive}: damaged or truncated archive ({exc})") from None
    return Path(dest) / tops.pop()
