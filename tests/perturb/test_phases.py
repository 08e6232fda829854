"""Phase tracker on scripted privileged-state rollouts, one task per suite (no cameras rendered:
the tracker reads the simulator only). libero_object-00 runs by default; the others are slow."""

from __future__ import annotations

import pytest

from vpro_assets.libero.env import libero_init_states, make_env
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb import PerturbedEnv
from vpro_assets.perturb.phases import ALL_PHASES
from vpro_assets.rollout.policies.scripted import PickPlaceController

MAX_STEPS = 260


def scripted_rollout(key: str):
    task = get_task(key)
    env = make_env(task, 64, use_camera_obs=False)
    try:
        wrapped = PerturbedEnv(env, None, task)
        wrapped.reset(trial=0, init_state=libero_init_states(task)[0])
        policy = PickPlaceController(env.sim, task)
        stages = []
        for _ in range(MAX_STEPS):
            action = policy.action()
            stages.append(policy.stage)
            wrapped.step(action)
            if policy.stage == "done":
                break
        return wrapped.phase_timeline(), stages, bool(env.check_success()), wrapped.pipeline.tracker.history
    finally:
        env.close()


def check_timeline(timeline, stages, history):
    phases = [p for _, p in timeline["changes"]]
    assert phases == list(ALL_PHASES), f"phases seen: {phases}"
    starts = {p: s for s, p in timeline["changes"]}
    g, o = timeline["grasp_onset"], timeline["placement_onset"]
    # grasp onset falls while the fingers close, within the grasp phase; transport starts after it
    assert starts["grasp"] <= g < starts["transport"]
    first_close = stages.index("close")  # the stage of the action that led to observation i + 1
    assert first_close < g <= first_close + 1 + 12
    # the target is lifted only after the controller starts lifting
    assert starts["transport"] > stages.index("lift")
    # pre-placement comes while carrying or lowering, placement onset while lowering or releasing
    assert stages[starts["pre_placement"] - 1] in ("carry", "lower")
    assert o == starts["placed"] and stages[o - 1] in ("carry", "lower", "release")
    assert len(history) == timeline["steps"]


def test_phase_tracker_on_scripted_libero_object_rollout():
    timeline, stages, success, history = scripted_rollout("libero_object-00")
    check_timeline(timeline, stages, history)
    assert success


@pytest.mark.slow
@pytest.mark.parametrize("key", ["libero_spatial-00", "libero_goal-08", "libero_10-00"])
def test_phase_tracker_on_scripted_rollouts_of_every_suite(key):
    timeline, stages, success, history = scripted_rollout(key)
    check_timeline(timeline, stages, history)
