"""When a perturbation is on: mask schedules, corruption bursts and stale-frame indices.

Pure functions of the step index, the phase state and a seeded generator, tested on synthetic
timelines. Step 0 is the observation at reset; each env step adds one.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.benchmark.taxonomy import MASK_SCHEDULES
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.perturb.phases import PLACED, PhaseState

PLACEMENT_PHASES = ("pre_placement", PLACED)


def mask_active(schedule: str, state: PhaseState) -> bool:
    """Whether an entity mask with this schedule covers the observation of `state.step`."""
    if schedule == "always":
        return True
    if schedule == "before_grasp":
        return state.grasp_onset is None or state.step < state.grasp_onset
    if schedule == "after_grasp":
        return state.grasp_onset is not None and state.step >= state.grasp_onset
    if schedule == "around_placement":
        return state.phase in PLACEMENT_PHASES
    raise InvalidParameterError(f"unknown mask schedule {schedule!r}; known: {', '.join(MASK_SCHEDULES)}")


class BurstSchedule:
    """Corruption bursts at a frequency: at every step one uniform draw; outside a burst, a draw
    below `onset_prob` starts a burst covering this step and the next `burst_steps - 1`.

    One draw per step whatever happens, so the schedule of step t depends only on the seed and
    t, and it is the same for every policy and every run of the trial.
    """

    def __init__(self, generator: np.random.Generator, onset_prob: float, burst_steps: int):
        self.generator, self.onset_prob, self.burst_steps = generator, onset_prob, burst_steps
        self._until = -1  # last step of the current burst
        self._next = 0
        self.onsets: list[int] = []

    def active(self, step: int) -> bool:
        if step != self._next:
            raise InvalidParameterError(f"burst schedule asked for step {step}, expected {self._next}")
        self._next += 1
        u = self.generator.random()
        if step > self._until and u < self.onset_prob:
            self._until = step + self.burst_steps - 1
            self.onsets.append(step)
        return step <= self._until


def stale_source_step(
    mode: str, step: int, *, delay_steps: int = 0, freeze_step: int = 0, replay_start: int = 0, replay_window: int = 0
) -> int:
    """The step whose clean frame a stale view shows at `step`.

    delay: step - delay (the first frame until `delay` steps have passed);
    freeze: the current frame until `freeze_step`, then the frame of `freeze_step` for ever;
    replay: the current frame until `replay_start`, then a loop over the `replay_window`
    frames just before it (replay_start - window ... replay_start - 1).
    """
    if mode == "delay":
        return max(step - delay_steps, 0)
    if mode == "freeze":
        return min(step, freeze_step)
    if mode == "replay":
        if step < replay_start:
            return step
        return replay_start - replay_window + (step - replay_start) % replay_window
    raise InvalidParameterError(f"unknown staleness mode {mode!r}; known: delay, freeze, replay")


def stale_frames_needed(mode: str, step: int, **params) -> set[int]:
    """Steps whose frames must still be kept after `step` (for the buffer of a stale view)."""
    if mode == "delay":
        return set(range(max(step - params["delay_steps"] + 1, 0), step + 1))
    if mode == "freeze":
        return {min(step, params["freeze_step"])}
    start, window = params["replay_start"], params["replay_window"]
    return {s for s in range(start - window, start) if s <= step}
