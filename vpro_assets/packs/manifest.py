"""The pack manifest: every file's sha256 and size, the pack's version and provenance.

`manifest.json` is canonical JSON (sorted keys) and lists every other file of the pack by its
relative POSIX path; verification recomputes the hashes and names each missing, extra or changed
file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from vpro_assets.core.errors import VProError
from vpro_assets.core.hashing import canonical_json, sha256_file

MANIFEST = "manifest.json"
PACK_FORMAT = "vpro-pack"
PACK_SCHEMA_VERSION = 1


class PackError(VProError):
    """A pack that is unreadable, of a newer schema, or does not match its manifest."""


def file_entries(root: Path) -> dict[str, dict]:
    """{relative path: {sha256, size}} of every file under `root` except the manifest and Python's
    bytecode caches (a fork importing the pack's modules writes `__pycache__/` beside them)."""
    entries = {}
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        if "__pycache__" in path.relative_to(root).parts:
            continue
        rel = path.relative_to(root).as_posix()
        if rel != MANIFEST:
            entries[rel] = {"sha256": sha256_file(path), "size": path.stat().st_size}
    return entries


def dumps(manifest: dict) -> str:
    return canonical_json(manifest)


def read_manifest(root: Path) -> dict:
    path = Path(root) / MANIFEST
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PackError(f"{root}: no {MANIFEST}; not a LIBERO-VPro pack") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PackError(f"{path}: unreadable manifest ({exc})") from None
    if not isinstance(data, dict) or data.get("pack_format") != PACK_FORMAT:
        raise PackError(
            f"{path}: not a LIBERO-VPro pack manifest (pack_format {data.get('pack_format') if isinstance(data, dict) else None!r})"
        )
    version = data.get("schema_version")
    if not isinstance(version, int) or version > PACK_SCHEMA_VERSION:
        raise PackError(
            f"{path}: pack schema_version {version!r} is newer than this toolkit reads "
            f"({PACK_SCHEMA_VERSION}); upgrade libero-vpro"
        )
    if not isinstance(data.get("files"), dict):
        raise PackError(f"{path}: manifest has no 'files' table")
    return data


@dataclass
class Mismatch:
    missing: list[str] = field(default_factory=list)
    extra: list[str] = field(default_factory=list)
    changed: list[str] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.missing or self.extra or self.changed)

    def lines(self) -> list[str]:
        return (
            [f"missing: {p}" for p in self.missing]
            + [f"extra: {p}" for p in self.extra]
            + [f"changed: {p}" for p in self.changed]
        )


def compare(manifest: dict, root: Path) -> Mismatch:
    actual = file_entries(Path(root))
    listed = manifest["files"]
    return Mismatch(
        missing=sorted(set(listed) - set(actual)),
        extra=sorted(set(actual) - set(listed)),
        changed=sorted(p for p in set(listed) & set(actual) if listed[p] != actual[p]),
    )
