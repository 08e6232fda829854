"""`wrap_case_env(env, case, trial=...)`: the pipeline as an observer of an env driven by someone else.

The rollout layer (`vpro_assets.rollout.case_env.CaseEnv`) resets and steps LIBERO's env itself
and tells this observer about each raw observation:

    obs = env.reset(); obs = env.set_init_state(state); observer.on_reset(obs)
    observer.on_step(obs)                       # after every env.step, wait steps included
    observer.policy_images(obs, t)              # camera -> raw frame, None for a removed view
    observer.feed_predicted(frames)             # camera -> (h, w, 3) or a chunk (H, h, w, 3)
    observer.phase_timeline()                   # JSON-ready phase changes and onsets

Because the env's first observation of an episode is rendered before `on_reset` can bind the
per-camera scene edits of Cross-View Contradiction to the freshly built sim, `on_reset` re-renders
the edited camera once for that observation (one extra frame per episode, none per step).
A chunk of predicted frames is consumed one frame per following step; a single frame predicts
the next observation.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping

import numpy as np

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.names import CAMERAS
from vpro_assets.libero.task_record import TaskRecord
from vpro_assets.perturb.pipeline import ObservationPipeline, build_pipeline, image_key
from vpro_assets.perturb.rendering import render_rgb


class CaseObserver:
    def __init__(
        self,
        env,
        case: Mapping,
        trial: int,
        task: TaskRecord | None = None,
        pipeline: ObservationPipeline | None = None,
    ):
        if pipeline is None:
            if task is None:
                raise InvalidParameterError(f"case {case.get('id')}: CaseObserver needs the case's task or a pipeline")
            pipeline = build_pipeline(case, task)
        self.env, self.case, self.trial = env, case, trial
        self.pipeline = pipeline
        self._current: dict | None = None
        self._queue: dict[str, deque] = {}

    @property
    def available_cameras(self) -> tuple[str, ...]:
        return self.pipeline.available_cameras

    def on_reset(self, obs: Mapping) -> dict:
        sim = self.env.sim
        self.pipeline.reset(self.trial, sim)
        self._queue = {}
        raw = dict(obs)
        if self.pipeline.hook is not None:
            for cam, edit in self.pipeline.hook.edits.items():
                key = image_key(cam)
                if key in raw:
                    h, w = raw[key].shape[:2]
                    raw[key] = render_rgb(sim, cam, w, h, edit)
        self._current = self.pipeline.observe(raw, sim)
        return self._current

    def on_step(self, obs: Mapping) -> dict:
        if self._current is None:
            raise InvalidParameterError(f"case {self.pipeline.case_id}: on_reset must come before on_step")
        predicted = {cam: q.popleft() for cam, q in self._queue.items() if q}
        self._current = self.pipeline.observe(obs, self.env.sim, predicted or None)
        return self._current

    def feed_predicted(self, frames: Mapping[str, np.ndarray] | None) -> None:
        for cam, value in (frames or {}).items():
            arr = np.asarray(value)
            if arr.ndim == 3:
                arr = arr[None]
            if arr.ndim != 4:
                raise InvalidParameterError(
                    f"case {self.pipeline.case_id}: predicted frames for {cam} must be "
                    f"(h, w, 3) or (H, h, w, 3), got shape {arr.shape}"
                )
            self._queue[cam] = deque(arr)

    def policy_images(self, obs: Mapping, step: int) -> dict:
        current = self._current if self._current is not None else obs
        return {cam: current.get(image_key(cam)) for cam in CAMERAS}

    def phase_timeline(self) -> dict:
        timeline = self.pipeline.phase_timeline()
        if timeline:
            timeline = dict(timeline, changes=[[s, p] for s, p in timeline["changes"]])
        return timeline


def wrap_case_env(env, case: Mapping, trial: int, task: TaskRecord) -> CaseObserver:
    return CaseObserver(env, case, trial, task)
