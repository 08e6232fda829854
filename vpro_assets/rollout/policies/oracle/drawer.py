"""Open and close a drawer by its handle, along the slide joint's axis.

Opening: the handle is the part of the drawer that sticks out farthest along the opening direction
(the joint's world axis, signed toward the open end of its range). The fingers, pre-closed to fit
between handle and front panel, come down around it, close, and pull along the axis until LIBERO's
`Open` check holds. Closing: the closed fingers push on the handle along the axis until LIBERO's
`Close` check holds (the cabinets count as closed only once pushed fully home).
"""
from __future__ import annotations

import numpy as np

from vpro_assets.core.mjgeom import geom_corners
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import Joint, joint_for
from vpro_assets.rollout.policies.oracle.grasp import grasp_orientation
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

HANDLE_DEPTH_M = 0.012  # geoms within this of the outermost point along the axis form the handle
PRESHAPE_GAP_M = 0.035  # finger opening while coming down around the handle
PULL_STEPS = 160
PUSH_STANDOFF_M = 0.03


def open_direction(world: World, joint: Joint) -> np.ndarray:
    """World direction the drawer front moves when the drawer opens."""
    return world.d.xaxis[joint.id] * joint.open_sign


def handle_point(world: World, joint: Joint) -> np.ndarray:
    """Centre of the handle: the drawer's collision geoms that stick out farthest along the axis."""
    axis = open_direction(world, joint)
    geoms = world.joint_geoms(joint.id)
    reach = {g: float((geom_corners(world.m, world.d, [g]) @ axis).max()) for g in geoms}
    front = max(reach.values())
    handle = [g for g, r in reach.items() if r > front - HANDLE_DEPTH_M]
    pts = geom_corners(world.m, world.d, handle)
    return (pts.min(0) + pts.max(0)) / 2


def _preshape(world: World, gap: float, orient) -> motion.Actions:
    for _ in range(20):
        if world.finger_gap() <= gap:
            break
        yield motion.action_to(world, world.eef(), CLOSE, orient)


def open_(world: World, region: str, attempts: int = 2) -> Actions:
    joint = joint_for(world, region)
    goal = ("open", region)
    for _ in range(attempts):
        if world.holds(goal):
            return
        axis = open_direction(world, joint)
        handle = handle_point(world, joint)
        orient = grasp_orientation(world, axis)
        yield from motion.move_to(world, handle + [0, 0, 0.08], OPEN, orient, tol=0.012, max_steps=150)
        yield from _preshape(world, PRESHAPE_GAP_M, orient)
        yield from motion.move_to(world, handle, 0.0, orient, tol=0.006, max_steps=80, speed=0.5)
        yield from motion.gripper(world, CLOSE, orient=orient)
        travel = abs(joint.open_end - world.qpos(joint.id))
        start = world.eef()
        for _ in range(PULL_STEPS):
            if world.holds(goal):
                break
            yield motion.action_to(world, start + axis * (travel + 0.01), CLOSE, orient, speed=0.5)
        yield from motion.gripper(world, OPEN, orient=orient)
        yield from motion.move_to(world, world.eef() - axis * 0.03 + [0, 0, 0.06], OPEN, orient, tol=0.015,
                                  max_steps=40)
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not open (joint at {world.qpos(joint.id):.3f})")


def close(world: World, region: str) -> Actions:
    joint = joint_for(world, region)
    goal = ("close", region)
    if world.holds(goal):
        return
    axis = open_direction(world, joint)
    handle = handle_point(world, joint)
    orient = world.eef_mat()
    start = handle + axis * PUSH_STANDOFF_M
    yield from motion.move_to(world, start + [0, 0, 0.08], CLOSE, orient, tol=0.012, max_steps=150)
    yield from motion.move_to(world, start, CLOSE, orient, tol=0.008, max_steps=80, speed=0.6)
    travel = abs(world.qpos(joint.id) - joint.closed_end)
    for _ in range(PULL_STEPS):
        if world.holds(goal):
            break
        yield motion.action_to(world, start - axis * (travel + PUSH_STANDOFF_M + 0.02), CLOSE, orient, speed=0.6)
    yield from motion.move_to(world, world.eef() + axis * 0.03 + [0, 0, 0.05], CLOSE, orient, tol=0.015,
                              max_steps=30)
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not close (joint at {world.qpos(joint.id):.3f})")
