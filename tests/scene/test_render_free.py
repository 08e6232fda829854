"""Scene build and validation without a renderer (`vpro_assets.libero.physics`): the same bytes as
the committed lock, no GL context anywhere, the physics-only step and the model cache equal to
robosuite's own step and compile, bit for bit, and a model without textures (its memory)."""

from __future__ import annotations

import contextlib

import mujoco
import numpy as np
import pytest

from vpro_assets.benchmark import lock
from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.core.hashing import mjcf_tree_sha256, sha256_file
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero import physics
from vpro_assets.libero.env import libero_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene import build, sim
from vpro_assets.scene.validate import validate_case

# A recoloured distractor: base scene, a generated object, variant env and 10 settled trials.
CASE = "libero_spatial-00/task_relevant_distractors/same_color-v1"


@contextlib.contextmanager
def no_renderer(monkeypatch):
    """Every way robosuite or MuJoCo makes a GL context raises inside the block."""
    import mujoco
    from robosuite.utils import binding_utils

    def refuse(*_args, **_kwargs):
        raise AssertionError("a renderer was created")

    monkeypatch.setattr(binding_utils.MjRenderContext, "__init__", refuse)
    monkeypatch.setattr(mujoco, "GLContext", refuse)
    monkeypatch.setattr(mujoco.Renderer, "__init__", refuse)
    yield


def test_render_free_build_matches_the_lock_and_validation_needs_no_renderer(tmp_path, monkeypatch):
    """A case built on the render-free path (model cache, physics-only step) into an empty out/
    has every file's sha256 as the committed lock records it (built by robosuite's own step and
    compiles), and validating it creates no renderer."""
    case = find_case(load_catalog(paths.catalog_path()), CASE)
    recorded = lock.load()[CASE]
    monkeypatch.setenv("VPRO_OUT", str(tmp_path))
    with no_renderer(monkeypatch):
        result = build.build_case(case, force=True)
        assert result.status == "built", result.error
        assert result.files == recorded["files"]
        for name, digest in recorded["files"].items():
            assert sha256_file(paths.scene_case_dir(CASE) / name) == digest
        for name, digest in recorded.get("objects", {}).items():
            assert mjcf_tree_sha256(paths.objects_root() / name / f"{name}.xml") == digest
        env = sim.physics_env(str(build.built_case(CASE)["bddl"]))
        try:
            assert not sim.raw(env).has_offscreen_renderer and sim.raw(env).sim._render_context_offscreen is None
            assert sim.raw(env).sim.model._model.ntex == 0  # the build's env: no texture data
        finally:
            sim.close(env)
        v = validate_case(case)
    assert v.ok, v.problems


def _settled(task_key: str, seeds: tuple[int, ...], fresh: bool = False) -> np.ndarray:
    task = get_task(task_key)
    rows = libero_init_states(task)
    env = sim.physics_env(str(libero_bridge.bddl_path(task.suite, task.name)), fresh=fresh)
    out = []
    try:
        for k, seed in enumerate(seeds):
            if k:
                env.reset()  # a hard reset (robosuite reloads the model), or `fresh`'s soft one
            sim.place_fixtures(env, seed)
            sim.load_state(env, rows[k])
            sim.settle(env, 10)
            out.append(sim.flattened_state(env))
    finally:
        env.close()
    return np.stack(out)


@pytest.mark.parametrize("task_key", ["libero_goal-03"])  # a cabinet: fixtures placed per seed
def test_physics_only_step_and_model_cache_equal_robosuite_bit_for_bit(task_key):
    with physics.reference():
        compiles = physics.COUNTERS.compiles
        reference = _settled(task_key, (11, 12))
        assert physics.COUNTERS.compiles - compiles == 3  # construction, reset in physics_env, hard reset
    compiles, hits = physics.COUNTERS.compiles, physics.COUNTERS.cache_hits
    fast = _settled(task_key, (11, 12))
    assert physics.COUNTERS.compiles - compiles <= 1 and physics.COUNTERS.cache_hits - hits >= 2
    assert reference.tobytes() == fast.tobytes()


@pytest.mark.parametrize("task_key", ["libero_goal-03"])
def test_validation_env_compiles_once_and_gives_the_builds_states(task_key):
    """`vpro validate`'s env (`fresh`: MuJoCo's XML load with textures, so `get_xml()` is its
    scene's, and robosuite's soft reset on that model) compiles once, keeps no copy in the model
    cache, and its trials (fixtures placed at each trial's seed on the model used before) end in
    the states the build's env (hard resets, a model without textures) gives, bit for bit."""
    build_states = _settled(task_key, (11, 12))
    physics.clear_model_cache()
    compiles, hits = physics.COUNTERS.compiles, physics.COUNTERS.cache_hits
    validation_states = _settled(task_key, (11, 12), fresh=True)
    assert physics.COUNTERS.compiles - compiles == 1 and physics.COUNTERS.cache_hits == hits
    assert not physics._MODELS  # nothing kept: the env read its own compile
    assert validation_states.tobytes() == build_states.tobytes()


def test_render_free_episode_env_resets_without_compiling():
    """`vpro eval --no-render` builds its env with `make_env(render=False)` and hard-resets it before
    every trial: the same mechanism, so only the construction compiles."""
    from vpro_assets.libero.env import make_env

    physics.clear_model_cache()
    compiles, hits = physics.COUNTERS.compiles, physics.COUNTERS.cache_hits
    env = make_env(get_task("libero_spatial-00"), render=False)
    try:
        assert not env.env.has_offscreen_renderer and not env.env.use_camera_obs
        for _ in range(2):
            env.reset()
    finally:
        env.close()
    assert physics.COUNTERS.compiles - compiles == 1 and physics.COUNTERS.cache_hits - hits == 2


# What a model without textures may differ in from MuJoCo's own compile: the textures, the
# materials' references to them, and where names sit in the names buffer (texture names are gone).
TEXTURE_FIELDS = ("tex_", "mat_texid", "name_", "names", "_sizes")


def test_render_free_model_has_no_textures_and_the_same_physics():
    """The render-free env compiles its scene without textures (two thirds of a LIBERO scene model's
    memory); every other array of the model, and every name, is what MuJoCo's own compile of the
    same MJCF gives. `fresh` (what `vpro validate` reads back through mj_saveLastXML) keeps them."""
    task = get_task("libero_goal-03")
    bddl = str(libero_bridge.bddl_path(task.suite, task.name))
    env = sim.physics_env(bddl)
    try:
        assert sim.raw(env).sim.model._model.ntex == 0
        xml = sim.raw(env).model.get_xml()  # the MJCF text robosuite compiles
    finally:
        sim.close(env)
    bare, full = physics.physics_model(xml), mujoco.MjModel.from_xml_string(xml)
    assert bare.ntex == 0 and bare.tex_data.size == 0 and (bare.mat_texid < 0).all()
    assert full.ntex > 0 and full.tex_data.size > bare.nbuffer  # the textures were most of it
    arrays = [n for n in dir(full) if isinstance(getattr(full, n), np.ndarray) and not n.startswith(TEXTURE_FIELDS)]
    assert len(arrays) > 300
    differ = [n for n in arrays if getattr(full, n).tobytes() != getattr(bare, n).tobytes()]
    assert not differ
    obj = mujoco.mjtObj
    for kind, count in (
        (obj.mjOBJ_BODY, "nbody"),
        (obj.mjOBJ_GEOM, "ngeom"),
        (obj.mjOBJ_JOINT, "njnt"),
        (obj.mjOBJ_SITE, "nsite"),
        (obj.mjOBJ_MATERIAL, "nmat"),
        (obj.mjOBJ_ACTUATOR, "nu"),
    ):
        names = [mujoco.mj_id2name(full, kind, i) for i in range(getattr(full, count))]
        assert [mujoco.mj_id2name(bare, kind, i) for i in range(getattr(bare, count))] == names
    env = sim.physics_env(bddl, fresh=True)
    try:
        assert sim.raw(env).sim.model._model.ntex == full.ntex
    finally:
        sim.close(env)
