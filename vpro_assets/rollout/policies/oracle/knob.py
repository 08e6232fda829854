"""Turn a stove knob on or off: grasp the knob over its hinge axis and turn the wrist.

The knob is the body the stove's hinge joint moves; the fingers close across its narrowest
horizontal direction (its own geometry, as any grasp) with the grip site on the joint's axis, so
turning the wrist about the vertical turns the knob about its axis. LIBERO's `TurnOn` holds at
qpos >= 0.5, `TurnOff` at qpos < 0: the wrist turns toward the end of the range it needs.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, geom_corners, quat_matrix
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import joint_for
from vpro_assets.rollout.policies.oracle.grasp import grasp_orientation
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.shape import principal_axes
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

TURN_STEP_RAD = 0.15  # wrist turn per goal update
GRIP_BELOW_TOP_M = 0.012


def switch(world: World, fixture: str, on: bool, attempts: int = 2) -> Actions:
    goal = ("turnon" if on else "turnoff", fixture)
    joint = joint_for(world, fixture)
    for _ in range(attempts):
        if world.holds(goal):
            return
        pts = geom_corners(world.m, world.d, world.joint_geoms(joint.id))
        _, minor = principal_axes(pts)
        anchor = world.d.xanchor[joint.id].copy()
        axis = world.d.xaxis[joint.id].copy()
        point = np.array([anchor[0], anchor[1], pts[:, 2].max() - GRIP_BELOW_TOP_M])
        orient = grasp_orientation(world, minor)
        yield from motion.move_to(world, point + [0, 0, 0.08], OPEN, orient, tol=0.012, max_steps=150)
        yield from motion.move_to(world, point, OPEN, orient, tol=0.006, max_steps=80, speed=0.5)
        yield from motion.gripper(world, CLOSE, orient=orient)
        sign = (1.0 if on else -1.0) * float(np.sign(axis[2]) or 1.0)
        turned = orient
        for _ in range(60):
            if world.holds(goal):
                break
            turned = quat_matrix(axis_angle_quat([0, 0, 1], sign * TURN_STEP_RAD)) @ world.eef_mat()
            yield motion.action_to(world, point, CLOSE, turned)
        yield from motion.gripper(world, OPEN, orient=turned)
        yield from motion.move_to(world, world.eef() + [0, 0, 0.08], OPEN, turned, tol=0.015, max_steps=40)
    if not world.holds(goal):
        raise SkillFailed(f"{fixture} not turned {'on' if on else 'off'} (knob at {world.qpos(joint.id):.3f})")
