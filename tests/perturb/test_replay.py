"""Every masking setting on a real scripted rollout (slow): one clean rollout of libero_spatial-00
is recorded with its semantic masks and phase states, then replayed through each of the 35
masking settings; the masked share of the entity's pixels is within 3 points of the ratio on
every frame where the entity shows at least 50 pixels, and nothing is masked outside the schedule."""

from __future__ import annotations

import numpy as np
import pytest

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.core import paths
from vpro_assets.libero.env import CAMERAS, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb import PerturbedEnv
from vpro_assets.perturb.base import Episode, MaskSource, Step
from vpro_assets.perturb.imageops import meeting_region, scaled_px
from vpro_assets.perturb.phases import PhaseState
from vpro_assets.perturb.pipeline import FAMILIES
from vpro_assets.perturb.schedules import mask_active
from vpro_assets.rollout.policies.scripted import PickPlaceController

pytestmark = pytest.mark.slow
TASK, RES, MAX_STEPS = "libero_spatial-00", 128, 200
MASK_SETTINGS = [
    s
    for s in tx.SETTINGS
    if s.category in ("target_object_masking", "target_receptacle_masking", "interaction_cue_masking")
]


class Recorded:
    """The masks of one recorded step, in MaskSource's interface."""

    def __init__(self, masks, shapes):
        self._masks, self.shapes, self.renders = masks, shapes, 0

    def mask(self, cam, label):
        return self._masks[(cam, label)]


@pytest.fixture(scope="module")
def recording():
    task = get_task(TASK)
    env = make_env(task, RES)
    try:
        wrapped = PerturbedEnv(env, None, task)
        obs = wrapped.reset(trial=0, init_state=libero_init_states(task)[0])
        controller = PickPlaceController(env.sim, task)
        steps = []
        for t in range(MAX_STEPS):
            source = MaskSource(env.sim, wrapped.pipeline.entities, dict.fromkeys(CAMERAS, (RES, RES)))
            masks = {
                (c, label): source.mask(c, label) for c in CAMERAS for label in ("target", "receptacle", "gripper")
            }
            tr = wrapped.pipeline.tracker
            state = PhaseState(t, tr.phase, tr.grasp_onset, tr.placement_onset)
            steps.append(({c: obs[f"{c}_image"] for c in CAMERAS}, masks, state))
            if controller.stage == "done":
                break
            obs, *_ = wrapped.step(controller.action())
        return task, steps
    finally:
        env.close()


def test_the_recording_goes_through_every_phase(recording):
    _, steps = recording
    assert list(dict.fromkeys(st.phase for _, _, st in steps)) == [
        "approach",
        "grasp",
        "transport",
        "pre_placement",
        "placed",
    ]


@pytest.mark.parametrize("setting", MASK_SETTINGS, ids=[s.id.removeprefix("vpro/") for s in MASK_SETTINGS])
def test_masking_on_a_real_rollout(recording, setting):
    task, steps = recording
    catalog = load_catalog(paths.catalog_path())
    case = next(c for c in catalog["cases"] if c["setting"] == setting.id)
    p = case["params"]
    pert = FAMILIES[setting.category](case["id"], p, task)
    pert.reset(Episode(case["id"], 0, task))
    checked = 0
    for clean, masks, state in steps:
        frames = dict(clean)
        pert.apply(frames, Step(state.step, state, clean, Recorded(masks, dict.fromkeys(CAMERAS, (RES, RES)))))
        for cam in CAMERAS:
            diff = np.any(frames[cam] != clean[cam], axis=-1)
            if setting.category == "interaction_cue_masking":
                radius = scaled_px(p["dilation_px"], RES)
                region = (
                    masks[(cam, "gripper")]
                    if p["region"] == "gripper"
                    else meeting_region(
                        *[
                            masks[(cam, x)]
                            for x in {
                                "gripper_object_contact": ("gripper", "target"),
                                "placement_contact": ("target", "receptacle"),
                            }[p["region"]]
                        ],
                        radius,
                    )
                )
                assert not (diff & ~region).any() and np.all(frames[cam][region] == p["occluder_gray"])
                checked += bool(region.any())
                continue
            entity = masks[(cam, p["entity"])]
            if not mask_active(p["schedule"], state):
                assert not diff.any(), f"step {state.step} ({state.phase}): masked outside the schedule"
                continue
            assert not (diff & ~entity).any()
            if entity.sum() >= 50:
                assert abs(diff[entity].mean() - p["ratio"]) <= 0.03
                checked += 1
    assert checked > 0, "no frame exercised the setting"
