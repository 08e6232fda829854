"""Scene cases build, validate and rebuild byte for byte; bad input fails cleanly.

Default run: a stratified sample (one case per generator family that needs no long mesh work:
a recoloured distractor, which registers a generated object; a precondition that flips an
articulation; a visual-only ambiguity copy). Full set (every scene case, including geometry cases whose deformed meshes take
coacd tens of seconds each): `.venv/bin/python -m pytest -m slow tests/scene/test_build.py`.
"""

from __future__ import annotations

import dataclasses
import json

import pytest
from conftest import BUILT_SCENE_CASE

from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.core import paths

SAMPLE = (
    BUILT_SCENE_CASE,
    "libero_goal-03/task_precondition_variation/receptacle_openness-v1",
    "libero_goal-03/visual_state_ambiguity/object_pose-v1",
)


@pytest.fixture(scope="module")
def catalog():
    return load_catalog(paths.catalog_path())


def _case(catalog, cid):
    return next(c for c in catalog["cases"] if c["id"] == cid)


@pytest.fixture(scope="module")
def out_dir(scene_out):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VPRO_OUT", str(scene_out))
        yield scene_out


@pytest.mark.parametrize("cid", SAMPLE)
def test_sample_case_builds_validates_and_rebuilds_identically(catalog, out_dir, cid):
    from vpro_assets.scene import build
    from vpro_assets.scene.validate import validate_case

    case = _case(catalog, cid)
    first = build.build_case(case, force=True)
    assert first.status == "built"
    d = paths.scene_case_dir(cid)
    files = {p.name: p.read_bytes() for p in d.iterdir()}
    assert set(first.files) <= set(files) and "meta.json" in files
    meta = json.loads(files["meta.json"])
    assert meta["init_states"] == {"rows": 10, "width": meta["init_states"]["width"]}
    v = validate_case(case)
    assert v.ok, v.problems
    # Unchanged inputs: not rebuilt.
    assert build.build_case(case).status == "unchanged"
    if cid == SAMPLE[0]:  # forced rebuild (kept to one case for time): the same bytes for every artifact
        again = build.build_case(case, force=True)
        assert again.files == first.files
        assert {p.name: p.read_bytes() for p in d.iterdir()} == files


def test_state_that_cannot_settle_names_case_and_leaves_nothing(catalog, out_dir, monkeypatch):
    from generators import distractors
    from vpro_assets.scene import build, plugins
    from vpro_assets.scene.init_gen import InitStateError
    from vpro_assets.scene.variant import Placement

    cid = "libero_spatial-00/task_relevant_distractors/same_category-v1"
    real = distractors.same_category

    def overlapping(ctx):
        variant = real(ctx)
        inside = tuple(ctx.familiar_xy(ctx.task.target))  # right inside the target, no clearance asked
        variant.placements = [Placement(variant.added[0], inside, 0.0, 0.0, margin=-1.0)]
        return variant

    gen = plugins.generator_for(_case(catalog, cid))
    monkeypatch.setitem(plugins._REGISTRY, gen.name, dataclasses.replace(gen, fn=overlapping))
    with pytest.raises(InitStateError, match=rf"case {cid}: trial 0 has no initial state"):
        build.build_case(_case(catalog, cid), force=True)
    assert not paths.scene_case_dir(cid).exists()
    assert not list(paths.scene_root().rglob(".tmp-*"))


def test_unknown_object_in_a_generator_names_the_case(catalog, out_dir, monkeypatch):
    from vpro_assets.core.errors import VProError
    from vpro_assets.scene import build, plugins

    cid = "libero_spatial-00/task_relevant_distractors/same_affordance-v1"

    def unknown(ctx):
        return ctx.pool_object("golden_teapot")

    gen = plugins.generator_for(_case(catalog, cid))
    monkeypatch.setitem(plugins._REGISTRY, gen.name, dataclasses.replace(gen, fn=unknown))
    with pytest.raises(VProError, match=rf"case {cid}: unknown object 'golden_teapot'"):
        build.build_case(_case(catalog, cid), force=True)
    assert not paths.scene_case_dir(cid).exists()


@pytest.mark.slow
def test_every_scene_case_builds_validates_and_matches_the_catalog(catalog):
    """The full set, in the repository's out/ (content-addressed: what `vpro build` already built is
    only checked, so after a full build this costs the validation, ~20 min with 2 workers): every
    scene case builds, validates, and its files have the hashes the committed catalog records."""
    from vpro_assets.benchmark.lock import check_built
    from vpro_assets.scene import build
    from vpro_assets.scene.validate import validate

    scene = [c for c in catalog["cases"] if c["level"] == "scene"]
    results = build.build(scene, jobs=2, progress=False)
    failed = [r.error for r in results if r.status == "failed"]
    assert not failed, "\n".join(failed[:20])
    bad = [(v.case_id, v.problems) for v in validate(scene, jobs=2, progress=False) if not v.ok]
    assert not bad, bad[:10]
    diffs, checked, missing = check_built(catalog)
    assert diffs == [] and missing == 0 and checked == sum(len(c["artifacts"]) for c in scene)


def test_killed_build_resumes_to_the_recorded_bytes(catalog, tmp_path):
    """`vpro build` killed with SIGKILL while a case is half-written leaves no case half-built;
    the same command then finishes the selection, and every file has the sha256 the committed
    lock file records (built on another machine state, in another process)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    from vpro_assets.benchmark import lock

    cases = SAMPLE[1:]
    cmd = [str(Path(sys.executable).with_name("vpro")), "build", "--no-record"]
    for cid in cases:
        cmd += ["--select", cid]
    env = dict(os.environ, VPRO_OUT=str(tmp_path))
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not list((tmp_path / "scene").glob(".tmp-*")):  # a case is being written
        assert proc.poll() is None and time.monotonic() < deadline, "the build ended before a case was half-written"
        time.sleep(0.05)
    time.sleep(1.0)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    partial = list((tmp_path / "scene").glob(".tmp-*"))
    assert partial, "the kill should have left the temporary folder of the case in progress"
    assert sum((tmp_path / "scene" / cid / "meta.json").is_file() for cid in cases) < len(cases)

    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert not list((tmp_path / "scene").rglob(".tmp-*")) and not list((tmp_path / "scene").rglob(".old-*"))
    recorded = lock.load()
    for cid in cases:
        meta = json.loads((tmp_path / "scene" / cid / "meta.json").read_text())
        assert meta["files"] == recorded[cid]["files"], cid
        for name, digest in meta["files"].items():
            from vpro_assets.core.hashing import sha256_file

            assert sha256_file(tmp_path / "scene" / cid / name) == digest


def test_build_places_fixtures_where_the_rollout_env_has_them():
    """LIBERO places fixtures from numpy's global stream at every reset. The build (and
    validation) place them per trial with `sim.place_fixtures(env, seed)`; the rollout seeds
    LIBERO's own render env and resets it. Same seed, same fixture placement; another seed moves
    the cabinet (so the check is not vacuous)."""
    import numpy as np

    from vpro_assets.libero import bridge as libero_bridge
    from vpro_assets.libero.env import make_env
    from vpro_assets.libero.tasks import get_task
    from vpro_assets.scene import sim

    task = get_task("libero_spatial-04")  # a bowl in the cabinet's drawer

    def fixtures(env):
        raw = sim.raw(env)
        return np.array(
            [
                raw.sim.model.body_pos[raw.sim.model.body_name2id(f.root_body)]
                for _, f in sorted(raw.fixtures_dict.items())
            ]
        )

    rollout_env = make_env(task, 32)
    build_env = sim.physics_env(str(libero_bridge.bddl_path(task.suite, task.name)))
    try:
        rollout_env.seed(1234)
        rollout_env.reset()
        sim.place_fixtures(build_env, 1234)
        assert np.array_equal(fixtures(rollout_env), fixtures(build_env))
        sim.place_fixtures(build_env, 4321)
        assert np.abs(fixtures(rollout_env) - fixtures(build_env)).max() > 1e-3
    finally:
        rollout_env.close()
        build_env.close()
