"""Close a hinged door (the microwave's) by pushing its free edge around the hinge.

The door is the body the fixture's hinge joint moves. Its free edge is its point farthest from the
hinge axis; the closing direction at a point is the axis crossed with the door's direction, signed
toward the closed end of the joint's range. The closed fingers stand on the near side of the door,
a little inside its edge, and follow the door's arc, always aiming a little ahead of its current
angle, until LIBERO's `Close` check holds. Opening a closed door would need a grasp of its edge
from outside; it is not in the oracle yet (no base task asks for it).
"""

from __future__ import annotations

import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, geom_corners, quat_matrix
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import joint_for
from vpro_assets.rollout.policies.oracle.motion import CLOSE, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

LEAD_RAD = 0.25  # aim this far ahead of the door's current angle
EDGE_INSET = 0.8  # push at this fraction of the door's radius
STANDOFF_M = 0.03  # grip site this far from the door's face before pushing


def _door_frame(world: World, joint) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """(hinge anchor, unit direction hinge -> free edge, radius, half thickness, mid height)."""
    pts = geom_corners(world.m, world.d, world.joint_geoms(joint.id))
    anchor = world.d.xanchor[joint.id].copy()
    rel = pts[:, :2] - anchor[:2]
    far = rel[np.argmax(np.linalg.norm(rel, axis=1))]
    u = np.append(far / np.linalg.norm(far), 0.0)
    normal = np.array([-u[1], u[0], 0.0])
    thick = float(np.abs(rel @ normal[:2]).max())
    return anchor, u, float(np.linalg.norm(far)), thick, float((pts[:, 2].min() + pts[:, 2].max()) / 2)


def open_(world: World, region: str) -> Actions:
    raise SkillFailed(f"{region}: opening a closed door is not supported by the oracle yet")
    yield  # a generator like every skill


def close(world: World, region: str) -> Actions:
    joint = joint_for(world, region)
    goal = ("close", region)
    if world.holds(goal):
        return
    axis = world.d.xaxis[joint.id].copy()
    sign = -np.sign(joint.open_end - joint.closed_end)  # the joint's direction of closing
    anchor, u, radius, thick, mid_z = _door_frame(world, joint)
    push_dir = np.cross(axis * sign, u)  # motion of the door's points while it closes
    r = radius * EDGE_INSET
    orient = world.eef_mat()
    start = anchor + u * r - push_dir * (thick + STANDOFF_M)
    start[2] = mid_z
    yield from motion.move_to(world, start + [0, 0, 0.12], CLOSE, orient, tol=0.015, max_steps=150)
    yield from motion.move_to(world, start, CLOSE, orient, tol=0.01, max_steps=80, speed=0.6)
    for _ in range(220):
        if world.holds(goal):
            break
        ahead = quat_matrix(axis_angle_quat(axis * sign, LEAD_RAD))
        _, u_now, _, _, _ = _door_frame(world, joint)
        u_goal = ahead @ u_now
        n_goal = np.cross(axis * sign, u_goal)
        target = anchor + u_goal * r - n_goal * (thick * 0.5)
        target[2] = mid_z
        yield motion.action_to(world, target, CLOSE, orient, speed=0.6)
    yield from motion.move_to(
        world, world.eef() - push_dir * 0.05 + [0, 0, 0.05], CLOSE, orient, tol=0.02, max_steps=30
    )
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not close (hinge at {world.qpos(joint.id):.3f})")
