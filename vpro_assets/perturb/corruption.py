"""Temporary Observation Corruption: full-frame blackout or additive noise in both views.

Triggers: `frequency` (bursts of `burst_steps` steps, each started with probability `onset_prob`
per step, see `schedules.BurstSchedule`, seeded per case and trial) or `phase` (every step the
phase tracker places in the named phase). Noise is Gaussian with `noise_std` (uint8 units),
rounded and clipped; its field for (trial, camera, step) comes from its own seed, so it is
reproducible and independent of the frame, of the policy and of which other steps were corrupted.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vpro_assets.benchmark.taxonomy import PHASES
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.perturb.base import Episode, Perturbation, Step, param
from vpro_assets.perturb.imageops import add_noise, blackout
from vpro_assets.perturb.masking import _cameras
from vpro_assets.perturb.schedules import BurstSchedule


class Corruption(Perturbation):
    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.mode = param(case_id, params, "mode", str, lambda v: v in ("blackout", "noise"), "blackout or noise")
        self.trigger = param(case_id, params, "trigger", str, lambda v: v in ("frequency", "phase"))
        if self.trigger == "frequency":
            self.onset_prob = float(param(case_id, params, "onset_prob", (int, float), lambda v: 0 <= v <= 1))
            self.burst_steps = param(case_id, params, "burst_steps", int, lambda v: v >= 1)
        else:
            self.phase = param(case_id, params, "phase", str, lambda v: v in PHASES, f"one of {', '.join(PHASES)}")
        if self.mode == "noise":
            self.noise_std = float(param(case_id, params, "noise_std", (int, float), lambda v: v > 0))
        self.camera_names = _cameras(case_id, params.get("views", "both"))
        self.episode: Episode | None = None
        self.bursts: BurstSchedule | None = None
        self.corrupted_steps: list[int] = []

    def reset(self, episode: Episode) -> None:
        self.episode = episode
        self.corrupted_steps = []
        if self.trigger == "frequency":
            self.bursts = BurstSchedule(episode.rng("corruption-bursts"), self.onset_prob, self.burst_steps)

    def active(self, step: Step) -> bool:
        if self.bursts is not None:  # frequency-triggered
            return self.bursts.active(step.index)
        return step.phase.phase == self.phase

    def noise(self, camera: str, step: int, shape) -> np.ndarray:
        if self.episode is None:
            raise InvalidParameterError(f"case {self.case_id}: reset the perturbation before use")
        gen = self.episode.rng(f"corruption-noise/{camera}/{step}")
        return gen.standard_normal(shape, dtype=np.float32) * np.float32(self.noise_std)

    def apply(self, frames, step: Step) -> None:
        if not self.active(step):
            return
        self.corrupted_steps.append(step.index)
        for cam in self.camera_names:
            if cam not in frames:
                continue
            if self.mode == "blackout":
                frames[cam] = blackout(frames[cam])
            else:
                frames[cam] = add_noise(frames[cam], self.noise(cam, step.index, frames[cam].shape))
            step.note(cam, self.mode)
