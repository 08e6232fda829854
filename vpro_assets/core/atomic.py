"""Atomic writes: a reader sees the old file (or folder) or the new one, never half of one."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path


def write_bytes_atomic(path: Path | str, data: bytes) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; artifacts and packs are meant to be shared
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text_atomic(path: Path | str, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def publish_dir(staging: Path | str, final: Path | str) -> None:
    """Move a finished folder into place as a whole, replacing what is there.

    Outputs are content-addressed, so when another process publishes the same folder at the same
    time its copy has the same bytes: whichever ends up in place is the right one.
    """
    staging, final = Path(staging), Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    old = final.with_name(f".old-{final.name}-{os.getpid()}")
    for _attempt in range(3):
        try:
            if final.exists():
                os.replace(final, old)
            os.replace(staging, final)
            break
        except OSError:  # `final` reappeared between the two renames (another writer published it)
            continue
    else:
        if not final.is_dir():
            raise OSError(f"could not publish {staging} as {final}")
        shutil.rmtree(staging, ignore_errors=True)  # another writer's identical folder is in place
    shutil.rmtree(old, ignore_errors=True)
