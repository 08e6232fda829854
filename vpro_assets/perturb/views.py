"""View Unavailability: one camera is removed from what the policy receives.

- `single_view`: the camera's image key is absent from the observation and the camera is left
  out of `cameras()` (the wrapper's `available_cameras`), so adapters know to feed one view;
- `constant`: its image is a constant frame of `constant_value` (black by default);
- `duplicate`: its image is a copy of the remaining camera's frame of the same step (after the
  remaining view's own perturbations, if any were composed before this one).
No extra render: the removed camera is still rendered by the env (LIBERO renders every camera it
was built with), its frame is just not shown.
"""

from __future__ import annotations

from collections.abc import Mapping

from vpro_assets.benchmark.taxonomy import VIEWS
from vpro_assets.perturb.base import Perturbation, Step, param

REPLACEMENTS = ("single_view", "constant", "duplicate")


class ViewUnavailability(Perturbation):
    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.camera = param(
            case_id, params, "camera", str, lambda v: v in VIEWS.values(), f"one of {', '.join(VIEWS.values())}"
        )
        self.replacement = param(
            case_id, params, "replacement", str, lambda v: v in REPLACEMENTS, f"one of {', '.join(REPLACEMENTS)}"
        )
        self.value = 0
        if self.replacement == "constant":
            self.value = param(case_id, params, "constant_value", int, lambda v: 0 <= v <= 255, "a uint8 level")
        self.other = next(c for c in VIEWS.values() if c != self.camera)

    def cameras(self, cameras):
        return tuple(c for c in cameras if c != self.camera) if self.replacement == "single_view" else cameras

    def apply(self, frames, step: Step) -> None:
        if self.camera not in frames:
            return
        if self.replacement == "single_view":
            del frames[self.camera]
        elif self.replacement == "constant":
            frames[self.camera] = frames[self.camera].copy()
            frames[self.camera][...] = self.value
        else:
            frames[self.camera] = frames[self.other].copy()
        step.note(self.camera, self.replacement)
