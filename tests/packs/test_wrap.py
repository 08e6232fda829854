"""`vpro_assets.wrap(env, case)` keeps LIBERO's env interface and applies the case."""

import numpy as np
import pytest

import vpro_assets
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.env import NOOP_ACTION, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task

TASK = "libero_goal-04"  # its observation cases used here are in the catalog (the allocation left libero_goal-03 without wrist-constant)


@pytest.fixture(scope="module")
def base_env():
    env = make_env(get_task(TASK), 64)
    yield env
    env.close()


def test_fork_loop_sees_the_delayed_view_and_the_current_one(base_env):
    """Against a twin env driven by the same actions (robosuite samples camera frames inside the
    control step, so the clean reference must come from the same loop, not a re-render). LIBERO
    places fixtures from numpy's global stream at every reset; `env.seed` (LIBERO's API, as
    openpi's loop uses it) makes both layouts the same."""
    twin = make_env(get_task(TASK), 64)
    env = vpro_assets.wrap(base_env, f"{TASK}/camera_staleness/third_person-delay1-v1")  # 5 steps
    states = libero_init_states(get_task(TASK))
    env.seed(7)
    env.reset()
    twin.seed(7)
    twin.reset()
    obs, ref = env.set_init_state(states[0]), twin.set_init_state(states[0])
    clean, seen = [ref["agentview_image"]], [obs["agentview_image"]]
    action = np.array([0.3, 0.0, 0.2, 0, 0, 0, -1.0])
    for _ in range(9):
        obs, *_ = env.step(action)
        ref, *_ = twin.step(action)
        clean.append(ref["agentview_image"])
        seen.append(obs["agentview_image"])
        np.testing.assert_array_equal(obs["robot0_eye_in_hand_image"], ref["robot0_eye_in_hand_image"])
    twin.close()
    for t in range(5, 10):
        np.testing.assert_array_equal(seen[t], clean[t - 5])
    assert not np.array_equal(clean[9], clean[4]), "the arm did not move; the test would prove nothing"
    assert env.trial == 1


def test_trial_follows_resets_and_scene_cases_are_refused(base_env):
    env = vpro_assets.wrap(base_env, f"{TASK}/view_unavailability/wrist-constant-v1")
    for expected in range(3):
        assert env.trial == expected
        env.reset()
        obs = env.set_init_state(libero_init_states(get_task(TASK))[expected])
        assert obs["robot0_eye_in_hand_image"].max() == 0
    with pytest.raises(InvalidParameterError, match="changes the scene"):
        vpro_assets.wrap(base_env, "libero_goal-03/task_precondition_variation/receptacle_openness-v1")
    with pytest.raises(InvalidParameterError, match="reset"):
        vpro_assets.wrap(base_env, f"{TASK}/view_unavailability/wrist-constant-v1").step(NOOP_ACTION)


def test_wrap_never_reaches_libero_bridge(base_env, monkeypatch):
    """The fork's env is used as it was built: wrapping, resetting and stepping never reach the
    toolkit's LIBERO bridge (which writes LIBERO's config and locates the asset wheels)."""
    from vpro_assets.libero import bridge, tasks

    state = libero_init_states(get_task(TASK))[0]
    tasks.load_tasks.cache_clear()  # a task looked up through LIBERO would reach the bridge again

    def refuse(*args, **kwargs):
        raise AssertionError("wrap reached the toolkit's LIBERO bridge")

    for name in ("write_libero_config", "assets_root", "libero_root", "libero_envs", "bddl_path", "init_state_path"):
        monkeypatch.setattr(bridge, name, refuse)
    env = vpro_assets.wrap(base_env, f"{TASK}/target_object_masking/ratio50-always-v1")
    env.seed(0)
    env.reset()
    first = env.set_init_state(state)
    obs, *_ = env.step(NOOP_ACTION)
    assert obs["agentview_image"].shape == first["agentview_image"].shape == (64, 64, 3)
