"""`env_for_case(case, trial, ...)`: the one place an episode's environment comes from.

- Normal cases: LIBERO's own env of the base task, initial state = LIBERO's row for the trial.
- Observation cases (masking, corruption, staleness, ...): the same base env, seen through the
  perturbation layer's `CaseObserver` (`vpro_assets.perturb`).
- Scene cases (distractors, preconditions, ambiguity, geometry): the generated BDDL and frozen
  initial states of the built case (`vpro build`, found by `vpro_assets.scene.build`); a case whose
  artifacts are not built is unavailable with the message "not built; run vpro build".

The phase timeline comes from the perturbation layer's phase tracker: the observer's own for
observation cases, a bare `PhaseTracker` for Normal and scene cases.

An unavailable case raises CaseUnavailableError (recorded once, not retried); anything the
simulator raises becomes SimulatorError (an infrastructure error, retried).
"""

from __future__ import annotations

import atexit
import hashlib
import logging
from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.core.hashing import sha256_file
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero import physics
from vpro_assets.libero.env import CAMERAS, make_env
from vpro_assets.libero.init_states import read_init_states
from vpro_assets.libero.settled import seeded_reset
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.perturb.observer import CaseObserver
from vpro_assets.perturb.phases import PhaseTracker
from vpro_assets.rollout.policies.base import SimulatorError
from vpro_assets.scene.build import built_case

log = logging.getLogger(__name__)


class CaseUnavailableError(VProError):
    """The case cannot run here: its scene is not built."""


def is_normal(case: Mapping) -> bool:
    return not case.get("setting")


@lru_cache(maxsize=8)
def _init_states_cached(path: str) -> np.ndarray:
    return read_init_states(path)


def scene_artifacts(case: Mapping) -> dict:
    """The built scene of a scene case (`vpro_assets.scene.build.built_case`: bddl, init_states,
    meta, with its generated objects registered with LIBERO), or CaseUnavailableError."""
    try:
        found = dict(built_case(case["id"]))
    except (VProError, FileNotFoundError, KeyError, StopIteration, ValueError) as exc:
        # built_case's own error already names the case and the command: say where it looked instead
        detail = f"looked in {paths.scene_case_dir(case['id'])}" if isinstance(exc, VProError) else str(exc)
        raise CaseUnavailableError(
            f"case {case['id']}: scene not built; run vpro build --select {case['id']} ({detail})"
        ) from None
    if not (Path(found["bddl"]).is_file() and Path(found["init_states"]).is_file()):
        raise CaseUnavailableError(
            f"case {case['id']}: scene not built (files missing in {found.get('dir')}); "
            f"run vpro build --select {case['id']}"
        )
    meta = found.get("meta") or {}
    if case.get("category") == "task_relevant_distractors":
        found["distractors"] = list(meta.get("added") or [])
    return found


def _phase_tracker(sim, task):
    """A phase tracker for an env without a perturbation observer (Normal and scene cases)."""
    try:
        tracker = PhaseTracker(EntityIndex(sim, task))
        tracker.reset()
        return tracker
    except Exception as exc:  # a scene variant the tracker does not understand: no timeline, not an error
        log.warning("no phase timeline: %s", exc)
        return None


# One built LIBERO env kept per process between episodes, as LIBERO's own evaluation scripts keep
# one env per task and call reset() (a hard reset: the model is reloaded) before each trial; a
# render-free one is reset in place (`env_for_case`). The trajectories are bit-identical to those of
# a fresh env (the backend-equality test, tests/rollout/test_env_reuse.py).
_ENV_CACHE: dict[tuple, Any] = {}


def _take_cached_env(key: tuple):
    env = _ENV_CACHE.pop(key, None)
    for other in list(_ENV_CACHE):
        _close_quietly(_ENV_CACHE.pop(other))
    return env


def _close_quietly(env) -> None:
    try:
        env.close()
    except Exception:  # a half-built env may fail to close; nothing to keep
        log.debug("env close failed", exc_info=True)


def release_cached_envs() -> None:
    for key in list(_ENV_CACHE):
        _close_quietly(_ENV_CACHE.pop(key))


atexit.register(release_cached_envs)  # close GL contexts while the GL library is still loaded


class CaseEnv:
    """One episode's environment: LIBERO env + optional perturbation wrapper + initial state."""

    def __init__(
        self,
        case: Mapping,
        trial: int,
        env,
        init_state: np.ndarray,
        wrapper: CaseObserver | None = None,
        artifacts: dict | None = None,
        scene: dict | None = None,
        cache_key: tuple | None = None,
        reset_in_place: bool = False,
    ):
        self.case, self.trial, self.env, self.wrapper = case, trial, env, wrapper
        self.cache_key = cache_key
        self.reset_in_place = reset_in_place
        self.broken = False
        self.init_state = init_state
        self.artifact_hashes = artifacts or {}
        self.scene = scene or {}
        self.task = get_task(case["task"])
        self.tracker = None

    @property
    def sim(self):
        return self.env.sim

    def reset(self) -> dict:
        try:
            # LIBERO re-samples fixture placements (cabinets, stoves, racks) from numpy's global
            # stream at every hard reset; its own `seed()` is the only handle on that stream (openpi's
            # LIBERO example calls it too). Seeding it with the trial's seed, and resetting as a new
            # env's first reset does, makes the scene, and so every frame, a function of (case,
            # trial) whatever ran before in this process.
            # A reused render-free env resets in place: the hard reset's state without its rebuild.
            reset = physics.seeded_reset_in_place if self.reset_in_place else seeded_reset
            reset(self.env, int(self.case["trial_seeds"][self.trial]))
            obs = self.env.set_init_state(self.init_state)
        except Exception as exc:
            self.broken = True
            raise SimulatorError(
                f"case {self.case['id']} trial {self.trial}: reset failed ({type(exc).__name__}: {exc})"
            ) from exc
        if self.wrapper is not None:
            self.wrapper.on_reset(obs)
        else:
            self.tracker = _phase_tracker(self.sim, self.task)
            if self.tracker is not None:
                self.tracker.update(self.sim)
        return obs

    def step(self, action: np.ndarray, observe: bool = True) -> tuple[dict, bool]:
        """One control step: (observation, LIBERO's success). `observe=False` (an env without a
        perturbation wrapper only): no observation is made (`physics.unobserved_step`), {}."""
        try:
            if observe or self.wrapper is not None:
                obs, _reward, done, _info = self.env.step(np.asarray(action, dtype=np.float64))
            else:
                obs, done = {}, physics.unobserved_step(self.env, np.asarray(action, dtype=np.float64))
        except Exception as exc:
            self.broken = True
            raise SimulatorError(
                f"case {self.case['id']} trial {self.trial}: step failed ({type(exc).__name__}: {exc})"
            ) from exc
        if self.wrapper is not None:
            self.wrapper.on_step(obs)
        elif self.tracker is not None:
            self.tracker.update(self.sim)
        return obs, bool(done)

    def policy_images(self, obs: Mapping, step: int) -> dict[str, np.ndarray | None]:
        """The views the policy receives at this step (raw frame; None = unavailable view)."""
        if self.wrapper is not None:
            return dict(self.wrapper.policy_images(obs, step))
        return {cam: obs[f"{cam}_image"] for cam in CAMERAS}

    def feed_predicted(self, frames) -> None:
        if self.wrapper is not None:
            self.wrapper.feed_predicted(frames)

    def phase_timeline(self) -> dict | None:
        if self.wrapper is not None:
            return self.wrapper.phase_timeline()
        return self.tracker.timeline() if self.tracker is not None else None

    def state_digest(self) -> str:
        """sha256 of the flattened simulator state (time, qpos, qvel), rounded to 1e-9."""
        state = np.round(np.asarray(self.env.get_sim_state(), dtype=np.float64), 9) + 0.0
        return hashlib.sha256(state.tobytes()).hexdigest()

    def success(self) -> bool:
        return bool(self.env.check_success())

    def close(self) -> None:
        """Keep the bare env for the next episode of the same scene, unless it failed."""
        if self.cache_key is not None and not self.broken:
            release_cached_envs()
            _ENV_CACHE[self.cache_key] = self.env
        else:
            _close_quietly(self.env)


def check_available(case: Mapping) -> None:
    """CaseUnavailableError if the case cannot run in this checkout (cheap: builds nothing)."""
    level = "normal" if is_normal(case) else case.get("level")
    if level == "scene":
        scene_artifacts(case)


def _case_files(case: Mapping) -> tuple[dict, str, str]:
    """A case's built scene (empty for LIBERO's own scenes), BDDL file and initial-state file."""
    if case.get("level") == "scene" and not is_normal(case):
        scene = scene_artifacts(case)
        return scene, str(scene["bddl"]), str(scene["init_states"])
    task = get_task(case["task"])
    return (
        {},
        str(libero_bridge.bddl_path(task.suite, task.name)),
        str(libero_bridge.init_state_path(task.suite, task.name)),
    )


def case_inputs(case: Mapping) -> dict:
    """sha256 of the files a case's starts come from (its BDDL and its initial states)."""
    _, bddl, init_path = _case_files(case)
    return {"bddl": sha256_file(bddl), "init_states": sha256_file(init_path)}


def env_for_case(
    case: Mapping,
    trial: int,
    *,
    resolution: int = 256,
    env_kwargs: dict | None = None,
    reuse: bool = True,
    render: bool = True,
) -> CaseEnv:
    """Build the environment of one trial of one case (see the module docstring). `render=False`:
    the same physics without a renderer or camera observations (no perturbation wrapper then)."""
    task = get_task(case["task"])
    rows = case.get("init_states", {}).get("rows") or list(range(10))
    if not 0 <= trial < len(rows):
        raise VProError(f"case {case['id']}: trial {trial} out of range (0..{len(rows) - 1})")
    level = "normal" if is_normal(case) else case.get("level")
    scene, bddl, init_path = _case_files(case)
    states = _init_states_cached(init_path) if not init_path.endswith(".npy") else np.load(init_path)
    row = rows[trial]
    if not 0 <= row < len(states):
        raise VProError(f"case {case['id']}: initial-state row {row} out of range ({len(states)} rows in {init_path})")
    hashes = {"bddl": sha256_file(bddl), "init_states": sha256_file(init_path), "init_row": row}
    key = (bddl, resolution, render, repr(sorted((env_kwargs or {}).items()))) if reuse else None
    env = _take_cached_env(key) if key is not None else None
    # The one place the reuse is decided: an env kept from an episode of the same BDDL, resolution
    # and render setting is reset again; a render-free one in place (`physics.seeded_reset_in_place`:
    # the same start, bit for bit). A rendered env keeps robosuite's hard reset: it compiles outside
    # the model cache, and what writes into its model for the pixels (LIBERO's burner sites, the
    # perturbation layer) is not covered by the in-place reset's proof.
    in_place = env is not None and not render and physics.can_reset_in_place(env)
    try:
        if env is None:
            env = make_env(
                task, resolution, bddl_file=bddl if level == "scene" else None, render=render, **(env_kwargs or {})
            )
    except VProError:
        raise
    except Exception as exc:
        raise SimulatorError(f"case {case['id']}: building the env failed ({type(exc).__name__}: {exc})") from exc
    wrapper = None
    if level == "observation" and render:
        try:
            wrapper = CaseObserver(env, case, trial, task)
        except Exception:
            _close_quietly(env)
            raise
    return CaseEnv(case, trial, env, states[row], wrapper, hashes, scene, cache_key=key, reset_in_place=in_place)
