"""Content hashes and canonical JSON: the one form of each the toolkit persists (catalog, lock,
built scene files, packs, episode rows); standard library only, so packs carry it too."""

from __future__ import annotations

import hashlib
import json
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: Path | str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def canonical_json(obj: Any) -> str:
    """JSON with sorted keys, one-space indent and a final newline: equal data, equal bytes."""
    return json.dumps(obj, sort_keys=True, indent=1, ensure_ascii=False) + "\n"


def mjcf_tree_files(xml_path: Path | str) -> list[Path]:
    """Every file of an MJCF object: its folder (MJCF, meshes, exports, records) and the files its
    MJCF references outside the folder (shared textures), sorted, no duplicates."""
    xml_path = Path(xml_path)
    folder = xml_path.parent.resolve()
    found = {p.resolve() for p in folder.rglob("*") if p.is_file()}
    for element in ET.parse(xml_path).getroot().iter():
        ref = element.get("file")
        if ref:
            found.add((folder / ref).resolve())
    return sorted(found)


def mjcf_tree_sha256(xml_path: Path | str) -> str:
    """One hash of all `mjcf_tree_files`: sha256 over (path relative to the objects root, sha256)
    lines, so a changed, added or missing file changes it."""
    root = Path(xml_path).parent.resolve().parent
    lines = [f"{p.relative_to(root).as_posix()} {sha256_file(p)}\n" for p in mjcf_tree_files(xml_path)]
    return hashlib.sha256("".join(lines).encode()).hexdigest()
