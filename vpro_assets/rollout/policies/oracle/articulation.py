"""Which joint a goal's region names, and which way it opens, read from the model.

LIBERO's region names carry the level (`wooden_cabinet_1_top_region` -> the joint `..._top_level`);
a fixture with one joint (the microwave's door) needs no level. A joint opens toward the end of its
range farther from its closed value 0 (LIBERO's cabinets open at qpos < -0.14, the microwave at
qpos < -1.3), and LIBERO's `Open` / `Close` checks decide when it is done.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

LEVELS = ("top", "middle", "bottom")


@dataclass(frozen=True)
class Joint:
    id: int
    fixture: str
    region: str  # the goal argument it serves
    open_end: float  # the range limit on the open side
    closed_end: float  # the range limit on the closed side

    @property
    def open_sign(self) -> float:
        return float(np.sign(self.open_end - self.closed_end))


def owner_of(world: World, arg: str) -> str:
    names = [inst for inst, _ in world.task.objects + world.task.fixtures]
    return max((n for n in names if arg == n or arg.startswith(n + "_")), key=len, default=arg)


def is_drawer(world: World, arg: str) -> bool:
    """Whether `arg` (a region or a fixture) belongs to a fixture with a slide joint: a drawer, pulled
    out and filled from above."""
    owner = owner_of(world, arg)
    return owner in dict(world.task.fixtures) and any(
        world.m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE for j in world.joints_of(owner)
    )


def is_fixture_region(world: World, region: str) -> bool:
    """Whether `region` is a site of one of the task's fixtures and not a drawer's (what a skill that
    readies an object to go `In` it, `turn_over` or `pivot`, aims at)."""
    return (
        world.has_site(region) and not is_drawer(world, region) and owner_of(world, region) in dict(world.task.fixtures)
    )


def joint_for(world: World, arg: str) -> Joint:
    fixture = owner_of(world, arg)
    joints = world.joints_of(fixture)
    if not joints:
        raise SkillFailed(f"{arg}: {fixture} has no hinge or slide joint")
    levels = [w for w in LEVELS if f"_{w}_" in arg[len(fixture) :] + "_"]
    named = [j for j in joints if any(w in world.joint_name(j) for w in levels)]
    j = (named or joints)[0]
    lo, hi = (float(x) for x in world.m.jnt_range[j])
    open_end, closed_end = (lo, hi) if abs(lo) > abs(hi) else (hi, lo)
    return Joint(j, fixture, arg, open_end, closed_end)


# A drawer counts as out to the end of its range this near it (libero_10-03's bottom drawer starts at
# -0.146 to -0.156 of -0.16; at -0.156 an inverted bowl still caught the handles above and fell on edge).
FULL_OPEN_M = 0.002


def fully_open(world: World, region: str) -> bool:
    """Whether the drawer of `region` is out to (within FULL_OPEN_M of) the end of its range."""
    joint = joint_for(world, region)
    return abs(world.qpos(joint.id) - joint.open_end) < FULL_OPEN_M


def needs_opening(world: World, region: str, is_open: bool) -> bool:
    """Whether the drawer or door of `region` must open before something goes in; `is_open`: LIBERO's
    Open holds for it. A drawer must be out as far as Open: less, its mouth stays under the
    cabinet's front and the object rests on the handle of the drawer below (libero_10-03's
    receptacle_openness -open75, out more than half). A door only when nearer its closed end than its
    open end: swung past halfway, it lets the object in."""
    if is_open:
        return False
    if is_drawer(world, region):
        return True
    joint = joint_for(world, region)
    return abs(world.qpos(joint.id) - joint.closed_end) < 0.5 * abs(joint.open_end - joint.closed_end)
