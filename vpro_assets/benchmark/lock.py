"""Recorded artifact hashes of built scene cases: `scene_artifacts.lock.json` (committed).

Why a lock file: the catalog must rebuild byte for byte on a clean clone, where building every
scene case (about an hour on two cores) is not affordable. So `vpro build` records the sha256 of
every file it writes here; `vpro catalog build` reads this file (never out/) to fill each scene
case's `artifacts` and `init_states.file`; `vpro catalog verify` checks the catalog against a
rebuild always, and with `--artifacts` also checks every file built in out/ against the recorded
hashes (files not built are reported as such, not as errors). A case's generated objects (deformed
targets, recoloured distractors) are recorded as one tree hash per object folder
(`core.hashing.mjcf_tree_sha256`, key `objects/<name>/`): every mesh, hull, export and shared
texture, without listing the ~50 hull files of each deformed object in the catalog. A full check is
`vpro build -j 2 && vpro catalog verify --artifacts` (see README).
"""

from __future__ import annotations

import json
from pathlib import Path

from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.hashing import canonical_json, mjcf_tree_sha256, sha256_file

LOCK_NAME = "scene_artifacts.lock.json"


def lock_path() -> Path:
    return paths.REPO_ROOT / LOCK_NAME


def load() -> dict[str, dict]:
    path = lock_path()
    if not path.is_file():
        return {}
    return json.loads(path.read_text(encoding="utf-8"))


def record(results, catalog_ids: set[str] | None = None) -> None:
    """Merge the hashes of built (or confirmed unchanged) cases into the lock file; with
    `catalog_ids` (the catalog's scene cases), drop entries of cases the catalog no longer has
    (a renamed or re-versioned setting's old cases)."""
    data = load()
    if catalog_ids is not None:
        data = {cid: entry for cid, entry in data.items() if cid in catalog_ids}
    if not results and catalog_ids is None:
        return
    trees: dict[str, str] = {}  # objects are shared by cases: hash each folder once
    for r in results:
        entry = {"files": dict(sorted(r.files.items()))}
        objects = {}
        for name in _generated_objects(r.case_id):
            if name not in trees:
                trees[name] = _object_tree(name)
            objects[name] = trees[name]
        if objects:
            entry["objects"] = objects
        data[r.case_id] = entry
    write_text_atomic(lock_path(), canonical_json(data))


def _generated_objects(case_id: str) -> list[str]:
    meta = json.loads((paths.scene_case_dir(case_id) / paths.SCENE_META).read_text())
    return sorted(meta.get("generated_objects", {}))


def _object_xml(name: str) -> Path:
    return paths.objects_root() / name / f"{name}.xml"


def _object_tree(name: str) -> str:
    return mjcf_tree_sha256(_object_xml(name))


def case_artifacts(case_id: str, entry: dict) -> dict:
    """The catalog's `artifacts` of a case: path relative to out/ -> sha256 (a folder, ending in
    '/', -> the tree hash of a generated object)."""
    out = {f"scene/{case_id}/{name}": digest for name, digest in sorted(entry["files"].items())}
    out.update({f"objects/{name}/": digest for name, digest in sorted(entry.get("objects", {}).items())})
    return out


def init_file(case_id: str, entry: dict) -> str | None:
    return next((f"scene/{case_id}/{n}" for n in sorted(entry["files"]) if n.endswith(".pruned_init")), None)


def check_built(catalog: dict) -> tuple[list[str], int, int]:
    """(differences, files checked, files not built) of out/ against the catalog's artifact hashes."""
    diffs, checked, missing = [], 0, 0
    trees: dict[str, str] = {}
    for case in catalog["cases"]:
        for rel, digest in case.get("artifacts", {}).items():
            folder = rel.endswith("/")
            path = _object_xml(rel.rstrip("/").rsplit("/", 1)[1]) if folder else paths.out_dir() / rel
            if not path.is_file():
                missing += 1
                continue
            checked += 1
            if folder and rel not in trees:
                trees[rel] = _object_tree(path.stem)
            actual = trees[rel] if folder else sha256_file(path)
            if actual != digest:
                diffs.append(
                    f"case {case['id']}: {rel} has sha256 {actual[:16]}..., the catalog records {digest[:16]}..."
                )
    return diffs, checked, missing
