"""Grasps from an object's own geometry (narrowest width, handles, pinches clear of neighbours, the
sway check) and the pick that lifts with them, on real LIBERO envs (render-free). Pinches under an
overhang: test_oracle_overhang.py; upside-down objects by their foot: test_oracle_foot.py.

Each skill test runs one skill alone from a task's first initial state (the `scene` fixture) and
checks LIBERO's own predicate, not the skill's opinion of itself.
"""

import numpy as np
import pytest
from conftest import build_scene_case, catalog_case, oracle_episode

from vpro_assets.rollout.case_env import env_for_case
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.oracle import grasp as grasp_mod
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import (
    Grasp,
    plan_grasp,
    sloped_close,
)
from vpro_assets.rollout.policies.oracle.hand import reach_height
from vpro_assets.rollout.policies.oracle.pick import SWAY_M, SWAY_STEPS, close_on_wall, pick
from vpro_assets.rollout.policies.oracle.pick_place import pick_place
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy, libero_holds
from vpro_assets.rollout.policies.oracle.shape import above, narrowest
from vpro_assets.rollout.policies.oracle.world import World


def test_narrowest_width_of_a_turned_box_and_the_top_of_a_tapered_solid():
    """The width a grasp closes across: a 6 x 12 cm box turned 30 degrees is 6 cm across (its
    world box is 11.2 cm); a frustum 8.2 cm square at its foot and 5 cm at its top, 8 cm tall, cut
    1 cm below its top, is 5.4 cm across (its top vertices alone say 5 cm)."""
    c, s_ = np.cos(np.radians(30)), np.sin(np.radians(30))
    box = np.array([[x, y, z] for x in (-0.03, 0.03) for y in (-0.06, 0.06) for z in (0.0, 0.1)])
    turned = box @ np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]]).T
    axis, width = narrowest(turned)
    assert width == pytest.approx(0.06, abs=1e-4) and abs(axis @ [c, s_, 0]) == pytest.approx(1.0, abs=1e-3)
    assert np.ptp(turned[:, 0]) > 0.11
    square = np.array([[x, y] for x in (-1, 1) for y in (-1, 1)])
    frustum = np.r_[np.c_[square * 0.041, np.zeros(4)], np.c_[square * 0.025, np.full(4, 0.08)]]
    assert narrowest(frustum)[1] == pytest.approx(0.082)
    assert narrowest(above([frustum], 0.07))[1] == pytest.approx(0.054)
    assert len(above([frustum], 0.09)) == 0


def _box(lo, hi):
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def test_handle_of_a_shell_of_convex_pieces_found_past_a_piece_bridging_it_to_the_lid():
    """A deformed moka pot as coacd leaves it: a shell of small wall pieces (radius 4.5 cm), a lid,
    and a C-shaped handle 1.5 cm thick sticking out 4.5 cm at -y, one convex piece bridging the lid
    and the handle's top bar (whole, that piece made the part sticking out 4 cm wide and a wall
    piece was taken for the handle: 0/10). The handle is found at -y however the pot is turned,
    and where none sticks out (a round shell) none is."""
    ring = [
        _box(
            [0.045 * np.cos(a) - 0.006, 0.045 * np.sin(a) - 0.006, 0.0],
            [0.045 * np.cos(a) + 0.006, 0.045 * np.sin(a) + 0.006, 0.13],
        )
        for a in np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ]
    lid = [_box([-0.04, -0.04, 0.12], [0.04, 0.04, 0.135])]
    handle_ = [
        _box([-0.0075, -0.09, 0.04], [0.0075, -0.08, 0.125]),  # outer bar
        _box([-0.0075, -0.09, 0.04], [0.0075, -0.05, 0.05]),  # lower arm
        _box([-0.0075, -0.09, 0.115], [0.0075, -0.05, 0.125]),  # top arm
    ]
    # A wedge from the lid (7 cm across) to the handle's top arm (1.5 cm).
    bridge = [
        np.array(
            [
                [x * w, y, z]
                for x, y, w in [(1, -0.02, 0.035), (-1, -0.02, 0.035), (1, -0.085, 0.0075), (-1, -0.085, 0.0075)]
                for z in (0.115, 0.13)
            ]
        )
    ]
    pot = ring + lid + handle_ + bridge
    assert grasp_mod.handle(ring + lid) is None
    for yaw in (0.0, 0.7, 2.5):
        turn = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
        found = grasp_mod.handle([h @ turn.T for h in pot])
        assert found is not None and found @ (turn @ [0, -1, 0]) > np.cos(np.radians(15)), yaw
        part = grasp_mod.outer_part([h @ turn.T for h in pot], turn @ [0, -1, 0])
        assert np.ptp(part[:, :2] @ (turn @ [1, 0, 0])[:2]) < grasp_mod.HANDLE_MAX_M  # the bridge cut there
    assert np.ptp(bridge[0][:, 0]) > grasp_mod.HANDLE_MAX_M


def test_solid_pinch_turns_the_hand_away_from_a_standing_neighbour(scene):
    """libero_object-01's cream cheese: closing across its narrowest direction, the open hand (its
    palm 21 cm long along the closing axis) would stop on a neighbour more than 2 cm above the
    grasp; the grasp turns until the hand comes down all the way, and the pick lifts it."""
    s = scene("libero_object-01/normal")
    obj = "cream_cheese_1"
    grasp = plan_grasp(s.world, obj)
    boxes = obstacle_boxes(s.world, (obj,))
    narrow_axis = narrowest(s.world.points(obj))[0]
    assert reach_height(boxes, grasp.point, narrow_axis) > grasp.point[2] + 0.02
    assert reach_height(boxes, grasp.point, grasp.axis) <= grasp.point[2]
    z0 = s.world.body_pos(obj)[2]
    s.run(pick(s.world, obj), limit=200)
    assert s.world.body_pos(obj)[2] - z0 > 0.05 and s.world.held(obj)


def test_a_pinch_of_sides_sloping_in_toward_the_top_closes_gently():
    """A 1.8 cm tall block 10 x 4.8 cm at its foot, pinched across its 4.8 cm 8 mm over it: tapered
    to 5.8 x 2.8 cm at its top (each side 0.56 in per unit of rise across the fingers,
    libero_object-06's butter at taper-s3), the fingers close to SLOPED_SQUEEZE_M inside its width
    and hold there (8-13 N a finger, not 20); tapered to 3.6 cm (0.33, taper-s2), straight-sided,
    or narrowing across the fingers but not along them (its top turned, as a twisted box's), they
    close fully."""

    def block(top, top_length):
        return [
            np.r_[
                _box([-0.05, -0.024, 0.0], [0.05, 0.024, 0.0])[::2],
                _box([-top_length / 2, -top / 2, 0.018], [top_length / 2, top / 2, 0.018])[::2],
            ]
        ]

    pinch = Grasp(np.array([0.0, 0.0, 0.008]), np.array([0.0, 1.0, 0.0]), 0.048, rim=False)
    gentle = sloped_close(block(0.028, 0.058), pinch).close_to
    assert gentle == pytest.approx(0.048 - grasp_mod.SLOPED_SQUEEZE_M)
    assert sloped_close(block(0.036, 0.075), pinch).close_to is None
    assert sloped_close(block(0.048, 0.1), pinch).close_to is None
    assert sloped_close(block(0.028, 0.1), pinch).close_to is None


@pytest.mark.slow
@pytest.mark.parametrize(
    "case_id, trial",
    [
        ("libero_object-06/target_geometry_variation/taper-s3-v1", 2),
        ("libero_object-01/target_geometry_variation/taper-s3-v1", 0),
    ],
)
def test_tapered_box_held_through_the_carry_into_the_basket(case_id, trial):
    """libero_object-06 taper-s3 trial 2: closed fully on its sides sloping in, the butter slid down
    out of the fingers on the way to the basket (the gap shrinking 1.8 cm in 80 steps) and the episode
    ran out (4 of 10 trials). libero_object-01 taper-s3 trial 0: closed to 2 mm inside its width
    (1 N a finger), the cream cheese did not come up. Closed to SLOPED_SQUEEZE_M inside, both are
    carried in. The scenes are built first."""
    row = oracle_episode(case_id, trial, build=True)
    assert row["success"] and row["steps"] < 200


def test_pick_place_bowl_onto_plate(scene):
    s = scene("libero_goal-08/normal")
    s.run(pick_place(s.world, "akita_black_bowl_1", "on", "plate_1"), limit=280)
    assert s.holds(("on", "akita_black_bowl_1", "plate_1")) and s.cenv.success()


def test_pick_takes_the_bowl_out_of_the_drawer_under_the_cabinet_top(scene):
    """libero_spatial-04: the bowl stands in the open top drawer of a cabinet turned 64 degrees,
    its back rim 1 cm under the cabinet's top panel. It is slid out from under the panel along
    the drawer and lifted, early enough for the suite's 220 steps."""
    s = scene("libero_spatial-04/normal")
    bowl = "akita_black_bowl_1"
    z0 = s.world.body_pos(bowl)[2]
    steps = s.run(pick(s.world, bowl), limit=120)
    assert s.world.body_pos(bowl)[2] - z0 > 0.08 and s.world.held(bowl), steps


def test_pick_lifts_objects_of_other_shapes(scene):
    """A can lying in the basket scene and a wine bottle standing: the grasp comes from geometry."""
    for case_id, obj in (("libero_object-05/normal", "tomato_sauce_1"), ("libero_goal-09/normal", "wine_bottle_1")):
        s = scene(case_id)
        z0 = s.world.body_pos(obj)[2]
        s.run(pick(s.world, obj), limit=250)
        assert s.world.body_pos(obj)[2] - z0 > 0.05, obj
        assert s.world.held(obj), obj


class _Swaying:
    """A hand whose grip site follows a script of offsets along x, one per action taken."""

    def __init__(self, offsets, touch_at=10**6):
        self.offsets, self.taken, self.touch_at = offsets, 0, touch_at

    def eef(self):
        return np.array([self.offsets[min(self.taken, len(self.offsets) - 1)], 0.0, 1.0])

    def eef_mat(self):
        return motion.DOWN.copy()

    def touching(self, instance):
        return {"gripper"} if self.taken >= self.touch_at else set()


def _take(world, actions):
    out = []
    for action in actions:
        out.append(action)
        world.taken += 1
    return np.array(out)


def test_wall_pinch_closes_only_while_the_hand_stays_over_it():
    """`close_on_wall`: a hand that stays put, or sways less than SWAY_M and back (libero_spatial-05:
    up to 7 mm), closes as `motion.gripper` does (the same actions); one that sways farther
    (libero_spatial-07: 1.4 cm toward the arm's base after the descent, back in about 20 steps)
    has its fingers stopped (gripper action 0) and is held where the close began while it is more
    than SWAY_M off, then closes the rest of the 12 steps; one that does not come back closes after
    SWAY_STEPS; one whose fingers already touch the object closes on."""
    for small in ([0.0], [0.0, 0.001, 0.003, 0.005, 0.007, 0.007, 0.006, 0.004, 0.002, 0.0]):
        world = _Swaying(small)
        closed = _take(world, close_on_wall(world, "bowl", motion.DOWN))
        world = _Swaying(small)
        np.testing.assert_array_equal(closed, _take(world, motion.gripper(world, motion.CLOSE, orient=motion.DOWN)))
    sway = [0.0, 0.004, 0.008, 0.011, 0.013, 0.014, 0.012, 0.009, 0.004, 0.0]
    world = _Swaying(sway)
    actions = _take(world, close_on_wall(world, "bowl", motion.DOWN))
    np.testing.assert_array_equal(actions[:, 6], [1, 1, 1, 0, 0, 0, 0] + [1] * 9)
    assert np.all(actions[3:7, 0] < 0)  # pulled back toward where the close began
    assert sway[3] > SWAY_M > sway[7]
    world = _Swaying([0.0, 0.0, 0.015])
    stuck = _take(world, close_on_wall(world, "bowl", motion.DOWN))
    np.testing.assert_array_equal(stuck[:, 6], [1, 1] + [0] * SWAY_STEPS + [1] * 10)
    # A finger on the object (libero_spatial-07's multipeak-s3 lobe): the close goes on, swayed or not.
    world = _Swaying(sway, touch_at=4)
    touched = _take(world, close_on_wall(world, "bowl", motion.DOWN))
    np.testing.assert_array_equal(touched[:, 6], [1, 1, 1, 0] + [1] * 9)


@pytest.mark.slow
def test_bowl_on_the_stove_near_the_arms_base_pinched_after_the_sway():
    """libero_spatial-07 twist-s1 trial 0 (the bowl on the stove, 36 cm from the arm's base): the
    hand sways 1.3 cm off the wall pinch as the fingers close; closed there, the bowl slipped out
    during the carry and the episode ran out (220 steps). Closing once the hand is back, it is
    solved (151 steps). The scene is built first."""
    row = oracle_episode("libero_spatial-07/target_geometry_variation/twist-s1-v2", 0, build=True)
    assert row["success"] and row["steps"] < 200


@pytest.mark.slow
@pytest.mark.parametrize(
    "case_id",
    [
        "libero_spatial-00/target_geometry_variation/taper-s2-v1",
        "libero_object-03/task_precondition_variation/object_pose-v1",
        "libero_10-00/target_geometry_variation/twist-s3-v2",  # a twisted can pinched at its narrower top
        "libero_object-00/target_geometry_variation/taper-s3-v1",  # 8.2 cm across its hulls: pinched at its 5 cm top
        "libero_10-02/target_geometry_variation/asymmetric-s3-v1",  # a shell of pieces: taken by its handle
        # the bowl displaced 0.88 m from the arm's base: its wall pinched within reach (`grasp.within_reach`)
        "libero_spatial-04/task_relevant_distractors/familiar_position-v1",
        # an inverted bowl in the drawer 0.76 m out: approached at half speed, closed at rest (`pick.settle`)
        "libero_spatial-04/task_precondition_variation/object_pose-v1",
    ],
)
def test_deformed_or_reposed_target_lifted_and_placed(case_id):
    """A deformed bowl, a deformed can and a target in another pose: grasped from their own geometry. The scene is
    built first (`vpro build --select CASE`, a no-op when it is current)."""
    build_scene_case(case_id)
    case = catalog_case(case_id)
    cenv = env_for_case(case, 0, render=False, reuse=False)
    try:
        cenv.reset()
        world = World(cenv.sim, cenv.task, libero_holds(cenv.env))
        target = cenv.task.target
        z0 = world.body_pos(target)[2]
        for n, action in enumerate(pick(world, target), 1):
            cenv.step(action)
            assert n < 300
        assert world.body_pos(target)[2] - z0 > 0.05 and world.held(target)
    finally:
        cenv.close()
    row = run_episode(case, 1, OraclePolicy(), EpisodeSettings(render=False))
    assert row["success"], case_id
