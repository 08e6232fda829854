"""Drawers over objects the goal moves: a drawer's sweep and what stands under it.

A drawer's sweep is the world box its collision geoms (front, walls, handle) pass through between
the closed and the open end of its slide joint. An object standing under the sweep (its footprint
within COVER_MARGIN_M of the sweep's, its top below the sweep's bottom) cannot be grasped from above
while the drawer is out: libero_goal's wooden cabinet's top drawer, open, is 10 cm over the akita
bowl's rim, and the palm is 9.3 cm tall. The plan closes such a drawer first when the goal does not
need it open.
"""

from __future__ import annotations

import mujoco
import numpy as np

from vpro_assets.core.mjgeom import geom_corners
from vpro_assets.libero.task_record import TABLE_CATEGORIES
from vpro_assets.rollout.policies.oracle.articulation import LEVELS, Joint, joint_for
from vpro_assets.rollout.policies.oracle.world import World

COVER_MARGIN_M = 0.02  # an object's footprint this close to a drawer's sweep counts as under it
OUT_M = 0.02  # a drawer this far from its closed end stands out over what is in front of its fixture


def drawer_joints(world: World) -> list[Joint]:
    """The slide joints of the scene's fixtures, each named by the region LIBERO's Open and Close
    check for it (`<fixture>_<level>_region`)."""
    out = []
    for fixture, category in world.task.fixtures:
        if category in TABLE_CATEGORIES:
            continue
        regions = [(level, f"{fixture}_{level}_region") for level in LEVELS]
        for level, region in regions:
            if not world.has_site(region) or not world.joints_of(fixture):
                continue
            joint = joint_for(world, region)
            if world.m.jnt_type[joint.id] == mujoco.mjtJoint.mjJNT_SLIDE and level in world.joint_name(joint.id):
                out.append(joint)
    return out


def sweep_box(world: World, joint: Joint) -> tuple[np.ndarray, np.ndarray]:
    """World box (lo, hi) the drawer's geoms pass through between its closed and open ends."""
    pts = geom_corners(world.m, world.d, world.joint_geoms(joint.id))
    q = world.qpos(joint.id)
    ends = [pts + (end - q) * world.d.xaxis[joint.id] for end in (joint.closed_end, joint.open_end)]
    both = np.concatenate(ends)
    return both.min(0), both.max(0)


def is_out(world: World, joint: Joint) -> bool:
    """Whether the drawer stands out of its fixture (farther than OUT_M from its closed end)."""
    return abs(world.qpos(joint.id) - joint.closed_end) > OUT_M


def under_sweep(world: World, joint: Joint, obj: str) -> bool:
    """Whether `obj` stands under the drawer's sweep (not in the drawer: its top below the sweep)."""
    lo, hi = sweep_box(world, joint)
    box = world.box(obj)
    if box.hi[2] >= lo[2]:
        return False
    return bool(np.all(box.lo[:2] < hi[:2] + COVER_MARGIN_M) and np.all(box.hi[:2] > lo[:2] - COVER_MARGIN_M))
