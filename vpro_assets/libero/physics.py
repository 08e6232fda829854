"""LIBERO envs at the least physics cost: without a renderer, camera observations or repeated
model compiles where no pixel is needed (the scene build's base scene, variant env and settling,
`vpro validate`, render-free episodes: `vpro eval --no-render`, `vpro certify`), and every env's
control step without robosuite's repeated forward passes.

- `physics_env(bddl_file, **kwargs)`: LIBERO's `ControlEnv` without offscreen renderer or camera
  observations. robosuite's `reset()` is a hard reset: it rebuilds the MJCF and compiles it again
  every time (about 2.5 s for a LIBERO scene on this machine). Compiles of such an env go through
  a process-wide cache keyed by the sha256 of the MJCF text: the same text gives a copy of the
  model compiled before (`mj_copyModel`: the same bytes as a new compile, so the same physics),
  and the fixture placement LIBERO writes into the model at each reset lands on a fresh copy,
  exactly as on a fresh compile. The same BDDL gives the same MJCF, so the trials of a case and
  the reset after construction reuse one compile. These compiles leave the textures out
  (`physics_model`): no pixel is drawn, and they were two thirds of a scene model's memory.
- `seeded_reset_in_place(env, seed)`: a trial's reset of such an env kept from an earlier episode
  (`vpro_assets.rollout.case_env` decides), the hard reset's start bit for bit without its MJCF
  rebuild, model copy and garbage collection.
- Split substeps: robosuite's control step runs, in each of its 25 substeps, mj_forward, the
  controllers (whose `update` runs mj_forward again) and mj_step (a third forward inside): MuJoCo's
  position and velocity stages three times on the same state. The controllers read only those
  stages (site poses, Jacobians, mass matrix, bias forces), so here each substep is MuJoCo's split
  step: mj_step1 (position and velocity stages), the controllers with their mj_forward skipped,
  mj_step2 (actuation, acceleration, constraints, Euler integration); between policy steps the arm
  control is robosuite's OSC and gripper arithmetic without its lookups, copies and property calls
  (`arm_control`). Same state, observations, reward and success, bit for bit
  (tests/libero/test_physics.py, tests/libero/test_arm_control.py), at about a third of the step's
  cost. Where nothing observes the substeps (`observe=False`), substeps 1..24 run in one compiled
  call instead (`fused_substeps`: the same operations, without the Python around them).
  Every env built here steps that way (`control_step`, in place of LIBERO's and robosuite's `step`).
- `physics_step(env, action)`: the same control step for the physics only, without what only an
  observer reads (observables updated at every substep, observations, reward and success): settling
  and drift checks.
- `reference()`: a context in which both are off (every reset compiles, every step is robosuite's
  own), the path tests and `vpro bench build` compare against.

A model copied from the cache was not parsed last, so MuJoCo's `mj_saveLastXML` (robosuite's
`sim.model.get_xml()`) would write the spec of whatever was parsed last: an env built with
`physics_env(..., fresh=True)` compiles at construction and its resets are robosuite's soft
resets on that model (no compile, no copy), so right after it is built, `get_xml()` is its own
scene's (what `vpro validate` checks).
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import importlib
import logging
import time
import weakref
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.libero import arm_control
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.settled import keep_property_samplers

log = logging.getLogger(__name__)

MODEL_CACHE_SIZE = 1  # compiled models kept per process: a LIBERO scene model is 70-120 MB without textures


@dataclass
class PhysicsCounters:
    """Model compiles in this process (how many, their seconds, copies taken from the cache) and,
    inside `metered()`, the seconds spent in MuJoCo's mj_step and mj_forward."""

    compiles: int = 0
    compile_seconds: float = 0.0
    cache_hits: int = 0
    mj_seconds: float = 0.0

    def physics_seconds(self) -> float:
        """What a stage needs of MuJoCo: compiling its models and stepping them."""
        return self.compile_seconds + self.mj_seconds


COUNTERS = PhysicsCounters()
_MODELS: OrderedDict[str, mujoco.MjModel] = OrderedDict()
_FAST = [True]
_METERED = [False]  # inside `metered()`: every MuJoCo step through the bindings, which it times


@contextlib.contextmanager
def reference() -> Iterator[None]:
    """Turn the model cache and the physics-only step off (robosuite's own path) inside the block."""
    before = _FAST[0]
    _FAST[0] = False
    try:
        yield
    finally:
        _FAST[0] = before


def fast() -> bool:
    return _FAST[0]


@contextlib.contextmanager
def metered() -> Iterator[None]:
    """Count the seconds of every mj_step, mj_step1, mj_step2 and mj_forward (robosuite's, the
    controller's, ours) in `COUNTERS.mj_seconds` inside the block (`vpro bench build`; a timer call
    per MuJoCo call; the fused substeps, which call MuJoCo's C functions directly, are off in it)."""
    real = {name: getattr(mujoco, name) for name in ("mj_step", "mj_step1", "mj_step2", "mj_forward")}

    def timed(fn):
        def call(*args):
            started = time.perf_counter()
            try:
                return fn(*args)
            finally:
                COUNTERS.mj_seconds += time.perf_counter() - started

        return call

    for name, fn in real.items():
        setattr(mujoco, name, timed(fn))
    before, _METERED[0] = _METERED[0], True
    try:
        yield
    finally:
        _METERED[0] = before
        for name, fn in real.items():
            setattr(mujoco, name, fn)


def clear_model_cache() -> None:
    _MODELS.clear()


def compiled_model(xml: str, fresh: bool = False) -> mujoco.MjModel:
    """A model compiled from `xml`: a copy of the cached one where this text was compiled before.
    `fresh`: compiled again all the same by MuJoCo's XML load, and not cached: its env reads this
    compile itself (`get_xml()`) and resets without recompiling (`physics_env`), so a pristine copy
    (210 MB with textures, 0.1-0.3 s to copy) would only wait to be evicted."""
    key = hashlib.sha256(xml.encode()).hexdigest()
    cached = _MODELS.get(key) if _FAST[0] and not fresh else None
    if cached is not None:
        _MODELS.move_to_end(key)
        COUNTERS.cache_hits += 1
        return copy.copy(cached)  # mj_copyModel
    started = time.perf_counter()
    # fresh: `vpro validate` reads the scene back through mj_saveLastXML, which needs MuJoCo's own
    # XML load (it keeps the parsed spec); robosuite's path (reference()) compiles as robosuite does.
    model = mujoco.MjModel.from_xml_string(xml) if fresh or not _FAST[0] else physics_model(xml)
    COUNTERS.compiles += 1
    COUNTERS.compile_seconds += time.perf_counter() - started
    if _FAST[0] and not fresh:
        _MODELS[key] = copy.copy(model)  # kept pristine: LIBERO writes fixture placements into `model`
        while len(_MODELS) > MODEL_CACHE_SIZE:
            _MODELS.popitem(last=False)
    return model


def physics_model(xml: str) -> mujoco.MjModel:
    """The model of `xml` without its textures: the physics reads none of them, and a LIBERO
    scene's textures are two thirds of its model (136 of 210 MB for libero_goal-03), decoded once
    more into MuJoCo's asset cache. Compiled from an `MjSpec`, so MuJoCo keeps no copy of the
    parsed scene for mj_saveLastXML either (its XML load does: about 300 MB more)."""
    spec = mujoco.MjSpec.from_string(xml)
    for texture in list(spec.textures):
        spec.delete(texture)
    for material in spec.materials:
        material.textures = [""] * len(material.textures)  # material colours stay: mj_ray reads their alpha
    return spec.compile()


class _CachedMjSim:
    """Stands in for robosuite's `MjSim` name inside `robosuite.environments.base` while a
    render-free env compiles: `from_xml_string` goes through `compiled_model`."""

    def __init__(self, fresh: bool):
        self.fresh = fresh

    def from_xml_string(self, xml: str):
        binding = importlib.import_module("robosuite.utils.binding_utils")
        return binding.MjSim(compiled_model(xml, self.fresh))


@contextlib.contextmanager
def _compiles_through_cache(fresh: bool = False) -> Iterator[None]:
    base = importlib.import_module("robosuite.environments.base")
    real = getattr(base, "MjSim")  # noqa: B009 (robosuite is untyped here)
    setattr(base, "MjSim", _CachedMjSim(fresh))  # noqa: B010
    try:
        yield
    finally:
        setattr(base, "MjSim", real)  # noqa: B010


def physics_env(bddl_file: str, fresh: bool = False, **kwargs):
    """LIBERO's ControlEnv for a BDDL file without renderer or camera observations, whose compiles
    (construction and every hard reset) go through the model cache (module docstring). `fresh`:
    the construction compiles in any case (MuJoCo's XML load, textures included) and `reset()` is
    robosuite's soft reset (`hard_reset=False`: the data reset and the same re-initialisation, on
    the construction's model), so `get_xml()` reads this scene's compile, and the env compiles once."""
    libero_bridge.libero_envs()
    control_env = importlib.import_module("libero.libero.envs.env_wrapper").ControlEnv
    kwargs = {"has_renderer": False, "has_offscreen_renderer": False, "use_camera_obs": False, **kwargs}
    if fresh:
        kwargs["hard_reset"] = False
    with _compiles_through_cache(fresh):
        env = control_env(bddl_file_name=str(bddl_file), **kwargs)
    inner = env.env
    initialize = inner._initialize_sim

    def initialize_sim(xml_string=None):
        arm_control.forget(inner)  # its kept arms hold the model this hard reset replaces
        with _compiles_through_cache():
            initialize(xml_string)
        _keep_compiled_values(inner)

    inner._initialize_sim = initialize_sim  # robosuite's own code, its compile through the cache
    return split_steps(env)


# The model arrays a reset or an episode writes: LIBERO's fixture placement (body_pos, body_quat)
# and robosuite's site visualisation (site_rgba). Everything else in the model stays as compiled
# (tests/rollout/test_env_reuse.py compares every model array after both resets).
RESET_WRITTEN_FIELDS = ("body_pos", "body_quat", "site_rgba")


def _keep_compiled_values(inner) -> None:
    model = inner.sim.model._model
    inner._vpro_compiled = {name: getattr(model, name).copy() for name in RESET_WRITTEN_FIELDS}


def can_reset_in_place(env) -> bool:
    """Whether `seeded_reset_in_place` can stand in for this env's hard reset: a render-free env of
    `physics_env` with robosuite's hard reset, compiled through the cache at least once."""
    inner = getattr(env, "env", env)
    return _FAST[0] and inner.hard_reset and not inner.has_offscreen_renderer and hasattr(inner, "_vpro_compiled")


def seeded_reset_in_place(env, seed: int):
    """robosuite's hard reset (`MujocoEnv.reset` inside LIBERO's `ControlEnv.reset`, line for line)
    on the env's own model and data instead of a rebuilt MJCF and a fresh model copy: the same
    state as the hard reset, bit for bit, without its rebuild, model copy and garbage collection
    (0.3-0.5 s of a render-free episode). What the rebuild would have renewed is renewed here:
    - the model: a fresh copy differs from this one only in the arrays resets and episodes write
      (`RESET_WRITTEN_FIELDS`), put back to their compiled values;
    - the data: a new MjData is a reset one (`mj_resetData`), forwarded once as `_initialize_sim` does;
    - LIBERO's articulation samplers: a hard reset's model load adds one copy of them
      (`settled.keep_property_samplers`), so this reset keeps as many as after that load, one more
      per RandomizationError retry as LIBERO's retry loads the model again;
    - robosuite's Python state (robots' initial pose and noise, new controllers, the gripper's
      format_action, timestep and done, observables) is renewed by `_reset_internal`, which both
      resets run; the observables' sensors read `self.sim`, the same sim here. What the rebuild
      renews and this reset keeps is read by nothing before it is written again: LIBERO's
      placement samplers (stateless), its burner flags and their list of sites (site_rgba only,
      set again from the knob's joint at the first step), MjData's scratch arrays.
    The trial's reset as `settled.seeded_reset` makes it (numpy's stream seeded first); returns the
    observation."""
    inner = getattr(env, "env", env)
    model, data = inner.sim.model._model, inner.sim.data._data
    randomization_error = importlib.import_module("robosuite.utils.errors").RandomizationError
    env.seed(int(seed))
    copies = 2  # construction's load and this reset's
    while True:
        keep_property_samplers(env, copies)
        for name, values in inner._vpro_compiled.items():
            getattr(model, name)[:] = values
        mujoco.mj_resetData(model, data)
        inner.sim.forward()
        inner.initialize_time(inner.control_freq)
        try:
            inner._reset_internal()
            break
        except randomization_error:
            copies += 1
    inner.sim.forward()
    inner._obs_cache = {}
    inner.visualize(vis_settings=dict.fromkeys(inner._visualizations, False))
    return inner._get_observations(force_update=True)


def split_steps(env):
    """Make a LIBERO env (the wrapper) step with split substeps (`control_step`); returns it."""
    inner = getattr(env, "env", env)
    if type(inner).step is not _libero_step():
        raise TypeError(
            f"{type(inner).__name__} has a step of its own; split substeps mirror LIBERO's BDDLBaseDomain.step"
        )
    env_ref = weakref.ref(inner)  # no reference cycle: the env and its ~200 MB model go when unused

    def step(action):
        return control_step(env_ref(), action)

    step._vpro_split = True  # what `unobserved_step` checks
    inner.step = step
    return env


def _libero_step():
    return importlib.import_module("libero.libero.envs.bddl_base_domain").BDDLBaseDomain.step


def _forward_done() -> None:
    """Stands in for `MjSim.forward` while the controllers run: mj_step1 has just computed it."""


def _substeps(inner, action, observe: bool) -> None:
    """robosuite's substep loop (`MujocoEnv.step`) with MuJoCo's split step (module docstring);
    `observe`: robosuite's observables updated after each substep, as its loop does."""
    sim = inner.sim
    model, data = sim.model._model, sim.data._data
    arms = arm_control.Arms.of(inner)
    count = int(inner.control_timestep / inner.model_timestep)
    fused = arms.fused_substeps if arms is not None and not observe and not _METERED[0] else None
    for substep in range(count):
        if substep == 1 and fused is not None and fused(action, count - 1):
            break  # the rest of the control step in one compiled call (`fused_substeps`)
        mujoco.mj_step1(model, data)
        if substep and arms is not None:
            arms.control(action)  # between policy steps: robosuite's arm control, written out (arm_control)
        else:
            sim.forward = _forward_done
            try:
                inner._pre_action(action, substep == 0)
            finally:
                del sim.forward  # MjSim's own method again
        mujoco.mj_step2(model, data)
        if observe:
            inner._update_observables()


def control_step(inner, action, observe: bool = True):
    """LIBERO's env step (`BDDLBaseDomain.step` around robosuite 1.4's `MujocoEnv.step`, line for
    line) with split substeps; robosuite's own inside `reference()`. Written out because the
    substep loop sits inside robosuite's `step` with nothing to hook into.

    `observe=False` (`unobserved_step`): without robosuite's observables, for a caller that reads
    no observation; the observations returned are None."""
    if not _FAST[0]:
        return _libero_step()(inner, action)
    if inner.action_dim == 4 and len(action) > 4:  # LIBERO: an OSC_POSE action for an OSC_POSITION arm
        action = np.array(action)
        action = np.concatenate((action[:3], action[-1:]), axis=-1)
    if inner.done:
        raise ValueError("executing action in terminated episode")
    inner.timestep += 1
    _substeps(inner, action, observe=observe)
    inner.cur_time += inner.control_timestep
    reward, _done, info = inner._post_action(action)
    if inner.viewer is not None and inner.renderer != "mujoco":
        inner.viewer.update()
    if not observe:
        return None, reward, inner._check_success(), info
    observations = inner.viewer._get_observations() if inner.viewer_get_obs else inner._get_observations()
    return observations, reward, inner._check_success(), info


def unobserved_step(env, action) -> bool:
    """One control step of LIBERO's env (the wrapper or the robosuite env inside) for a caller that
    reads no observation (`vpro certify`'s oracle acts from the simulator): `control_step` without
    robosuite's observables, which it updates after each of the 25 substeps and gathers into the
    observation dict at the step's end: 43 observables of libero_10-00 sampled and 1,075 timer
    updates per step, 1.2 ms of a 20-25 ms render-free step here, thrown away unread). The
    observables only read the simulator (robosuite's and LIBERO's sensors write nothing back): the
    state, the reward, `done` and LIBERO's object states (`_post_action`) are the same, bit for bit
    (tests/libero/test_physics.py); what is left stale is the observables' own sampled values and
    their timers, which robosuite's next `reset()` resets. Returns LIBERO's
    success (what `step` returns as `done`). robosuite's own `step` inside `reference()`, or on an env
    not made here (whose `step` is not the split one)."""
    inner = getattr(env, "env", env)
    if not _FAST[0] or not getattr(inner.step, "_vpro_split", False):
        return bool(env.step(action)[2])
    return bool(control_step(inner, action, observe=False)[2])


def physics_step(env, action) -> None:
    """One control step of LIBERO's env (the wrapper or the robosuite env inside), physics only
    (module docstring); robosuite's own `step` inside `reference()`."""
    inner = getattr(env, "env", env)
    if not _FAST[0]:
        _libero_step()(inner, action)
        return
    inner.timestep += 1
    _substeps(inner, action, observe=False)
    inner.cur_time += inner.control_timestep
    inner._post_process()  # LIBERO's object states (a stove turned on), as its _post_action does
