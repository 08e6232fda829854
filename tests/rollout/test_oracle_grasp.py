"""Grasps from an object's own geometry (narrowest width, handles, pinches clear of neighbours and
overhangs) and the pick that lifts with them, on real LIBERO envs (render-free).

Each skill test runs one skill alone from a task's first initial state (the `scene` fixture) and
checks LIBERO's own predicate, not the skill's opinion of itself.
"""

from dataclasses import replace

import numpy as np
import pytest
from conftest import OracleScene, build_scene_case, catalog_case, oracle_episode

from vpro_assets.rollout.case_env import env_for_case
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.oracle import drawer, motion
from vpro_assets.rollout.policies.oracle import grasp as grasp_mod
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.foot import solid_below, top_face_up
from vpro_assets.rollout.policies.oracle.grasp import (
    ROBOT_BASE_XY,
    Grasp,
    foot_grasp,
    plan_grasp,
    side_entry,
    sloped_close,
)
from vpro_assets.rollout.policies.oracle.hand import FINGER_HALF_WIDTH_M, FINGER_THICK_M, WITH_WRIST, reach_height
from vpro_assets.rollout.policies.oracle.overhang import blocked as overhang_blocked
from vpro_assets.rollout.policies.oracle.overhang import lands_clear, overhang_pinch, placed_parts
from vpro_assets.rollout.policies.oracle.pick import SWAY_M, SWAY_STEPS, close_on_wall, inner_way, pick
from vpro_assets.rollout.policies.oracle.pick_place import pick_place
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy, libero_holds
from vpro_assets.rollout.policies.oracle.shape import MAX_PINCH_M, SOLID_TOP_M, above, narrowest
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


def test_side_entry_shifts_the_hand_along_the_wall_until_it_comes_down_beside_the_overhang():
    """A wall pinch at the origin, fingers closing along x, under an overhang over the palm's inner
    end (x from 9.5 cm, y up to 0, its bottom above the palm's top: the hand fits under it but cannot
    come down through it): the hand comes down 3.5 cm along y (the palm is 3.3 cm half wide; the wrist,
    9 cm along x, is clear of it; the other way the overhang reaches 10 cm) and slides in. Nothing
    over the hand, or a pinch that is not a wall's: no shift."""
    grasp = Grasp(np.array([0.0, 0.0, 0.02]), np.array([1.0, 0.0, 0.0]), 0.024, rim=True)
    overhang = np.array([[[0.095, -0.1, 0.15], [0.2, 0.0, 0.2]]])
    assert reach_height(overhang, grasp.point, grasp.axis, WITH_WRIST) > grasp.point[2]
    np.testing.assert_allclose(side_entry(overhang, grasp), [0.0, 0.035, 0.0], atol=1e-9)
    assert not side_entry(overhang + [0.03, 0.0, 0.0], grasp).any()  # past the palm's end: straight down
    assert not side_entry(overhang, replace(grasp, rim=False)).any()


def _ring_bowl(r_in: float = 0.040, r_out: float = 0.046, height: float = 0.05) -> list[np.ndarray]:
    """A bowl's wall as 24 convex blocks between radii `r_in` and `r_out` around the origin."""
    half = r_out * np.tan(np.pi / 24)
    blocks = []
    for ang in 2 * np.pi * np.arange(24) / 24:
        out, side = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
        blocks.append(
            np.array([[*(out * r + side * t), z] for r in (r_in, r_out) for t in (-half, half) for z in (0.0, height)])
        )
    return blocks


def test_pinch_under_an_overhang_comes_straight_down_with_the_wrist_beside_it():
    """A bowl (walls 4.0-4.6 cm from its centre) under an overhang 13.3 cm over the pinch height, over
    x > 1 cm and y < -1 cm (libero_goal-03's opened drawer over a bowl, taper-s3 trials 2-5, 8, 9):
    with the wrist modelled on both sides no radial side is free from above (the sideways entry then
    landed the inner finger on the rim). With the hand's parts where the yaw puts them, a pinch
    is found the open hand comes straight down to: one finger inside the mouth, the other outside the
    wall, the axis turned off the radial direction. With nothing overhead, the radial pinch nearest
    the robot."""
    hulls, z, robot = _ring_bowl(), 0.015, np.array([-1.0, 0.0, 0.0])
    drawer_front = np.array([[[0.01, -0.3, z + 0.133], [0.3, -0.01, z + 0.2]]])
    for ang in np.radians(np.arange(0, 360, 22.5)):
        out = np.array([np.cos(ang), np.sin(ang), 0.0])
        assert reach_height(drawer_front, out * 0.034 + [0, 0, z], out, WITH_WRIST) > z
    point, left = overhang_pinch(hulls, drawer_front, z, robot, lambda left: True)
    assert not overhang_blocked(drawer_front, point, left)
    radii = sorted(float(np.linalg.norm(c[:2])) for c, *_ in placed_parts(point, left)[:2])
    assert radii[0] + np.hypot(FINGER_THICK_M / 2, FINGER_HALF_WIDTH_M) < 0.040 and radii[1] > 0.046 + 0.011
    radial = point[:2] / np.linalg.norm(point[:2])
    assert abs(float(radial @ left[:2])) < np.cos(np.radians(5))  # turned off the radial direction
    # The sideways entry it replaces: 2 cm along the wall the inner finger comes down in the mouth;
    # 4 cm along, 1.1 cm over its edge, on the rim (kept only to RIM_SLACK_M over).
    wall_pinch = np.array([-0.034, 0.0, z])
    assert lands_clear(hulls, wall_pinch + [0, 0.02, 0], robot)
    assert not lands_clear(hulls, wall_pinch + [0, 0.04, 0], robot)
    free, left = overhang_pinch(hulls, np.zeros((0, 2, 3)), z, robot, lambda left: True)
    np.testing.assert_allclose(free, [-0.034, 0.0, z], atol=1e-3)
    np.testing.assert_allclose(np.abs(left), [1.0, 0.0, 0.0], atol=1e-9)


@pytest.mark.slow
def test_tapered_bowl_under_the_opened_drawer_lifted_by_a_pinch_the_wrist_clears():
    """libero_goal-03 taper-s3 trial 2 (4/10 before): the bowl's -y side stands under the opened top
    drawer. The sideways entry came down 5 cm along the wall, the inner finger on the rim (-0.082,
    0.047, 0.943), and sliding in link7 met the drawer's front (wooden_cabinet_1_g11); the episode
    ran out in the pick. Now the pinch is planned with the wrist on its side: the hand turns so (the
    left finger toward the planned axis), comes straight down touching nothing of the cabinet, and
    lifts the bowl in under 150 steps. The scene is built first."""
    case_id, bowl = "libero_goal-03/target_geometry_variation/taper-s3-v1", "akita_black_bowl_1"
    build_scene_case(case_id)
    s = OracleScene(case_id, 2)
    try:
        s.run(drawer.open_(s.world, "wooden_cabinet_1_top_region"), limit=130)
        grasp = plan_grasp(s.world, bowl)
        assert grasp.sided and not grasp.entry.any()
        z0, touched, steps = s.world.body_pos(bowl)[2], set(), 0
        for steps, action in enumerate(pick(s.world, bowl), 1):
            s.cenv.step(action)
            touched |= {s.world.root_name(g) for g in _robot_contacts(s.world)}
            if s.world.finger_gap() < 0.03:  # closed: the left finger toward the planned axis
                assert float(s.world.finger_axis() @ grasp.axis) > 0.95
            assert steps < 150
        assert "wooden_cabinet_1" not in touched
        assert s.world.body_pos(bowl)[2] - z0 > 0.05 and s.world.held(bowl)
    finally:
        s.close()


def _robot_contacts(world: World) -> list[int]:
    """The geoms the robot (arm or gripper) touches now."""
    out = []
    for con in world.d.contact[: world.d.ncon]:
        robot = [
            world.m.body(world.m.geom_bodyid[g]).name.startswith(("robot0", "gripper0")) for g in (con.geom1, con.geom2)
        ]
        if robot[0] != robot[1]:
            out.append(con.geom2 if robot[0] else con.geom1)
    return out


@pytest.mark.parametrize("trial", [4, 6])
def test_bowl_under_the_opened_drawer_is_taken_from_beside_it(scene, trial):
    """libero_goal-03 ("open the top drawer and put the bowl inside"): once open, the drawer's front
    stands 10 cm over the bowl's rim, over part of it. The drawer opens in under 130 steps (the hand
    turns on its way to the handle and lets go of it in 4 steps). The wall pinch is then one the hand
    and its wrist reach down to, straight (trial 6: not the side where the wrist meets the drawer's
    front) or, where no radial side is (trial 4: the palm's end under the drawer), one planned with the
    wrist on its side (`overhang`) or beside it, sliding in along the wall; and the bowl comes up."""
    s = scene("libero_goal-03/normal", trial)
    region, bowl = "wooden_cabinet_1_top_region", "akita_black_bowl_1"
    steps = s.run(drawer.open_(s.world, region), limit=130)
    assert s.holds(("open", region)), steps
    grasp = plan_grasp(s.world, bowl)
    boxes = obstacle_boxes(s.world, (bowl,))
    if grasp.sided:
        assert trial == 4 and not grasp.entry.any() and not overhang_blocked(boxes, grasp.point, grasp.axis)
    else:
        entry = side_entry(boxes, grasp)
        assert reach_height(boxes, grasp.point + entry, grasp.axis, WITH_WRIST) <= grasp.point[2]
        assert entry.any() or trial != 4
        np.testing.assert_array_equal(grasp.entry, entry)  # the planned grasp carries it: `pick` measures it no more
    z0 = s.world.body_pos(bowl)[2]
    s.run(pick(s.world, bowl), limit=150)
    assert s.world.body_pos(bowl)[2] - z0 > 0.05 and s.world.held(bowl)


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


def test_inverted_bowl_lifted_by_its_foot(scene):
    """libero_spatial-00's precondition object pose: the akita bowl stands upside down, rim on the
    table. Its top is a 4.6 cm foot a few millimetres over shoulders sloping out to 9 cm, so the
    fingertips land on the shoulders, which squeeze it down and out of a full close; the fingers
    take the foot's sides, closed only to just inside it, and lift it clear of the table and hold
    it. The scene is built first (a no-op when it is current)."""
    case_id = "libero_spatial-00/task_precondition_variation/object_pose-v1"
    build_scene_case(case_id)
    s = scene(case_id)
    bowl = s.cenv.task.target
    w = s.world
    assert w.d.xmat[w.entity(bowl).root][8] < -0.9  # the case keeps the bowl upside down
    grasp = plan_grasp(w, bowl)
    assert grasp.squeeze_to is not None and grasp.squeeze_to < grasp.width <= MAX_PINCH_M
    z0 = w.body_pos(bowl)[2]
    s.run(pick(w, bowl), limit=150)
    s.run(motion.hold_still(w, w.hold_grip, 20), limit=25)
    assert w.body_pos(bowl)[2] - z0 > 0.05 and w.held(bowl)


CABINET_BOWL = "libero_spatial-09/task_precondition_variation/object_pose-v1"


@pytest.mark.parametrize("trial", [0, 5])
def test_inverted_bowl_far_out_on_the_cabinet_lifted_in_time(scene, trial):
    """libero_spatial-09's precondition object pose: the akita bowl upside down on the wooden
    cabinet's top (1.18 m), its foot's pinch 0.75 m (trial 0) and 0.77 m (trial 5) from the arm's
    base, near the farthest the arm reaches with the hand pointing down. Coming down on it from
    above, the arm straightened its elbow to its limit and the hand stayed 1 cm over and beyond the
    pinch (1 of 10 trials solved). Reached from nearer the base (`pick.come_out`), the bowl is lifted
    and held within 140 steps, leaving the carry to the plate its 70-80 of the suite's 220. The scene
    is built first (a no-op when it is current)."""
    build_scene_case(CABINET_BOWL)
    s = scene(CABINET_BOWL, trial)
    w = s.world
    bowl = s.cenv.task.target
    assert w.d.xmat[w.entity(bowl).root][8] < -0.9  # upside down
    grasp = plan_grasp(w, bowl)
    assert grasp.squeeze_to is not None and np.linalg.norm(grasp.point[:2] - ROBOT_BASE_XY) > 0.745
    assert inner_way(w, bowl, grasp) is not None
    z0 = w.body_pos(bowl)[2]
    s.run(pick(w, bowl), limit=140)
    s.run(motion.hold_still(w, w.hold_grip, 20), limit=25)
    assert w.body_pos(bowl)[2] - z0 > 0.05 and w.held(bowl)


def test_no_way_in_from_nearer_the_base_past_an_open_drawers_front(scene):
    """libero_spatial-04's inverted bowl lies in the open drawer, as far out (0.76 m) and high as the
    cabinet's: 4 cm nearer the base the drawer's front stands over the fingertips' way out, so
    `inner_way` finds none and the pinch is come down on from above (`pick.settle`)."""
    case_id = "libero_spatial-04/task_precondition_variation/object_pose-v1"
    build_scene_case(case_id)
    s = scene(case_id)
    bowl = s.cenv.task.target
    grasp = plan_grasp(s.world, bowl)
    assert grasp.squeeze_to is not None and np.linalg.norm(grasp.point[:2] - ROBOT_BASE_XY) > 0.75
    assert inner_way(s.world, bowl, grasp) is None


@pytest.mark.slow
@pytest.mark.parametrize("trial", [1, 5, 8])
def test_inverted_bowl_on_the_cabinet_placed_on_the_plate(trial):
    """The farthest of libero_spatial-09's inverted bowls on the cabinet (0.77 m out) are solved within
    the suite's 220 steps (before: none of them)."""
    row = oracle_episode(CABINET_BOWL, trial, build=True)
    assert row["success"], row["steps"]


class _Hulls:
    """The part of a World `foot_grasp` reads: an object's collision hulls."""

    def __init__(self, hulls):
        self._hulls = hulls

    def hulls(self, instance):
        return self._hulls


def _turned(hulls, about, angle, axis):
    """Hulls turned by `angle` about the horizontal unit `axis` through the point `about`."""
    c, s_ = np.cos(angle), np.sin(angle)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + s_ * k + (1 - c) * k @ k
    return [(h - about) @ rot.T + about for h in hulls]


def test_foot_of_an_inverted_bowl_level_or_tilted_and_none_on_an_upright_bowls_narrowed_rim(scene):
    """LIBERO's akita bowl (libero_spatial-00, its 40 collision boxes). Upright, the vertical line
    through its middle meets the bowl only at its floor, 4.5 cm under the rim; turned upside down,
    at its foot's top. An upright bowl whose rim a taper narrowed to 6.6 cm looks like a foot from
    above (a 1 mm slice fits the fingers and stands over the middle): no foot grasp, the top is
    not solid. Upside down and tilted 2.4 degrees (libero_spatial-05's bowl on the ramekin), a
    level 1 mm slice is a crescent off the middle; measured square to the top face (the face's
    normal, from the highest hull), the foot is found as when level, its pinch over the middle."""
    s = scene("libero_spatial-00/normal")
    upright = s.world.hulls("akita_black_bowl_1")
    pts = np.concatenate(upright)
    lo, hi = pts.min(0), pts.max(0)
    mid = (lo + hi) / 2
    assert 0.04 < solid_below(upright, hi[2]) < 0.05
    inverted = [h * [1, 1, -1] + [0, 0, lo[2] + hi[2]] for h in upright]
    assert solid_below(inverted, hi[2]) < 0.001
    # The taper: horizontal scale falling linearly from 1 at the bottom to 0.62 at the rim.
    flat = np.array([1.0, 1.0, 0.0])
    narrowed = [
        h * [0, 0, 1] + mid * flat + (h - mid) * flat * (1 - 0.38 * (h[:, 2:] - lo[2]) / (hi[2] - lo[2]))
        for h in upright
    ]
    assert narrowest(above(narrowed, hi[2] - 0.001))[1] < MAX_PINCH_M - 0.004  # the rim fits the fingers
    assert solid_below(narrowed, hi[2]) > SOLID_TOP_M and foot_grasp(_Hulls(narrowed), "bowl") is None
    level = foot_grasp(_Hulls(inverted), "bowl")
    assert level is not None and level.squeeze_to is not None
    np.testing.assert_array_equal(top_face_up(inverted), [0.0, 0.0, 1.0])
    tilt, axis = np.radians(2.4), np.array([0.6, -0.8, 0.0])
    tilted = _turned(inverted, mid, tilt, axis)
    up = top_face_up(tilted)
    assert np.degrees(np.arccos(up[2])) == pytest.approx(2.4, abs=0.01)
    top = max(h[:, 2].max() for h in tilted)
    crescent = above(tilted, top - 0.001)
    assert np.linalg.norm(crescent[:, :2].mean(0) - mid[:2]) > 0.01  # the level slice is off the middle
    grasp = foot_grasp(_Hulls(tilted), "bowl")
    assert grasp is not None and grasp.squeeze_to is not None
    assert np.linalg.norm(grasp.point[:2] - mid[:2]) < 0.003
    assert grasp.width == pytest.approx(level.width, abs=0.003)
    # The grip site as high over the foot's top at its middle as when level (within the tilt's mm).
    face = max((h @ up).max() for h in tilted)
    level_top = max(h[:, 2].max() for h in inverted)
    assert (face - up[:2] @ grasp.point[:2]) / up[2] - grasp.point[2] == pytest.approx(
        level_top - level.point[2], abs=0.0015
    )


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
