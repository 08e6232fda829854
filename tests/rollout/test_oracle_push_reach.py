"""A plate pushed from inside where its far rim is out of the hand's reach (issue 13: libero_goal-05
familiar_position, the plate displaced to 0.84-0.86 m from the arm's base; Normal: 0.71 m): the
push starts within reach, the hand tipped outward, along a route that keeps the hand within reach.
"""

import numpy as np
import pytest
from conftest import build_scene_case, oracle_episode

from vpro_assets.rollout.policies.oracle import push
from vpro_assets.rollout.policies.oracle.grasp import REACH_M, ROBOT_BASE_XY
from vpro_assets.rollout.policies.oracle.motion import DOWN

FAMILIAR = "libero_goal-05/task_relevant_distractors/familiar_position-v1"


def test_a_start_out_of_reach_moves_along_the_push_and_the_hand_tips_outward():
    """A start 0.89 m out pushed toward the arm's base comes to PUSH_REACH_M, no farther along the
    push than allowed; a start within reach, or on a push away from the base, stays. Beyond REACH_M
    the hand pointing down tips REACH_PITCH_DEG with its fingertips away from the base."""
    inward = np.array([-1.0, 0.0])
    far = ROBOT_BASE_XY + [0.89, 0.0]
    moved = push.within_reach(far, inward, 0.2)
    assert np.linalg.norm(moved - ROBOT_BASE_XY) == pytest.approx(push.PUSH_REACH_M)
    assert np.allclose(push.within_reach(far, inward, 0.03), far + inward * 0.03)  # at most `most`
    assert np.array_equal(push.within_reach(far, -inward, 0.2), far)  # away from the base: nothing to gain
    near = ROBOT_BASE_XY + [0.75, 0.0]
    assert np.array_equal(push.within_reach(near, inward, 0.2), near)
    assert np.array_equal(push.tipped_out(DOWN, ROBOT_BASE_XY + [REACH_M - 0.01, 0.0]), DOWN)
    tipped = push.tipped_out(DOWN, ROBOT_BASE_XY + [0.6, 0.6])
    approach = tipped[:, 2]  # the grip frame's z: from the wrist to the fingertips
    assert np.degrees(np.arccos(-approach[2])) == pytest.approx(push.REACH_PITCH_DEG)
    assert approach[:2] @ [1.0, 1.0] > 0 and abs(approach[:2] @ [1.0, -1.0]) < 1e-9  # outward, not sideways


def test_plate_beyond_reach_pushed_to_the_front_of_the_stove(scene):
    """libero_goal-05 familiar_position trial 4: the plate's body 0.85 m from the arm's base, its far
    rim 0.92 m. The push came down inside the far rim (the hand stopped 0.85 m out, the plate never
    moved) or, once it started within reach, pushed first along y across the arm, the hand stretched
    0.86 m out the whole leg (the plate tilted and stopped): 1 and 5 of 10 trials. Now the route keeps
    the pushing hand within reach, the start is within reach and the hand tips outward: solved. The
    scene is built first (a no-op when it is current)."""
    build_scene_case(FAMILIAR)
    s = scene(FAMILIAR, 4)
    plate = "plate_1"
    pos = s.world.body_pos(plate)[:2]
    assert np.linalg.norm(pos - ROBOT_BASE_XY) > 0.84
    target = s.world.site_pos("main_table_stove_front_region")[:2]
    frm = pos
    for leg in push.push_path(s.world, plate, target):
        assert not push.beyond_reach(s.world, plate, frm, leg.to)
        frm = leg.to
    row = oracle_episode(FAMILIAR, 4)
    assert row["success"] and row["steps"] < 200
