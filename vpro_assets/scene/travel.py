"""Objects kept out of the travel of a part a scene variant sets: a door set part-open, a drawer set open.

A joint setting with `travel_from` (`variant.JointSetting`: the part's closed end) stands for a
part that was moved there from closed. An object on the way would have been pushed or knocked
over, and setting the part at once and settling does the same: libero_10-09's microwave door set
75% open (-0.98 rad) passes through where LIBERO puts the mug in 9 of its 10 trials, and the
settled starts had the mug moved 11 cm (trial 3), knocked over (trials 8 and 9) or left against
the microwave (4 more). So each object the variant lists (`SceneVariant.keep_clear`: those LIBERO
places in a rectangle on the table) that the travel passes closer than TRAVEL_CLEARANCE_M starts
instead at a spot drawn uniformly from its own LIBERO init region (same height and turn) where the
travel passes no closer and nothing but its support comes closer either. An object the travel
leaves clear keeps LIBERO's spot untouched. No clear spot in the region: InitStateError (the
region, LIBERO's own, is never left). After settling, `disturbed` names a listed object that
settling moved or tilted, or that touches a set part's fixture: the build rejects that start.

A part the variant does not set but the policy must open (`Placement.clear_of_opened`) is the
other way round: `opened_sweep` gives the ground it will cover, and `init_gen` starts a turned
target clear of it (libero_goal-03's upside-down bowl under the top drawer).

Distances are MuJoCo's own contact distances, with the listed object's geom margins raised to the
clearance for the check (`mj_geomDistance` between the microwave's door panel and the mug, both
meshes, returned 0 where the door passes more than 1 cm from it).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import mujoco
import numpy as np

from vpro_assets.core.mjgeom import colliding, geom_corners, subtree
from vpro_assets.scene import sim
from vpro_assets.scene.variant import SceneVariant

TRAVEL_CLEARANCE_M = 0.005  # the travel and other bodies pass a kept-clear object no closer than this
# Samples of the travel: a slide part moves at most 2 mm between them, a hinge 5 mrad (1.3 mm at
# the edge of the microwave's 26 cm door), well under the clearance.
TRAVEL_STEP = {mujoco.mjtJoint.mjJNT_SLIDE: 0.002, mujoco.mjtJoint.mjJNT_HINGE: 0.005}
SPOT_DRAWS = 400  # spots drawn in the region (libero_10-09's door at 75% leaves about 16% of the mug's clear)
# Settling a start whose objects stand clear moves them less than a millimetre; more was a push.
SETTLE_SHIFT_M = 0.005  # horizontal
SETTLE_TILT_DEG = 5.0


class NoClearSpot(Exception):
    """No spot of an object's region is clear of a set part's travel (init_gen turns it into
    InitStateError with the case and trial)."""


def _bodies(model, root: int) -> set[int]:
    return set(subtree(model, root))


@contextlib.contextmanager
def _margins(model, geoms: list[int], margin: float) -> Iterator[None]:
    """Contacts of `geoms` reported from `margin` apart (MuJoCo takes a pair's larger margin)."""
    saved = model.geom_margin[geoms].copy()
    model.geom_margin[geoms] = np.maximum(saved, margin)
    try:
        yield
    finally:
        model.geom_margin[geoms] = saved


def _near(model, data, mine: set[int], others: set[int], gap: float) -> bool:
    """Whether a contact between a body of `mine` and one of `others` is closer than `gap`, in the
    scene as posed (kinematics)."""
    mujoco.mj_collision(model, data)
    for i in range(data.ncon):
        c = data.contact[i]
        if c.dist >= gap:
            continue
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        if (b1 in mine and b2 in others) or (b2 in mine and b1 in others):
            return True
    return False


def _support(env, instance: str) -> int:
    """The root body under an object (a ray down from 5 mm over its lowest point at its
    footprint's centre): the table it stands on, the one body it may touch."""
    raw = sim.raw(env)
    model, data = raw.sim.model._model, raw.sim.data._data
    own = sim.body_layout(env)[instance]
    start = np.array([*((own["lo"][:2] + own["hi"][:2]) / 2), own["lo"][2] + 0.005])
    geom = np.array([-1], dtype=np.int32)
    body = raw.sim.model.body_name2id(raw.objects_dict[instance].root_body)
    mujoco.mj_ray(model, data, start, np.array([0.0, 0.0, -1.0]), None, 1, body, geom)
    return int(model.body_rootid[model.geom_bodyid[geom[0]]]) if geom[0] >= 0 else -1


def _outside(model, roots: set[int]) -> set[int]:
    """The bodies whose root is not among `roots`."""
    return {b for b in range(model.nbody) if int(model.body_rootid[b]) not in roots}


def _travel(model, data, variant: SceneVariant, raw) -> tuple[list[tuple[int, float, float]], int]:
    """([(qpos address, from, to)] of the set parts with a travel, sample count)."""
    moves, samples = [], 0
    for js in variant.joints:
        if js.travel_from is None:
            continue
        joint = raw.sim.model.joint_name2id(js.joint)
        adr = int(model.jnt_qposadr[joint])
        start, end = float(js.travel_from), float(data.qpos[adr])
        moves.append((adr, start, end))
        samples = max(samples, math.ceil(abs(end - start) / TRAVEL_STEP[model.jnt_type[joint]]))
    return moves, samples


def _travel_clear(model, data, moves, samples: int, mine: set[int], parts: set[int]) -> bool:
    """Whether every sample of the travel passes `mine` no closer than the clearance; the parts are
    left at their set values."""
    try:
        for s in range(samples + 1):
            t = s / samples if samples else 1.0
            for adr, start, end in moves:
                data.qpos[adr] = start + t * (end - start)
            mujoco.mj_kinematics(model, data)
            if _near(model, data, mine, parts, TRAVEL_CLEARANCE_M):
                return False
        return True
    finally:
        for adr, _, end in moves:
            data.qpos[adr] = end


def keep_clear_of_travel(env, variant: SceneVariant, rng: np.random.Generator) -> dict[str, tuple[float, float]]:
    """Move each listed object the set parts' travel passes too close to a clear spot of its
    region (module doc); {instance: new xy} of those moved."""
    raw = sim.raw(env)
    model, data = raw.sim.model._model, raw.sim.data._data
    moves, samples = _travel(model, data, variant, raw)
    if not moves or not variant.keep_clear:
        return {}
    parts: set[int] = set()
    for js in variant.joints:
        if js.travel_from is not None:
            parts |= _bodies(model, int(model.jnt_bodyid[raw.sim.model.joint_name2id(js.joint)]))
    moved = {}
    for keep in variant.keep_clear:
        obj = raw.objects_dict[keep.instance]
        root = raw.sim.model.body_name2id(obj.root_body)
        mine = _bodies(model, root)
        support = _support(env, keep.instance)
        geoms = colliding(model, [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) in mine])
        around = _outside(model, {support, root})  # what it must stand clear of: all but its support
        joint = obj.joints[-1]
        qpos = np.array(raw.sim.data.get_joint_qpos(joint))
        with _margins(model, geoms, TRAVEL_CLEARANCE_M):
            mujoco.mj_kinematics(model, data)
            if _travel_clear(model, data, moves, samples, mine, parts):
                continue
            lo, hi = np.asarray(keep.box[:2]), np.asarray(keep.box[2:])
            for _ in range(SPOT_DRAWS):
                qpos[:2] = rng.uniform(lo, hi)
                raw.sim.data.set_joint_qpos(joint, qpos)
                mujoco.mj_kinematics(model, data)
                if not _near(model, data, mine, around, TRAVEL_CLEARANCE_M) and _travel_clear(
                    model, data, moves, samples, mine, parts
                ):
                    break
            else:
                raise NoClearSpot(
                    f"no spot of {keep.instance}'s region {keep.box} is {TRAVEL_CLEARANCE_M * 1000:g} mm clear of "
                    f"the travel of {', '.join(js.joint for js in variant.joints if js.travel_from is not None)} "
                    f"({SPOT_DRAWS} drawn)"
                )
        raw.sim.data.set_joint_qvel(joint, np.zeros(6))
        moved[keep.instance] = (float(qpos[0]), float(qpos[1]))
    raw.sim.forward()
    return moved


def poses(env, variant: SceneVariant) -> dict[str, np.ndarray]:
    """qpos (7) of each listed object, to compare a start before and after settling."""
    state = sim.free_object_state(env)
    return {k.instance: state[k.instance][0] for k in variant.keep_clear}


def _tilt_deg(q0: np.ndarray, q1: np.ndarray) -> float:
    """Angle between the object's up axis in two poses (w, x, y, z quaternions)."""
    up = []
    for q in (q0, q1):
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, np.asarray(q, dtype=np.float64))
        up.append(mat.reshape(3, 3)[:, 2])
    return math.degrees(math.acos(float(np.clip(np.dot(up[0], up[1]), -1.0, 1.0))))


def disturbed(env, variant: SceneVariant, before: dict[str, np.ndarray]) -> list[str]:
    """What is wrong with the listed objects after settling: moved more than SETTLE_SHIFT_M
    horizontally or tilted more than SETTLE_TILT_DEG from `before`, or touching the fixture of a
    part the variant sets (other than the one it stands on)."""
    raw = sim.raw(env)
    model, data = raw.sim.model._model, raw.sim.data._data
    fixtures = {
        int(model.body_rootid[model.jnt_bodyid[raw.sim.model.joint_name2id(js.joint)]]) for js in variant.joints
    }
    after = poses(env, variant)
    out = []
    for keep in variant.keep_clear:
        q0, q1 = before[keep.instance], after[keep.instance]
        shift, tilt = float(np.linalg.norm(q1[:2] - q0[:2])), _tilt_deg(q0[3:], q1[3:])
        if shift > SETTLE_SHIFT_M or tilt > SETTLE_TILT_DEG:
            out.append(f"{keep.instance} moved {shift * 1000:.1f} mm and tilted {tilt:.1f} degrees while settling")
        root = raw.sim.model.body_name2id(raw.objects_dict[keep.instance].root_body)
        support = _support(env, keep.instance)
        touched = {b for b in range(model.nbody) if int(model.body_rootid[b]) in fixtures - {support}}
        mujoco.mj_forward(model, data)
        # Any contact MuJoCo reports counts: it reports a pair only within its margin (the microwave
        # door's 1 mm), and with no gap set each one pushes.
        if _near(model, data, _bodies(model, root), touched, math.inf):
            out.append(f"{keep.instance} touches the fixture of a part the variant sets")
    return out


def opened_sweep(env, joint_name: str, to: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """World xy boxes (lo, hi) of the ground a part covers on its way from where it stands to `to`
    (the policy opening it): its collision geoms' box at each sample of the travel (TRAVEL_STEP),
    at any height, since a hand cannot come down under it either. The part is left where it was."""
    raw = sim.raw(env)
    model, data = raw.sim.model._model, raw.sim.data._data
    joint = raw.sim.model.joint_name2id(joint_name)
    adr = int(model.jnt_qposadr[joint])
    bodies = _bodies(model, int(model.jnt_bodyid[joint]))
    geoms = colliding(model, [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) in bodies])
    start = float(data.qpos[adr])
    samples = max(1, math.ceil(abs(to - start) / TRAVEL_STEP[model.jnt_type[joint]]))
    boxes = []
    try:
        for s in range(samples + 1):
            data.qpos[adr] = start + s / samples * (to - start)
            mujoco.mj_kinematics(model, data)
            corners = geom_corners(model, data, geoms)
            boxes.append((corners.min(0)[:2], corners.max(0)[:2]))
    finally:
        data.qpos[adr] = start
        mujoco.mj_kinematics(model, data)
    return boxes
