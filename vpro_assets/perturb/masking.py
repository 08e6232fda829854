"""Target-Object, Target-Receptacle and Interaction-Cue Masking.

Entity masking covers `ratio` of the entity's visible pixels in each view with a flat grey
occluder (`occluder_gray`), only on the steps its schedule selects. The covered pixels are those
furthest along a direction drawn once per trial and view, so the occluder is one flat patch
sweeping across the entity from one side, and it covers exactly round(ratio * n) of the n
visible pixels of every frame.

Interaction-cue masking covers a whole region on every step: the gripper (hand and fingers),
the gripper-object contact region (pixels within `dilation_px` of both the gripper and the
target), or the placement contact region (pixels within `dilation_px` of both the target and
the receptacle). `dilation_px` is stated at 256 px and scaled with the frame height. A contact
region is empty, and nothing is covered, while the two entities do not meet in the image.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vpro_assets.benchmark.taxonomy import MASK_SCHEDULES, VIEWS
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.perturb.base import Episode, Perturbation, Step, param
from vpro_assets.perturb.imageops import meeting_region, occlude, partial_mask, scaled_px
from vpro_assets.perturb.schedules import mask_active

REGIONS = ("gripper", "gripper_object_contact", "placement_contact")


def _cameras(case_id: str, views) -> tuple[str, ...]:
    if views == "both":
        return tuple(VIEWS.values())
    if views in VIEWS:
        return (VIEWS[views],)
    raise InvalidParameterError(f"case {case_id}: views={views!r}; expected 'both' or one of {', '.join(VIEWS)}")


def _gray(case_id: str, params: Mapping) -> int:
    return param(case_id, params, "occluder_gray", int, lambda v: 0 <= v <= 255, "a uint8 grey level")


class EntityMasking(Perturbation):
    needs_extra_render = True

    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.entity = param(case_id, params, "entity", str, lambda v: v in ("target", "receptacle"))
        self.ratio = float(param(case_id, params, "ratio", (int, float), lambda v: 0 < v <= 1, "in (0, 1]"))
        self.schedule = param(
            case_id, params, "schedule", str, lambda v: v in MASK_SCHEDULES, f"one of {', '.join(MASK_SCHEDULES)}"
        )
        self.gray = _gray(case_id, params)
        self.camera_names = _cameras(case_id, params.get("views", "both"))
        self.mask_labels = (self.entity,)
        if getattr(task, self.entity) is None:
            raise InvalidParameterError(f"case {case_id}: task {task.key} has no {self.entity} to mask")
        self.angles: dict[str, float] = {}

    def reset(self, episode: Episode) -> None:
        self.angles = {cam: float(episode.rng(f"mask-sweep/{cam}").uniform(0, 2 * np.pi)) for cam in self.camera_names}

    def apply(self, frames, step: Step) -> None:
        if not mask_active(self.schedule, step.phase):
            return
        for cam in self.camera_names:
            if cam not in frames:
                continue
            mask = step.masks.mask(cam, self.entity)
            if not mask.any():
                continue
            cover = mask if self.ratio >= 1 else partial_mask(mask, self.ratio, self.angles[cam])
            frames[cam] = occlude(frames[cam], cover, self.gray)
            step.note(cam, f"mask {self.entity} {int(cover.sum())}/{int(mask.sum())} px")


class CueMasking(Perturbation):
    needs_extra_render = True

    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.region = param(case_id, params, "region", str, lambda v: v in REGIONS, f"one of {', '.join(REGIONS)}")
        ratio = param(case_id, params, "ratio", (int, float))
        schedule = param(case_id, params, "schedule", str)
        if ratio != 1.0 or schedule != "always":
            raise InvalidParameterError(
                f"case {case_id}: interaction-cue masking covers the whole region on "
                f"every step (ratio 1.0, schedule 'always'), got ratio={ratio!r} "
                f"schedule={schedule!r}"
            )
        self.dilation_px = param(case_id, params, "dilation_px", int, lambda v: 0 <= v <= 64, "0..64 px")
        self.gray = _gray(case_id, params)
        self.camera_names = _cameras(case_id, params.get("views", "both"))
        self.mask_labels = {
            "gripper": ("gripper",),
            "gripper_object_contact": ("gripper", "target"),
            "placement_contact": ("target", "receptacle"),
        }[self.region]
        need = {"gripper_object_contact": "target", "placement_contact": "receptacle"}.get(self.region)
        if need and getattr(task, need) is None:
            raise InvalidParameterError(f"case {case_id}: task {task.key} has no {need} for the {self.region} region")

    def region_mask(self, masks, cam: str) -> np.ndarray:
        radius = scaled_px(self.dilation_px, masks.shapes[cam][0])
        if self.region == "gripper":
            return masks.mask(cam, "gripper")
        a, b = ("gripper", "target") if self.region == "gripper_object_contact" else ("target", "receptacle")
        if not masks.may_meet(cam, a, b, radius):  # apart in the image: nothing to draw or cover
            return np.zeros(masks.shapes[cam], dtype=bool)
        return meeting_region(masks.mask(cam, a), masks.mask(cam, b), radius)

    def apply(self, frames, step: Step) -> None:
        for cam in self.camera_names:
            if cam not in frames:
                continue
            region = self.region_mask(step.masks, cam)
            if region.any():
                frames[cam] = occlude(frames[cam], region, self.gray)
                step.note(cam, f"mask {self.region} {int(region.sum())} px")
