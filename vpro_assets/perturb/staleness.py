"""Camera Staleness: one view shows an older clean frame of its own; the other stays current.

Which step's frame is shown is `schedules.stale_source_step` (delay by k steps, freeze at a step,
or replay a window of history). The view keeps only the clean frames it may still show, so memory
stays bounded over long episodes. Nothing is rendered: the frames are the env's own renders.
Before the delay has elapsed, a delayed view shows the first frame of the episode.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vpro_assets.benchmark.taxonomy import VIEWS
from vpro_assets.perturb.base import Episode, Perturbation, Step, param
from vpro_assets.perturb.schedules import stale_frames_needed, stale_source_step


class Staleness(Perturbation):
    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.camera = param(
            case_id, params, "camera", str, lambda v: v in VIEWS.values(), f"one of {', '.join(VIEWS.values())}"
        )
        self.mode = param(case_id, params, "mode", str, lambda v: v in ("delay", "freeze", "replay"))
        self.params: dict[str, int] = {}
        if self.mode == "delay":
            self.params["delay_steps"] = param(case_id, params, "delay_steps", int, lambda v: v >= 1)
        elif self.mode == "freeze":
            self.params["freeze_step"] = param(case_id, params, "freeze_step", int, lambda v: v >= 0)
        else:
            self.params["replay_start"] = param(case_id, params, "replay_start", int, lambda v: v >= 1)
            self.params["replay_window"] = param(
                case_id,
                params,
                "replay_window",
                int,
                lambda v: 1 <= v <= params["replay_start"],
                "between 1 and replay_start",
            )
        self.buffer: dict[int, np.ndarray] = {}

    def reset(self, episode: Episode) -> None:
        self.buffer = {}

    def source_step(self, step: int) -> int:
        return stale_source_step(self.mode, step, **self.params)

    def apply(self, frames, step: Step) -> None:
        if self.camera not in step.clean:
            return
        t = step.index
        self.buffer[t] = step.clean[self.camera]
        source = self.source_step(t)
        keep = stale_frames_needed(self.mode, t, **self.params)
        self.buffer = {s: f for s, f in self.buffer.items() if s in keep or s == source}
        if source != t and self.camera in frames:
            frames[self.camera] = self.buffer[source]
            step.note(self.camera, f"stale: frame of step {source}")
