"""Push a flat object (libero_goal's plate) along the table onto a table region.

The closed fingers come down inside the object's far rim (the side away from the region), just
above its floor, then move toward the region's centre, re-aiming from the object's current body
position each step, until LIBERO's `On` check holds. Pushing from inside keeps the hand over the
object: behind it there may be no room (libero_goal's plate lies 4 cm in front of the cabinet).
The hand turns so the fingers line up across the push (a wider pusher).
"""

from __future__ import annotations

import numpy as np

from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.grasp import grasp_orientation
from vpro_assets.rollout.policies.oracle.motion import CLOSE, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

CONTACT_Z_M = 0.012  # fingertips this high above the object's bottom while pushing
INSIDE_M = 0.03  # fingertips this far inside the object's far edge
PUSH_STEPS = 200
STEP_AHEAD_M = 0.03


def push_to(world: World, obj: str, region: str) -> Actions:
    goal = ("on", obj, region)
    if world.holds(goal):
        return
    target = world.site_pos(region)[:2]
    pos = world.body_pos(obj)[:2]
    direction = target - pos
    if np.linalg.norm(direction) < 1e-6:
        direction = np.array([1.0, 0.0])
    direction /= np.linalg.norm(direction)
    box = world.box(obj)
    proj = (world.points(obj)[:, :2] - pos) @ direction
    reach = -proj.min() - INSIDE_M  # from the body position back to the fingertips
    start = np.append(pos - direction * reach, box.lo[2] + CONTACT_Z_M)
    orient = grasp_orientation(world, np.array([-direction[1], direction[0], 0.0]))
    yield from motion.move_to(world, start + [0, 0, 0.10], CLOSE, orient, tol=0.012, max_steps=150)
    yield from motion.move_to(world, start, CLOSE, orient, tol=0.008, max_steps=80, speed=0.6)
    for _ in range(PUSH_STEPS):
        if world.holds(goal):
            break
        pos = world.body_pos(obj)[:2]
        err = target - pos
        # Keep the fingers behind the object's centre on the line to the target.
        unit = err / (np.linalg.norm(err) + 1e-9)
        # A goal a short step ahead of the fingers' place behind the object: the hand never runs
        # ahead of an object that stopped following.
        aim = np.append(pos - unit * reach + unit * min(float(np.linalg.norm(err)), STEP_AHEAD_M), start[2])
        yield motion.action_to(world, aim, CLOSE, orient, speed=0.5)
    yield from motion.move_to(world, world.eef() + [0, 0, 0.08], CLOSE, orient, tol=0.02, max_steps=30)
    if not world.holds(goal):
        raise SkillFailed(f"{obj} not pushed onto {region} (at {np.round(world.body_pos(obj)[:2], 3).tolist()})")
