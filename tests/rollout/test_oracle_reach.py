"""The arm's reach (`reach`): how far the wrist may go from the shoulder before the elbow
straightens, and an elbow bent the wrong way brought back (issue: libero_10-03 familiar_position,
the bowl 0.82 m from the arm's base; the elbow went past straight to its limit, and the hand never
came back to close the drawer).
"""

import numpy as np
import pytest
from conftest import build_scene_case, oracle_episode

from vpro_assets.rollout.policies.oracle import reach

NORMAL = "libero_10-03/normal"
FAMILIAR = "libero_10-03/task_relevant_distractors/familiar_position-v1"


def _set_elbow(s, q: float) -> None:
    """Set the elbow joint (no steps: the kinematics only)."""
    import mujoco

    w = s.world
    w.d.qpos[w.m.jnt_qposadr[w.arm_joints[3]]] = q
    mujoco.mj_kinematics(w.m, w.d)
    mujoco.mj_comPos(w.m, w.d)


def test_the_arm_is_as_long_as_its_two_links_and_bent_its_own_way_at_the_start(scene):
    """The Panda's shoulder-to-wrist distance is at most 0.719 m (0.3266 + 0.3928 m), reached with the
    elbow straight at -0.467 rad; at LIBERO's start (-2.46) it is bent its own way, at -0.2 (0.27 rad
    past straight, its limit -0.07) the wrong way, and the distance is shorter on either side: at the
    limit, `wrong_way_shortest` (0.705 m)."""
    s = scene(NORMAL)
    assert len(s.world.arm_joints) == 7
    assert reach.full_length(s.world) == pytest.approx(0.7194, abs=5e-4)
    assert reach.past_straight(s.world) < -1.5
    _set_elbow(s, -0.2)
    assert reach.past_straight(s.world) == pytest.approx(0.267, abs=0.01)
    straight = -0.2 - reach.past_straight(s.world)
    _set_elbow(s, straight)
    assert reach.stretch(s.world) == pytest.approx(reach.full_length(s.world), abs=1e-6)
    lo, hi = s.world.m.jnt_range[s.world.arm_joints[3]]
    _set_elbow(s, hi)
    assert reach.stretch(s.world) < reach.full_length(s.world) - 0.01
    assert reach.wrong_way_shortest(s.world) == pytest.approx(reach.stretch(s.world), abs=1e-6)


def test_a_goal_beyond_reach_comes_within_it(scene):
    """A grip-site goal 0.80 m out and 0.30 m over the table (the bowl's carry) is brought toward the
    shoulder until the wrist is MARGIN_M short of the arm's full length; one within reach, or one
    too high to reach anywhere, stays. A goal 0.77 m out and 0.34 m over the table is lowered until
    it is within reach, but not below its floor."""
    s = scene(NORMAL)
    w = s.world
    limit = reach.full_length(w) - reach.MARGIN_M
    far = np.array([0.14, -0.1, 1.21])
    assert reach.stretch(w, far) > limit
    moved = reach.within(w, far)
    assert reach.stretch(w, moved) == pytest.approx(limit, abs=1e-3)
    assert moved[2] == far[2] and np.linalg.norm(moved[:2] + [0.66, 0.0]) < np.linalg.norm(far[:2] + [0.66, 0.0])
    near = np.array([-0.05, 0.1, 1.1])
    np.testing.assert_array_equal(reach.within(w, near), near)
    too_high = np.array([0.14, -0.1, 2.2])
    np.testing.assert_array_equal(reach.within(w, too_high), too_high)
    high = np.array([0.10, -0.1, 1.25])  # 0.77 m out: within reach from 1.0 to 1.14 m only
    lowered = reach.lowered(w, high, floor=1.0)
    assert 1.1 < lowered[2] < high[2] and reach.stretch(w, lowered) == pytest.approx(limit, abs=1e-3)
    assert reach.lowered(w, high, floor=1.2)[2] == 1.2


@pytest.mark.slow
def test_bowl_far_out_goes_into_the_drawer_and_the_drawer_closes():
    """libero_10-03 familiar_position trial 0: the bowl 0.83 m from the arm's base. The carry rose
    1.2 m high 0.80 m out and the elbow went past straight to its limit; the hand then stayed 2.7 cm
    short of where it turns to close the drawer (0 of 10 trials). Now the approach and the carry keep
    the wrist within reach and an elbow past straight is brought back before the carry: solved in
    about as many steps as the Normal task (344). The scene is built first (a no-op when current)."""
    build_scene_case(FAMILIAR)
    row = oracle_episode(FAMILIAR, 0)
    assert row["success"] and row["steps"] < 420
