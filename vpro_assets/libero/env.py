"""Headless LIBERO environments for base tasks, with both cameras at a chosen resolution."""

from __future__ import annotations

import atexit
import logging
import weakref
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero import physics
from vpro_assets.libero.init_states import read_init_states
from vpro_assets.libero.names import CAMERAS, GRIPPER_PREFIX  # noqa: F401 (re-exported)
from vpro_assets.libero.settled import NOOP_ACTION  # noqa: F401 (re-exported; the pack runtime carries it)
from vpro_assets.libero.tasks import TaskRecord

log = logging.getLogger(__name__)

DEFAULT_RESOLUTION = 256


def make_env(
    task: TaskRecord, resolution: int = DEFAULT_RESOLUTION, bddl_file: str | None = None, render: bool = True, **kwargs
):
    """LIBERO's own `OffScreenRenderEnv` for a task (or another BDDL file of the same task).

    `render=False`: LIBERO's `ControlEnv` without an offscreen renderer or camera observations,
    the same physics at no render cost, its hard resets reusing the compiled model. Either steps
    with split substeps (`vpro_assets.libero.physics`: LIBERO's step, bit for bit, at about half
    its physics cost)."""
    if not isinstance(resolution, int) or not 16 <= resolution <= 2048:
        raise InvalidParameterError(f"resolution must be an integer in 16..2048, got {resolution!r}")
    envs = libero_bridge.libero_envs()
    bddl = bddl_file or str(libero_bridge.bddl_path(task.suite, task.name))
    if not render:
        log.info("building %s (%s) without rendering", task.key, bddl)
        return physics.physics_env(bddl, camera_names=list(CAMERAS), **kwargs)
    log.info("building %s (%s) at %dx%d", task.key, bddl, resolution, resolution)
    env = envs.OffScreenRenderEnv(
        bddl_file_name=bddl, camera_heights=resolution, camera_widths=resolution, camera_names=list(CAMERAS), **kwargs
    )
    _track_render_context(env)
    return physics.split_steps(env)


_LIVE_ENVS: weakref.WeakSet = weakref.WeakSet()


def _track_render_context(env) -> None:
    # robosuite registers eglTerminate with atexit when it creates its first EGL context (inside
    # the first env built); contexts still alive at exit are then freed during interpreter
    # teardown on a terminated display, printing "Exception ignored ... EGLError" tracebacks.
    # atexit runs handlers last-registered first, so a handler registered after that env frees
    # the remaining contexts while the display is still valid.
    if not _LIVE_ENVS:
        atexit.unregister(_free_render_contexts)
        atexit.register(_free_render_contexts)
    _LIVE_ENVS.add(env)


def _free_render_contexts() -> None:
    for env in list(_LIVE_ENVS):
        ctx = getattr(getattr(getattr(env, "env", None), "sim", None), "_render_context_offscreen", None)
        if ctx is not None and getattr(ctx, "gl_ctx", None) is not None:
            ctx.gl_ctx.free()  # idempotent: robosuite's own __del__ then finds nothing to free


@contextmanager
def task_env(task: TaskRecord, resolution: int = DEFAULT_RESOLUTION, **kwargs) -> Iterator:
    env = make_env(task, resolution, **kwargs)
    try:
        yield env
    finally:
        env.close()


def libero_init_states(task: TaskRecord) -> np.ndarray:
    return read_init_states(libero_bridge.init_state_path(task.suite, task.name))


def views_side_by_side(obs: dict) -> np.ndarray:
    """Both camera images upright (raw frames are bottom-up), third-person left, wrist right."""
    return np.concatenate([obs[f"{cam}_image"][::-1] for cam in CAMERAS], axis=1)
