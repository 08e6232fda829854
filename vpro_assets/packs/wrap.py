"""`vpro_assets.wrap(env, case)`: a case's observation perturbations inside a fork's own loop.

A fork's evaluation script (openpi's LIBERO example, OpenVLA-OFT's, LeRobot's) builds LIBERO's
`OffScreenRenderEnv` and calls `reset()`, `set_init_state(state)` and `step(action)`. The wrapper
keeps exactly that interface and returns the case's perturbed observations (raw, bottom-up frames,
as LIBERO returns them, so the fork's own flips and resizes still apply):

    env = vpro_assets.wrap(OffScreenRenderEnv(**env_args), case)   # case id, or a pack's case JSON
    for episode in range(num_trials):
        env.reset()
        obs = env.set_init_state(initial_states[episode])           # trial = episode, automatically
        ...
        obs, reward, done, info = env.step(action)

The trial (which seeds the case's random streams) is the number of `reset()` calls made before,
as in those loops; set `env.trial` before `reset()` to choose it. Under single-view View
Unavailability the removed camera's key is absent from the observation (`env.available_cameras`
lists what the policy receives).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Mapping

from vpro_assets.core.errors import InvalidParameterError


def _load_case(case: Mapping | str | Path) -> dict:
    if isinstance(case, Mapping):
        return dict(case)
    text = str(case)
    if text.endswith(".json") and Path(text).is_file():
        return json.loads(Path(text).read_text())
    from vpro_assets.core import paths
    from vpro_assets.benchmark.catalog import find_case
    from vpro_assets.benchmark.catalog import load_catalog

    return find_case(load_catalog(paths.catalog_path()), text)


class ForkEnv:
    def __init__(self, env, case: Mapping | str | Path):
        if not all(hasattr(env, m) for m in ("reset", "step", "set_init_state", "sim")):
            raise InvalidParameterError(f"wrap() needs a LIBERO env (OffScreenRenderEnv), got {type(env).__name__}")
        self.env = env
        self.case = _load_case(case)
        if self.case.get("level") == "scene":
            raise InvalidParameterError(f"case {self.case['id']} changes the scene: build its env from the pack's "
                                        "BDDL instead of wrapping the base task's env")
        self.trial = 0
        self._observer = None

    def __getattr__(self, name):
        if name in ("env", "case", "_observer"):
            raise AttributeError(name)
        return getattr(self.env, name)

    @property
    def available_cameras(self) -> tuple[str, ...]:
        return self._require().available_cameras

    def _require(self):
        if self._observer is None:
            raise InvalidParameterError(f"case {self.case['id']}: call reset() before using the env")
        return self._observer

    def reset(self):
        from vpro_assets.perturb import wrap_case_env

        raw = self.env.reset()
        self._observer = wrap_case_env(self.env, self.case, self.trial)
        self.trial += 1
        return self._observer.on_reset(raw)

    def set_init_state(self, state):
        # LIBERO's loops set the initial state right after reset: the episode (step 0) starts here.
        return self._require().on_reset(self.env.set_init_state(state))

    def step(self, action, predicted_frames: Mapping | None = None):
        observer = self._require()
        observer.feed_predicted(predicted_frames)
        raw, reward, done, info = self.env.step(action)
        return observer.on_step(raw), reward, done, info

    def phase_timeline(self) -> dict:
        return self._require().phase_timeline()


def wrap(env, case: Mapping | str | Path) -> ForkEnv:
    """Wrap a fork's LIBERO env so its observations follow `case` (an observation-level case)."""
    return ForkEnv(env, case)
