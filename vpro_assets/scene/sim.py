"""Simulation helpers for scene building: a render-free LIBERO env, the measured layout of a
scene (where every object and fixture sits, its footprint), mapping a LIBERO state row between
models by joint name, and the rest/penetration/table checks used to accept initial states.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.core.mjgeom import colliding, world_aabb
from vpro_assets.libero import physics
from vpro_assets.libero.env import NOOP_ACTION
from vpro_assets.libero.settled import keep_property_samplers

log = logging.getLogger(__name__)

SETTLE_STEPS = 20  # control steps at 20 Hz: one second
REST_LINEAR = 0.02  # m/s: an object faster than this is not at rest
REST_ANGULAR = 0.5  # rad/s
PENETRATION_TOL = 0.005  # m: deeper contacts between scene bodies count as interpenetration
DROP_TOL = 0.05  # m: an object this far below the surface the others rest on has left the table
DRIFT_TOL = 0.01  # m: validation: one second of zero actions moves no object further than this


def physics_env(bddl_file: str, fresh: bool = False):
    """LIBERO's ControlEnv for a BDDL file, without cameras, renderer or textures (physics only;
    its reset reuses the model compiled at construction: `vpro_assets.libero.physics`). `fresh`:
    compiled at construction by MuJoCo's XML load, textures included, even where the same MJCF was
    compiled before in this process, and reset without compiling again (robosuite's soft reset:
    every trial re-places the fixtures on the model anyway, `place_fixtures`)."""
    # ignore_done: building steps one env through many trials, past LIBERO's 1000-step horizon.
    env = physics.physics_env(str(bddl_file), fresh=fresh, ignore_done=True)
    env.reset()
    return env


def close(env) -> None:
    """Close a scene env and drop its compile from the model cache: its resets are done, and no
    other env of a build has the same MJCF (each case's BDDL is its own), so the cached copy
    (70-120 MB) would only wait for the next compile to evict it."""
    env.close()
    physics.clear_model_cache()


def place_fixtures(env, seed: int) -> None:
    """Place the scene's fixtures (cabinets, stoves, racks: bodies without joints, so not part of
    a state row) where LIBERO's reset puts them after `env.seed(seed)`, which is what the rollout
    does before each trial. LIBERO samples fixture positions from numpy's global stream at every
    reset (up to ~1 cm apart); the build and validation call this with the trial's seed so a
    frozen state always meets the fixture placement it was settled with, in every process.
    `_reset_internal` is the part of a reset that samples placements (checked equal to a full
    hard reset, without recompiling the model); the state loaded afterwards overrides the rest."""
    keep_property_samplers(raw(env), 2)  # as at a new env's first reset (construction and reset)
    env.seed(int(seed))
    raw(env)._reset_internal()


def raw(env):
    """The robosuite env inside LIBERO's wrapper."""
    return env.env


@dataclass(frozen=True)
class JointSlot:
    name: str
    qpos: slice
    qvel: slice


def joint_slots(env) -> dict[str, JointSlot]:
    m = raw(env).sim.model._model
    out = {}
    for j in range(m.njnt):
        nq = {0: 7, 1: 4}.get(int(m.jnt_type[j]), 1)
        nv = {0: 6, 1: 3}.get(int(m.jnt_type[j]), 1)
        qa, va = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        out[name] = JointSlot(name, slice(qa, qa + nq), slice(va, va + nv))
    return out


def map_state(row: np.ndarray, src: dict[str, JointSlot], dst_env) -> np.ndarray:
    """A LIBERO state row (time, qpos, qvel) of one model, carried to another model by joint name.
    Joints the source lacks take the destination model's reference configuration (qpos0)."""
    m = raw(dst_env).sim.model._model
    nq_src = sum(s.qpos.stop - s.qpos.start for s in src.values())
    qpos, qvel = m.qpos0.copy(), np.zeros(m.nv)
    src_q, src_v = row[1 : 1 + nq_src], row[1 + nq_src :]
    for name, slot in joint_slots(dst_env).items():
        if name in src:
            qpos[slot.qpos] = src_q[src[name].qpos]
            qvel[slot.qvel] = src_v[src[name].qvel]
    return np.concatenate([[row[0]], qpos, qvel])


def body_layout(env) -> dict[str, dict]:
    """Every object and fixture of the scene: world position and the box of its colliding geoms."""
    m = raw(env).sim.model._model
    d = raw(env).sim.data._data
    roots = {}
    for kind, table in (("object", raw(env).objects_dict), ("fixture", raw(env).fixtures_dict)):
        for name, obj in table.items():
            roots[raw(env).sim.model.body_name2id(obj.root_body)] = (name, kind)
    geoms: dict[int, list[int]] = {}
    for g in colliding(m, range(m.ngeom)):
        root = int(m.body_rootid[m.geom_bodyid[g]])
        if root in roots:
            geoms.setdefault(root, []).append(g)
    out = {}
    for root, (name, kind) in roots.items():
        lo, hi = world_aabb(m, d, geoms[root]) if root in geoms else (d.xpos[root].copy(), d.xpos[root].copy())
        out[name] = {"kind": kind, "pos": d.xpos[root].copy(), "lo": lo, "hi": hi}
    return out


def settle(env, steps: int = SETTLE_STEPS) -> None:
    """`steps` control steps of zero actions (the physics of LIBERO's step, no observations)."""
    for _ in range(steps):
        physics.physics_step(env, NOOP_ACTION)


def free_object_state(env) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """instance -> (qpos[7], qvel[6]) of every movable object."""
    data = raw(env).sim.data
    out = {}
    for name, obj in raw(env).objects_dict.items():
        if not obj.joints:
            continue
        out[name] = (np.array(data.get_joint_qpos(obj.joints[-1])), np.array(data.get_joint_qvel(obj.joints[-1])))
    return out


def moving_objects(env) -> list[tuple[str, float, float]]:
    """Objects not at rest: (instance, linear speed, angular speed)."""
    out = []
    for name, (_, qvel) in free_object_state(env).items():
        lin, ang = float(np.linalg.norm(qvel[:3])), float(np.linalg.norm(qvel[3:]))
        if lin > REST_LINEAR or ang > REST_ANGULAR:
            out.append((name, lin, ang))
    return out


def penetrations(env, tol: float = PENETRATION_TOL) -> list[tuple[str, str, float]]:
    """Contacts deeper than `tol` between bodies of the scene (the robot excluded)."""
    m = raw(env).sim.model._model
    d = raw(env).sim.data._data
    robot_roots = {
        int(m.body_rootid[raw(env).sim.model.body_name2id(r.robot_model.root_body)]) for r in raw(env).robots
    }
    out = []
    for i in range(d.ncon):
        c = d.contact[i]
        if c.dist >= -tol:
            continue
        b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
        if int(m.body_rootid[b1]) in robot_roots or int(m.body_rootid[b2]) in robot_roots:
            continue
        out.append(
            (
                mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b1) or str(b1),
                mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b2) or str(b2),
                float(-c.dist),
            )
        )
    return out


def flattened_state(env) -> np.ndarray:
    return np.asarray(raw(env).sim.get_state().flatten(), dtype=np.float64)


def load_state(env, row: np.ndarray) -> None:
    """Load a state row from a clean slate (no solver warm start or controller history carried
    over from earlier trials), so a trial's outcome never depends on what ran before it."""
    sim = raw(env).sim
    mujoco.mj_resetData(sim.model._model, sim.data._data)
    env.set_init_state(row)
    for robot in raw(env).robots:
        robot.controller.update(force=True)
        robot.controller.reset_goal()


def mujoco_warnings(env) -> list[str]:
    d = raw(env).sim.data._data
    return [
        f"{mujoco.mjtWarning(i).name}: {int(d.warning[i].number)} time(s)"
        for i in range(len(d.warning))
        if d.warning[i].number > 0
    ]
