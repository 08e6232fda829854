"""The oracle's privileged view of one simulation: the grip site, the fingers, bodies, geoms,
sites and joints by LIBERO's names, and the extent of objects from their collision geoms (convex
hulls for what is grasped and carried, boxes for regions and obstacles).

Everything is read from MuJoCo's model and data (`sim.model._model`, `sim.data._data`), never from
images. A `World` belongs to one sim: robosuite rebuilds the sim on a hard reset, so the policy
makes a new `World` after each reset.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from functools import cached_property, lru_cache

import mujoco
import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.core.mjgeom import colliding, geom_corners, piece_corners, posed_pieces, subtree
from vpro_assets.libero.env import GRIPPER_PREFIX
from vpro_assets.libero.tasks import TaskRecord
from vpro_assets.perturb.entities import GRIP_SITE, Entity, object_entity
from vpro_assets.perturb.occluders import GeomHulls

ROBOT_PREFIXES = ("robot0_", GRIPPER_PREFIX, "mount0_")
FINGER_JOINTS = ("gripper0_finger_joint1", "gripper0_finger_joint2")


@lru_cache(maxsize=1024)
def _piece_corners(aabb: bytes, piece_m: float) -> np.ndarray:
    """`core.mjgeom.piece_corners` of a geom's box (its `geom_aabb` row's bytes; read-only): of the
    model only, kept for every episode and every scene whose geoms have that box."""
    corners = piece_corners(np.frombuffer(aabb, dtype=np.float64), piece_m)
    corners.flags.writeable = False
    return corners


class SkillFailed(VProError):
    """A skill could not reach its goal (a grasp slipped, a joint did not move); the plan may retry."""


@dataclass(frozen=True)
class Box:
    """A world axis-aligned box (`core.mjgeom.world_aabb`): the oracle's and the scripted
    controller's view of an object's extent."""

    lo: np.ndarray
    hi: np.ndarray

    @property
    def center(self) -> np.ndarray:
        return (self.lo + self.hi) / 2

    @property
    def size(self) -> np.ndarray:
        return self.hi - self.lo


class World:
    """Named access to one sim for the oracle's skills."""

    def __init__(self, sim, task: TaskRecord, holds: Callable[[tuple[str, ...]], bool]):
        """`holds(predicate)`: LIBERO's own check of one goal predicate in this sim, e.g.
        `("open", "wooden_cabinet_1_top_region")` (lower-case predicate names)."""
        self.sim, self.task, self.holds = sim, task, holds
        self.m, self.d = sim.model._model, sim.data._data
        self.grip_site = self._id(mujoco.mjtObj.mjOBJ_SITE, GRIP_SITE)
        self._entities: dict[str, Entity] = {}
        self._hulls = GeomHulls()
        # What the skills measure again and again at every plan and step: the geoms of an instance
        # and of the obstacles (of the model: found once), and each geom's world hull, box corners
        # and pieces, kept with the pose they were measured at (`_at_pose`).
        self._geoms: dict[str, list[int]] = {}
        self._obstacle_geoms: dict[tuple[str, ...], list[int]] = {}
        self._posed: dict[tuple[str, int], tuple[bytes, np.ndarray]] = {}
        self._root_names: dict[int, str] = {}
        self.step = 0  # control steps the oracle has acted
        # The gripper action that keeps a held object: 1 closes on it, 0 keeps the fingers' target
        # where the grasp left it (a gentle pinch, `grasp.foot_grasp`). Set by each pick.
        self.hold_grip = 1.0
        # Whether the held object hangs from its narrow top only (`grasp.narrow_top_grasp`): the carry
        # then passes higher over obstacles. Set by each pick.
        self.hung = False
        # The table (or floor) top: what the lowest movable object rests on.
        self.table_z = min(float(self.box(inst).lo[2]) for inst, _ in task.objects) if task.objects else 0.0

    # ---- names -----------------------------------------------------------------------------------
    def _id(self, kind, name: str) -> int:
        i = mujoco.mj_name2id(self.m, kind, name)
        if i < 0:
            raise VProError(f"task {self.task.key}: no {kind.name[6:].lower()} named {name!r} in the simulation")
        return i

    def entity(self, instance: str) -> Entity:
        if instance not in self._entities:
            self._entities[instance] = object_entity(self.m, instance)
        return self._entities[instance]

    def has_site(self, name: str) -> bool:
        return mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_SITE, name) >= 0

    # ---- the robot -------------------------------------------------------------------------------
    def eef(self) -> np.ndarray:
        return self.d.site_xpos[self.grip_site].copy()

    def eef_mat(self) -> np.ndarray:
        return self.d.site_xmat[self.grip_site].reshape(3, 3).copy()

    @cached_property
    def _finger_qpos(self) -> list[int]:
        return [int(self.m.jnt_qposadr[self._id(mujoco.mjtObj.mjOBJ_JOINT, j)]) for j in FINGER_JOINTS]

    def finger_gap(self) -> float:
        """Opening of the fingers (m): about 0.08 open, near 0 closed on nothing."""
        return float(abs(self.d.qpos[self._finger_qpos[0]]) + abs(self.d.qpos[self._finger_qpos[1]]))

    @cached_property
    def _finger_actuators(self) -> list[int]:
        joints = {self._id(mujoco.mjtObj.mjOBJ_JOINT, j) for j in FINGER_JOINTS}
        return [a for a in range(self.m.nu) if int(self.m.actuator_trnid[a, 0]) in joints]

    def finger_target_gap(self) -> float:
        """The opening the fingers' position actuators drive to (m), as `finger_gap` measures it."""
        return float(sum(abs(self.d.ctrl[a]) for a in self._finger_actuators))

    def finger_axis(self) -> np.ndarray:
        """Horizontal unit vector along which the fingers close."""
        left = self.d.xpos[self._id(mujoco.mjtObj.mjOBJ_BODY, "gripper0_leftfinger")]
        right = self.d.xpos[self._id(mujoco.mjtObj.mjOBJ_BODY, "gripper0_rightfinger")]
        axis = (left - right)[:2]
        return np.append(axis / (np.linalg.norm(axis) + 1e-9), 0.0)

    @cached_property
    def wrist_joint(self) -> int:
        """The arm's last hinge (the Panda's joint 7, turning the hand about its axis)."""
        if not self.arm_joints:
            raise VProError(f"task {self.task.key}: no hinge between the grip site and the world")
        return self.arm_joints[-1]

    @cached_property
    def arm_joints(self) -> list[int]:
        """The arm's hinges from its base to the hand (the Panda's joints 1 to 7): those walking up
        from the grip site's body, robot0_'s."""
        hinges, body = [], int(self.m.site_bodyid[self.grip_site])
        while body > 0:
            hinges += [
                j
                for j in range(self.m.njnt)
                if self.m.jnt_bodyid[j] == body and self.m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
            ]
            body = int(self.m.body_parentid[body])
        return [j for j in hinges[::-1] if self.joint_name(j).startswith(ROBOT_PREFIXES[0])]

    def wrist_room(self, turn: float) -> float:
        """How far the wrist joint stays from its nearer limit after the hand turns `turn` rad more
        about the wrist's axis (negative: past it)."""
        lo, hi = (float(x) for x in self.m.jnt_range[self.wrist_joint])
        q = self.qpos(self.wrist_joint) + turn
        return min(q - lo, hi - q)

    @cached_property
    def gripper_geoms(self) -> frozenset[int]:
        return frozenset(
            g for g in range(self.m.ngeom) if self._body_name(self.m.geom_bodyid[g]).startswith(GRIPPER_PREFIX)
        )

    def _body_name(self, b) -> str:
        return mujoco.mj_id2name(self.m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or ""

    # ---- objects ---------------------------------------------------------------------------------
    def geoms(self, instance: str) -> list[int]:
        if instance not in self._geoms:
            ent = self.entity(instance)
            self._geoms[instance] = colliding(self.m, ent.geoms) or list(ent.geoms)
        return list(self._geoms[instance])

    def _at_pose(self, what: str, geom: int, measure: Callable[[int], np.ndarray]) -> np.ndarray:
        """`measure(geom)`, a function of the model and of the geom's pose (`geom_xpos`, `geom_xmat`)
        only, measured again only once the geom has moved (read-only): a pose seen before gives
        the same numbers, bit for bit; most geoms the oracle measures (fixtures, objects standing
        still) do not move between two steps."""
        pose = self.d.geom_xpos[geom].tobytes() + self.d.geom_xmat[geom].tobytes()
        kept = self._posed.get((what, geom))
        if kept is not None and kept[0] == pose:
            return kept[1]
        value = measure(geom)
        value.flags.writeable = False
        self._posed[(what, geom)] = (pose, value)
        return value

    def hulls(self, instance: str) -> list[np.ndarray]:
        """World points of the convex hull of each of the instance's collision geoms (box corners
        for primitives; read-only)."""
        return [
            self._at_pose("hull", g, lambda g: self._hulls.world(self.m, self.d, [g])[0]) for g in self.geoms(instance)
        ]

    def points(self, instance: str) -> np.ndarray:
        """All of `hulls` stacked (N x 3): the object's actual extent (a deformed can's hull
        pieces are about 1 cm narrower than their boxes)."""
        return np.concatenate(self.hulls(instance))

    def box(self, instance: str) -> Box:
        """`core.mjgeom.world_aabb` of the instance's geoms: around their box corners."""
        pts = np.concatenate(
            [self._at_pose("corners", g, lambda g: geom_corners(self.m, self.d, [g])) for g in self.geoms(instance)]
        )
        return Box(pts.min(0), pts.max(0))

    def body_pos(self, instance: str) -> np.ndarray:
        """LIBERO's position of an object: its `<instance>_main` body (what On and In test)."""
        return self.d.xpos[self.entity(instance).root].copy()

    def body_mat(self, instance: str) -> np.ndarray:
        """The rotation of the object's `<instance>_main` body (its columns: the body's axes in the world)."""
        return self.d.xmat[self.entity(instance).root].reshape(3, 3).copy()

    def site_pos(self, name: str) -> np.ndarray:
        return self.d.site_xpos[self._id(mujoco.mjtObj.mjOBJ_SITE, name)].copy()

    def site_mat(self, name: str) -> np.ndarray:
        return self.d.site_xmat[self._id(mujoco.mjtObj.mjOBJ_SITE, name)].reshape(3, 3).copy()

    def site_size(self, name: str) -> np.ndarray:
        return self.m.site_size[self._id(mujoco.mjtObj.mjOBJ_SITE, name)].copy()

    def region_half(self, name: str) -> np.ndarray:
        """Half sizes (x, y, z) of LIBERO's box of a region, axis-aligned in the world as its
        `SiteObject.in_box` and `under` take it: `|mat @ size|`."""
        return np.abs(self.site_mat(name) @ self.site_size(name))

    def joint(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_JOINT, name)

    def qpos(self, joint: int) -> float:
        return float(self.d.qpos[self.m.jnt_qposadr[joint]])

    def joints_of(self, instance: str) -> list[int]:
        """Hinge and slide joints of an articulated fixture."""
        bodies = set(self.entity(instance).bodies)
        return [
            j
            for j in range(self.m.njnt)
            if self.m.jnt_bodyid[j] in bodies
            and self.m.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
        ]

    def joint_name(self, joint: int) -> str:
        return mujoco.mj_id2name(self.m, mujoco.mjtObj.mjOBJ_JOINT, joint) or ""

    def joint_geoms(self, joint: int) -> list[int]:
        """Collision geoms of the body a joint moves and of its descendants."""
        bodies = set(subtree(self.m, int(self.m.jnt_bodyid[joint])))
        return colliding(self.m, [g for g in range(self.m.ngeom) if self.m.geom_bodyid[g] in bodies])

    # ---- contacts --------------------------------------------------------------------------------
    def _touching_geoms(self, geoms: Collection[int]) -> Iterator[int]:
        """The geom outside `geoms` of each contact between one of `geoms` and another geom."""
        for i in range(self.d.ncon):
            c = self.d.contact[i]
            a, b = int(c.geom1), int(c.geom2)
            other = b if a in geoms else a if b in geoms else None
            if other is not None and other not in geoms:
                yield other

    def touching(self, instance: str) -> set[str]:
        """Top-level body names (`..._main` stripped) of everything in contact with the instance,
        'gripper' for the gripper."""
        mine = set(self.entity(instance).geoms)
        return {"gripper" if g in self.gripper_geoms else self.root_name(g) for g in self._touching_geoms(mine)}

    def robot_touches(self, geoms: Collection[int]) -> bool:
        """Whether the robot (arm, gripper or mount) touches any of `geoms`."""
        return any(self.root_name(g).startswith(ROBOT_PREFIXES) for g in self._touching_geoms(geoms))

    def root_name(self, geom: int) -> str:
        """The top-level body name of a geom (`..._main` stripped); of the model only, so found once
        per geom (contacts ask for it at every step)."""
        if geom not in self._root_names:
            self._root_names[geom] = self._find_root_name(geom)
        return self._root_names[geom]

    def _find_root_name(self, geom: int) -> str:
        b = int(self.m.geom_bodyid[geom])
        while self.m.body_parentid[b] != 0:
            b = int(self.m.body_parentid[b])
        name = self._body_name(b)
        return name[:-5] if name.endswith("_main") else name

    def held(self, instance: str) -> bool:
        """Both fingers in contact with the instance."""
        mine = set(self.entity(instance).geoms)
        left = self._finger_geoms("gripper0_leftfinger", "gripper0_finger_joint1_tip")
        right = self._finger_geoms("gripper0_rightfinger", "gripper0_finger_joint2_tip")
        hit_l = hit_r = False
        for i in range(self.d.ncon):
            c = self.d.contact[i]
            pair = {int(c.geom1), int(c.geom2)}
            if pair & mine:
                hit_l |= bool(pair & left)
                hit_r |= bool(pair & right)
        return hit_l and hit_r

    def _finger_geoms(self, *bodies: str) -> set[int]:
        ids = {mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_BODY, b) for b in bodies} - {-1}
        return {g for g in range(self.m.ngeom) if self.m.geom_bodyid[g] in ids}

    def pieces(self, geom: int, piece_m: float) -> np.ndarray:
        """`core.mjgeom.geom_pieces` of a geom (read-only), measured again only once the geom has
        moved: a function of its pose (`geom_xpos`, `geom_xmat`) and the model, so a pose seen
        before gives the same boxes, bit for bit; most obstacles are fixtures that never move."""
        return self._at_pose(
            f"pieces {piece_m}",
            geom,
            lambda g: posed_pieces(self.d, g, _piece_corners(self.m.geom_aabb[g].tobytes(), piece_m)),
        )

    def obstacle_geoms(self, exclude: tuple[str, ...] = ()) -> list[int]:
        """Collision geoms of everything but the robot, the table/floor and the excluded instances
        (of the model only: found once per `exclude`)."""
        key = tuple(exclude)
        if key not in self._obstacle_geoms:
            self._obstacle_geoms[key] = self._find_obstacle_geoms(key)
        return list(self._obstacle_geoms[key])

    def _find_obstacle_geoms(self, exclude: tuple[str, ...]) -> list[int]:
        skip = set()
        for inst in exclude:
            skip |= set(self.entity(inst).geoms)
        out = []
        for g in range(self.m.ngeom):
            if g in skip or not (self.m.geom_contype[g] or self.m.geom_conaffinity[g]):
                continue
            name = self.root_name(g)
            if not name or name.startswith(ROBOT_PREFIXES) or name in ("world", "table", "floor") or "table" in name:
                continue
            if self.m.geom_bodyid[g] == 0:
                continue
            out.append(g)
        return out
