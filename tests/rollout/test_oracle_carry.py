"""The carry of a picked object to where it goes (`pick_place.carry`): the corridor it must clear,
what it leaves behind, and coming down on its way; and the grasp of a wall out of the arm's reach.

libero_spatial-04 ("pick up the black bowl in the top drawer of the wooden cabinet and place it on
the plate", 220 steps) is the scene: the bowl comes out of the drawer of a cabinet turned 64
degrees, a second bowl stands on the cabinet's top beside it, and the plate is 35 cm away at the
far edge of the arm's reach.
"""

import numpy as np
import pytest
from conftest import build_scene_case, oracle_episode

from vpro_assets.rollout.policies.oracle.clearance import object_boxes
from vpro_assets.rollout.policies.oracle.grasp import REACH_M, REACH_SHIFT_M, ROBOT_BASE_XY, within_reach
from vpro_assets.rollout.policies.oracle.pick_place import _plan_gaps, corridor_tops, pick_place


def test_plan_gaps_from_a_shifted_footprint():
    """The distance in plan from an obstacle's box to the nearest of an object's boxes, the object
    shifted along its way: 2 cm beside it, then 7 cm as it moves 5 cm away; corner to corner, the
    diagonal; an obstacle under it, 0."""
    own = np.array([[[0.0, 0.0, 0.0], [0.1, 0.1, 0.05]], [[0.1, 0.0, 0.0], [0.12, 0.02, 0.05]]])
    boxes = np.array(
        [
            [[0.14, 0.0, 0.0], [0.2, 0.1, 0.1]],  # beside the second piece, 2 cm off
            [[0.13, 0.14, 0.0], [0.2, 0.2, 0.1]],  # off the first piece's corner by (3, 4) cm
            [[0.02, 0.02, -0.1], [0.05, 0.05, 0.0]],  # under it
        ]
    )
    gaps = _plan_gaps(boxes, own, np.array([[0.0, 0.0], [-0.05, 0.0]]))
    np.testing.assert_allclose(gaps, [[0.02, 0.07], [0.05, np.hypot(0.08, 0.04)], [0.0, 0.0]], atol=1e-9)


def test_a_grip_point_out_of_reach_is_brought_within_it():
    """A wall pinched 85 cm from the arm's base is taken REACH_SHIFT_M nearer it, along the line to
    the base; one 81 cm out at REACH_M; one within reach where it is; the height is kept."""
    base = np.append(ROBOT_BASE_XY, 0.0)
    far = base + [0.85, 0.0, 0.95]
    np.testing.assert_allclose(within_reach(far), base + [0.85 - REACH_SHIFT_M, 0.0, 0.95], atol=1e-12)
    beyond = base + np.array([0.81 * np.cos(0.3), 0.81 * np.sin(0.3), 1.1])
    moved = within_reach(beyond)
    assert np.linalg.norm(moved[:2] - ROBOT_BASE_XY) == pytest.approx(REACH_M)
    assert np.cross(moved[:2] - ROBOT_BASE_XY, beyond[:2] - ROBOT_BASE_XY) == pytest.approx(0.0, abs=1e-12)
    assert moved[2] == 1.1
    near = base + [0.7, 0.1, 1.0]
    np.testing.assert_array_equal(within_reach(near), near)


def test_corridor_leaves_out_the_bowl_it_moves_away_from(scene):
    """libero_spatial-04 trial 3: the second bowl stands on the cabinet's top 1-2 cm beside the bowl
    in the drawer, its top 6 cm over the drawer's bowl rim; the way to the plate leads away from it.
    Counted (the corridor about the bowl's centre reaches it), it set the carry 5 cm higher than the
    arm reaches over the plate (step limit); left out, the corridor's top is the cabinet's top panel
    by the drawer, and over the plate only the plate's."""
    s = scene("libero_spatial-04/normal", 3)
    w, bowl = s.world, "akita_black_bowl_1"
    box = w.box(bowl)
    margin = float(np.max(box.size[:2])) / 2 + 0.02
    start, plate = w.body_pos(bowl)[:2], w.body_pos("plate_1")[:2]
    other = w.box("akita_black_bowl_2")
    _, counted = corridor_tops(w, start, plate, margin, (bowl,))
    assert counted.max() == pytest.approx(other.hi[2], abs=1e-3)
    _, tops = corridor_tops(w, start, plate, margin, (bowl,), object_boxes(w, bowl))
    assert tops.max() < other.hi[2] - 0.04
    assert tops[-1] == pytest.approx(w.box("plate_1").hi[2], abs=2e-3)


def test_bowl_out_of_the_drawer_carried_low_onto_the_plate(scene):
    """libero_spatial-04 trial 3 (in the certificate at the step limit): pick, carry and set down in
    about 120 steps, the grip site never higher than the arm reaches over the plate, and over the
    plate already on its way down."""
    s = scene("libero_spatial-04/normal", 3)
    w, bowl = s.world, "akita_black_bowl_1"
    plate = w.box("plate_1")
    heights, over_plate = [], []
    for n, action in enumerate(pick_place(w, bowl, "on", "plate_1"), 1):
        s.cenv.step(action)
        heights.append(w.eef()[2])
        if np.all((w.body_pos(bowl)[:2] > plate.lo[:2]) & (w.body_pos(bowl)[:2] < plate.hi[:2])):
            over_plate.append(w.eef()[2])
        assert n < 160
    assert s.holds(("on", bowl, "plate_1")) and s.cenv.success()
    assert max(heights) < 1.23
    assert over_plate and over_plate[0] < max(heights) - 0.02


def test_bowl_tilting_in_the_fingers_is_still_carried_and_set_down():
    """libero_spatial-06 trial 5 (in the certificate: "slipped out of the gripper"): the bowl, pinched
    at its wall, tilts in the fingers on the way and hangs lower than it was taken, but both fingers
    still hold it; it is carried on and set down instead of dropped over the plate by a new pick."""
    row = oracle_episode("libero_spatial-06/normal", 5)
    assert row["success"] and row["steps"] < 160, row["steps"]


@pytest.mark.slow
def test_deformed_bowl_hanging_on_the_open_hand_is_set_down(scene):
    """libero_spatial-09 multipeak-s3 trial 4 (in the certificate at the step limit): the bowl,
    pinched at its wall and released 1 cm over the plate's rim, stays on the opened inner finger
    (jammed between the deformed wall's hull pieces) and came up with the hand; a new pick then took
    it out of the air. Set down with the fingers open and the hand moved toward the bowl's middle
    before it rises, the bowl stays on the plate and the hand leaves it (set down only, it came up
    again with the hand)."""
    case_id = "libero_spatial-09/target_geometry_variation/multipeak-s3-v1"
    build_scene_case(case_id)
    s = scene(case_id, 4)
    w, bowl = s.world, "akita_black_bowl_1"
    s.run(pick_place(w, bowl, "on", "plate_1"), limit=200)
    assert s.holds(("on", bowl, "plate_1")) and s.cenv.success()
    assert "gripper" not in w.touching(bowl)
    assert w.box(bowl).lo[2] < w.box("plate_1").hi[2]


MULTIPEAK_S1 = "libero_spatial-04/target_geometry_variation/multipeak-s1-v1"


@pytest.mark.slow
def test_deformed_bowl_carried_onto_the_far_plate_with_its_elbow_as_bent():
    """libero_spatial-04 multipeak-s1 trial 0 (certified in 180 steps, since at the step limit): the
    elbow, past straight after the pick out of the drawer, was unbent although the carry ends 2 mm
    nearer the shoulder than a wrong-bent elbow reaches; it bent the wrong way again as the carry set
    off (37 steps); over the plate the re-aim stalled three times at one goal (12 more), and the turn
    back upright, 3.4 degrees short of its tolerance, ran its 40 steps. Now the elbow is left as it is,
    a stalled re-aim is not made again and the turn ends once it stalls: 199 steps."""
    build_scene_case(MULTIPEAK_S1)
    row = oracle_episode(MULTIPEAK_S1, 0)
    assert row["success"] and row["steps"] < 205, row["steps"]
