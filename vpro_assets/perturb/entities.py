"""Task entities (target, receptacle, gripper, articulated parts) as MuJoCo ids of one sim.

LIBERO names the root body of every object and fixture `<instance>_main`; an entity is that body
and all its descendants. The gripper is every body under the robot's gripper prefix (`gripper0_`:
hand and fingers). Geom ids are split into visual geoms (what cameras draw) and collision geoms
(what makes contacts). Ids change when robosuite rebuilds the sim on a hard reset, so an
`EntityIndex` is built for one sim and rebuilt after each reset.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.core.mjgeom import subtree
from vpro_assets.libero.names import GRIPPER_PREFIX
from vpro_assets.libero.task_record import TaskRecord

GRIP_SITE = "gripper0_grip_site"
LEFT_FINGER_BODIES = ("gripper0_leftfinger", "gripper0_finger_joint1_tip")
RIGHT_FINGER_BODIES = ("gripper0_rightfinger", "gripper0_finger_joint2_tip")
REGION_WORDS = ("top", "middle", "bottom")


@dataclass(frozen=True)
class Entity:
    name: str
    bodies: tuple[int, ...]
    geoms: tuple[int, ...]  # every geom of the bodies
    visual_geoms: tuple[int, ...]  # geoms cameras draw (contype 0 and conaffinity 0)

    @property
    def root(self) -> int:
        return self.bodies[0]


def _name(m, kind, i) -> str:
    return mujoco.mj_id2name(m, kind, i) or ""


def _entity(m, name: str, roots: list[int]) -> Entity:
    bodies: list[int] = []
    for r in roots:
        bodies += [b for b in subtree(m, r) if b not in bodies]
    body_set = set(bodies)
    geoms = tuple(int(g) for g in range(m.ngeom) if m.geom_bodyid[g] in body_set)
    visual = tuple(g for g in geoms if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0)
    return Entity(name, tuple(bodies), geoms, visual)


def object_entity(m, instance: str) -> Entity:
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{instance}_main")
    if body < 0:
        raise VProError(f"no body {instance}_main in the simulation (LIBERO names an object's root body <name>_main)")
    return _entity(m, instance, [body])


def gripper_entity(m) -> Entity:
    roots = [
        b
        for b in range(m.nbody)
        if _name(m, mujoco.mjtObj.mjOBJ_BODY, b).startswith(GRIPPER_PREFIX)
        and not _name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.body_parentid[b])).startswith(GRIPPER_PREFIX)
    ]
    if not roots:
        raise VProError(f"no gripper bodies ({GRIPPER_PREFIX}*) in the simulation")
    return _entity(m, "gripper", roots)


def _bodies_named(m, names) -> set[int]:
    return {i for n in names if (i := mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n)) >= 0}


class EntityIndex:
    """The task's entities in one sim: target, receptacle, gripper, articulation joints."""

    def __init__(self, sim, task: TaskRecord):
        m = sim.model._model
        self.model = m
        self.task = task
        self.gripper = gripper_entity(m)
        self.target = object_entity(m, task.target) if task.target else None
        self.receptacle = object_entity(m, task.receptacle) if task.receptacle else None
        self.articulations = tuple(object_entity(m, a.name) for a in task.articulations)
        # The object the robot interacts with first: the target, else the first articulated fixture.
        self.interaction = self.target or (self.articulations[0] if self.articulations else None)
        self.grip_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, GRIP_SITE)
        self.left_finger_geoms = self._geoms_of(_bodies_named(m, LEFT_FINGER_BODIES))
        self.right_finger_geoms = self._geoms_of(_bodies_named(m, RIGHT_FINGER_BODIES))

    def _geoms_of(self, bodies: set[int]) -> np.ndarray:
        m = self.model
        return np.array([g for g in range(m.ngeom) if m.geom_bodyid[g] in bodies], dtype=np.int32)

    def entity(self, label: str) -> Entity | None:
        return {"target": self.target, "receptacle": self.receptacle, "gripper": self.gripper}[label]

    def articulation_joints(self) -> list[tuple[int, float, float]]:
        """(joint id, lower, upper) of the hinge/slide joints of the articulated fixtures the goal
        involves; where the goal names a level (top/middle/bottom) only that level's joints."""
        m = self.model
        words = {
            w for pred in self.task.goal for arg in pred[1:] for w in REGION_WORDS if re.search(rf"_{w}_", arg + "_")
        }
        if self.task.receptacle_region:
            words |= {w for w in REGION_WORDS if w in self.task.receptacle_region}
        out = []
        for ent in self.articulations:
            joints = [
                j
                for j in range(m.njnt)
                if m.jnt_bodyid[j] in ent.bodies
                and m.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
            ]
            named = [j for j in joints if any(w in _name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for w in words)]
            for j in named or joints:
                lo, hi = m.jnt_range[j]
                out.append((j, float(lo), float(hi)))
        return out
