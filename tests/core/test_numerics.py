"""numpy's kernels are pinned when `vpro_assets` is imported, and a build refuses to run under others:
the OpenBLAS core decides the last bits of every settled initial state (docs/simulator.md, "Numerics")."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from conftest import BUILT_SCENE_CASE

PROBE = """
import sys
if sys.argv[1] == "numpy-first":
    import numpy
import vpro_assets
from threadpoolctl import threadpool_info
from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.scene.build import build_case

print([lib["architecture"] for lib in threadpool_info() if lib["internal_api"] == "openblas"])
try:
    build_case(find_case(load_catalog(paths.catalog_path()), sys.argv[2]), force=True)
except VProError as exc:
    print("refused:", exc)
"""


def _probe(order: str, env: dict, tmp_path) -> list[str]:
    """Lines printed by a fresh process: the OpenBLAS core numpy loaded, then whether a build ran."""
    clean = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    done = subprocess.run(
        [sys.executable, "-c", PROBE, order, BUILT_SCENE_CASE],
        env=clean | env | {"VPRO_OUT": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.splitlines()


def test_numpy_loaded_under_another_core_is_refused_naming_the_case_and_the_core(tmp_path):
    lines = _probe("numpy-first", {"OPENBLAS_CORETYPE": "Prescott"}, tmp_path)
    assert lines[0] == "['Prescott']"  # numpy's OpenBLAS (scipy's loads later, under the same setting)
    assert lines[1].startswith(f"refused: building {BUILT_SCENE_CASE}: OpenBLAS (")
    assert "runs its Prescott core, not Haswell" in lines[1] and "OPENBLAS_CORETYPE='Haswell'" in lines[1]
    assert not (tmp_path / "scene").exists()  # nothing written


def test_importing_the_toolkit_first_pins_the_haswell_core_and_builds_the_locked_bytes(tmp_path):
    """A fresh process with no variable set: the toolkit's import picks the Haswell core and the
    case builds to the lock's bytes."""
    from vpro_assets.benchmark import lock

    lines = _probe("toolkit-first", {}, tmp_path)
    assert lines == ["['Haswell']"]
    meta = (tmp_path / "scene" / BUILT_SCENE_CASE / "meta.json").read_text()
    assert lock.load()[BUILT_SCENE_CASE]["files"] == json.loads(meta)["files"]
