"""Grasps of a bowl standing partly under an overhang (libero_goal-03's bowl under its opened top
drawer): the sideways entry along the wall, and the pinch planned with the wrist on its real side
(`oracle/overhang.py`), on synthetic shapes and real LIBERO envs (render-free)."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import OracleScene, build_scene_case

from vpro_assets.rollout.policies.oracle import drawer
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import (
    Grasp,
    plan_grasp,
    side_entry,
)
from vpro_assets.rollout.policies.oracle.hand import FINGER_HALF_WIDTH_M, FINGER_THICK_M, WITH_WRIST, reach_height
from vpro_assets.rollout.policies.oracle.overhang import blocked as overhang_blocked
from vpro_assets.rollout.policies.oracle.overhang import lands_clear, overhang_pinch, placed_parts
from vpro_assets.rollout.policies.oracle.pick import pick
from vpro_assets.rollout.policies.oracle.world import World


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
