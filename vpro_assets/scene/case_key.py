"""What a built scene case depends on, as one hash, and whether the files built for it are current.

The input hash covers the toolkit's build version, the generator's name and version (and its
revision for the case, where it has one: `plugins`), the case record, the base task's BDDL and
initial states, the distractor pool table, the library versions and the BDDL templates; computing
it needs no simulation, so a warm rebuild is quick.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from vpro_assets.benchmark.catalog import library_versions
from vpro_assets.core import paths
from vpro_assets.core.hashing import canonical_json, sha256_file
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene import bddl_doc, plugins
from vpro_assets.scene import pool as pool_mod

BUILD_VERSION = 3  # bump when what a build writes changes without a generator's version changing


def input_hash(case: dict, generator: plugins.Generator) -> str:
    task = get_task(case["task"])
    h = hashlib.sha256()
    for part in (
        f"build-v{BUILD_VERSION}",
        f"{generator.name}-v{generator.version}",
        canonical_json({k: case[k] for k in ("id", "setting", "params", "trial_seeds", "task")}),
        libero_bridge.bddl_path(task.suite, task.name).read_bytes().hex(),
        libero_bridge.init_state_path(task.suite, task.name).read_bytes().hex(),
        canonical_json({k: v.to_json() for k, v in pool_mod.pool().items()}),
        canonical_json(library_versions()),
        (Path(bddl_doc.TEMPLATE_DIR) / bddl_doc.SCENE_TEMPLATE).read_text(),
        (Path(bddl_doc.TEMPLATE_DIR) / bddl_doc.REGION_TEMPLATE).read_text(),
    ):
        h.update(part.encode())
        h.update(b"\0")
    revision = generator.revision_of(case)
    if revision:  # only then: the hash of every case without one stays as it was
        h.update(f"revision-{revision}".encode())
        h.update(b"\0")
    return h.hexdigest()


def current_meta(case_id: str, key: str) -> dict | None:
    """The meta.json of the built case if it was built from inputs with hash `key` and its files
    are intact; None otherwise (the case must be built)."""
    meta_path = paths.scene_case_dir(case_id) / paths.SCENE_META
    if not meta_path.is_file():
        return None
    try:
        meta = json.loads(meta_path.read_text())
    except json.JSONDecodeError:
        return None
    if meta.get("input_hash") != key:
        return None
    for rel, digest in meta.get("files", {}).items():
        path = paths.scene_case_dir(case_id) / rel
        if not path.is_file() or sha256_file(path) != digest:
            return None
    return meta
