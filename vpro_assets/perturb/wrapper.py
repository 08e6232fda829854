"""`PerturbedEnv`: a LIBERO env whose observations pass through a case's pipeline.

Gymnasium-wrapper idiom: the wrapped env is `.env` (`.unwrapped` is LIBERO's env), arguments are
validated up front, all perturbation state lives in the pipeline and is cleared by `reset`, and the
trial (the seed) is given to `reset`. Attributes not defined here are the wrapped env's.

    env = PerturbedEnv(make_env(task, 256), case, task)
    obs = env.reset(trial=0, init_state=libero_init_states(task)[0])
    obs, reward, done, info = env.step(action)                      # VLA
    obs, reward, done, info = env.step(action, predicted_frames=p)  # frame-predicting model

`reset` calls the env's reset (robosuite rebuilds the sim), binds the pipeline to the new sim,
then loads the initial state (or re-reads the current one) so the first observation is already
perturbed. `info["vpro"]` carries the step, the phase, what each camera got, and the cameras the
policy receives (`available_cameras`: under single-view unavailability one camera is absent from
the observation and from this list, which is how adapters are told).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.task_record import TaskRecord
from vpro_assets.perturb.pipeline import ObservationPipeline, build_pipeline


class PerturbedEnv:
    def __init__(self, env, case: Mapping | str | None, task: TaskRecord, pipeline: ObservationPipeline | None = None):
        if not hasattr(env, "sim") or not hasattr(env, "step"):
            raise InvalidParameterError(f"PerturbedEnv wraps a LIBERO/robosuite env, got {type(env).__name__}")
        self.env = env
        self.task = task
        self.pipeline = pipeline or build_pipeline(case or {"id": f"{task.key}/normal", "setting": None}, task)
        self._started = False

    @property
    def unwrapped(self):
        return getattr(self.env, "env", self.env)

    @property
    def available_cameras(self) -> tuple[str, ...]:
        return self.pipeline.available_cameras

    def __getattr__(self, name):
        if name in ("env", "pipeline"):  # not yet set: avoid recursion during construction
            raise AttributeError(name)
        return getattr(self.env, name)

    def reset(self, *, trial: int, init_state: np.ndarray | None = None) -> dict:
        self.env.reset()
        self.pipeline.reset(trial, self.env.sim)
        state = self.env.get_sim_state() if init_state is None else np.asarray(init_state, dtype=np.float64)
        raw = self.env.set_init_state(state)
        self._started = True
        return self.pipeline.observe(raw, self.env.sim)

    def set_init_state(self, init_state: np.ndarray) -> dict:
        """LIBERO's own call order (reset, then set_init_state) also works: the episode restarts at
        step 0 from this state with the same trial."""
        if self.pipeline.episode is None:
            raise InvalidParameterError(f"case {self.pipeline.case_id}: call reset(trial=...) first")
        self.pipeline.reset(self.pipeline.episode.trial, self.env.sim)
        return self.pipeline.observe(self.env.set_init_state(init_state), self.env.sim)

    def step(self, action, predicted_frames: Mapping[str, np.ndarray] | None = None):
        if not self._started:
            raise InvalidParameterError(f"case {self.pipeline.case_id}: call reset(trial=...) before step()")
        raw, reward, done, info = self.env.step(action)
        obs = self.pipeline.observe(raw, self.env.sim, predicted_frames)
        info = dict(info or {})
        info["vpro"] = self.pipeline.info()
        return obs, reward, done, info

    def phase_timeline(self) -> dict:
        return self.pipeline.phase_timeline()

    def close(self) -> None:
        self.pipeline.detach()
        self.env.close()
