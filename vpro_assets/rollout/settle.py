"""Settled starts: the scene a policy sees in its first frame, measured without rendering.

One trial is settled exactly as an episode starts (`episode.run_episode`): the case's env, seeded
with the trial's seed, `reset()`, `set_init_state(row)`, then the 10 no-op wait steps. After
`set_init_state` and after every wait step each movable object is checked:
- off the table: its origin below the table top by more than TABLE_DROP_M, or outside the table's
  footprint (scenes on the floor have no table and are not checked);
- out of view: no part of it is in the third-person (agentview) image (its origin and the corners
  of its bounding box all project outside);
and at the first policy frame (after the last wait step) its speed (m/s) and spin (rad/s) are read.
The BDDL's :init relations are evaluated twice: by LIBERO's own predicate, and geometrically where
LIBERO's is unreliable (docs/simulator.md): `On(a, b)` between objects (LIBERO asks for b's origin
below a's, a contact and origins within 3 cm in x-y, which a bowl stacked on a ramekin or a cookie
box never meets), `On(a, region)` (LIBERO's regions are the 1 cm sampling boxes of the
placement, which the recorded initial states themselves miss by up to 1.5 cm), and a visual-only
look-alike `On` a region by its lowest point (an upside-down look-alike's origin is at its top).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

import mujoco
import numpy as np

from vpro_assets.core.mjgeom import colliding, geom_corners, subtree
from vpro_assets.libero.env import NOOP_ACTION
from vpro_assets.libero.settled import articulated_joints, joint_positions, movable_objects, pose
from vpro_assets.rollout.case_env import env_for_case
from vpro_assets.rollout.episode import WAIT_STEPS

log = logging.getLogger(__name__)

TABLE_DROP_M = 0.03  # an object this far below the table top has fallen off it
SPEED_LIMIT_M_S = 0.05  # the fastest an object may move at the first policy frame (2.5 mm per 20 Hz step)
REGION_XY_TOL_M = 0.02  # an object may rest this far outside its 1 cm placement box
REGION_Z_BAND_M = (-0.05, 0.10)  # its origin above the region's site (LIBERO's own band is 0.10)
VIEW_CAMERA = "agentview"


def _name(model, kind, index: int) -> str:
    return mujoco.mj_id2name(model, kind, index) or ""


def _subtree(model, root: int) -> set[int]:
    return set(subtree(model, root))


def _colliding_geoms(model, bodies: set[int]) -> np.ndarray:
    return np.array(colliding(model, [g for g in range(model.ngeom) if model.geom_bodyid[g] in bodies]), dtype=int)


def _world_box(model, data, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned world box of some geoms; no geom gives an empty (inverted) box."""
    corners = geom_corners(model, data, geoms)
    if not len(corners):
        return np.full(3, np.inf), np.full(3, -np.inf)
    return corners.min(0), corners.max(0)


def _in_view(model, data, camera: int, points: np.ndarray) -> bool:
    """Whether any of some world points projects inside a camera's image (MuJoCo cameras look along -z)."""
    local = (np.atleast_2d(points) - data.cam_xpos[camera]) @ data.cam_xmat[camera].reshape(3, 3)
    half = np.tan(np.deg2rad(model.cam_fovy[camera]) / 2)  # square images: same extent in x and y
    depth = -local[:, 2]
    ahead = depth > 0
    inside = ahead & (np.abs(local[:, 0]) <= half * depth) & (np.abs(local[:, 1]) <= half * depth)
    return bool(inside.any())


class _Scene:
    """Names and ids of one LIBERO env's movable objects, articulated joints and table."""

    def __init__(self, env):
        self.inner = env.env
        self.model, self.data = self.inner.sim.model._model, self.inner.sim.data._data
        self.objects = movable_objects(self.inner)
        self.geoms = {
            name: _colliding_geoms(self.model, _subtree(self.model, body)) for name, body in self.objects.items()
        }
        self.joints = articulated_joints(self.model)
        self.camera = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, VIEW_CAMERA)
        # The arena's table body: `table` (tabletop), `kitchen_table`, `living_room_table`, `study_table`;
        # LIBERO's floor scenes have none.
        table = next(
            (b for b in range(self.model.nbody) if _name(self.model, mujoco.mjtObj.mjOBJ_BODY, b).endswith("table")),
            None,
        )
        self.table = (
            _world_box(self.model, self.data, _colliding_geoms(self.model, _subtree(self.model, table)))
            if table
            else None
        )

    def off_table(self, pos: np.ndarray) -> bool:
        if self.table is None:
            return False
        lo, hi = self.table
        return bool(pos[2] < hi[2] - TABLE_DROP_M or not (lo[0] <= pos[0] <= hi[0] and lo[1] <= pos[1] <= hi[1]))

    def in_view(self, name: str) -> bool:
        lo, hi = _world_box(self.model, self.data, self.geoms[name])
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        return _in_view(self.model, self.data, self.camera, np.vstack([self.data.xpos[self.objects[name]], corners]))

    def velocity(self, body: int) -> tuple[float, float]:
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_BODY, body, vel, 0)
        return float(np.linalg.norm(vel[3:])), float(np.linalg.norm(vel[:3]))

    def relation(self, state: list) -> dict:
        pred, args = state[0].lower(), state[1:]
        libero = bool(self.inner._eval_predicate(state))
        geometric: bool | None = None
        if pred == "on" and len(args) == 2 and args[0] in self.objects:
            a, b = args
            if b in self.inner.obj_body_id and b not in self.inner.object_sites_dict:
                geometric = self._on_object(a, b)
            elif b in self.inner.object_sites_dict:
                geometric = self._on_region(self.objects[a], b)
        elif pred == "on" and len(args) == 2 and args[1] in self.inner.object_sites_dict and self._visual_only(args[0]):
            geometric = self._look_alike_on_region(*args)
        return {
            "relation": " ".join(state),
            "libero": libero,
            "geometric": geometric,
            "holds": libero if geometric is None else geometric,
        }

    def _on_object(self, a: str, b: str) -> bool:
        """a touches b, a's centre of mass is above b's, a's origin is over b's footprint."""
        ia, ib = self.inner.obj_body_id[a], self.inner.obj_body_id[b]
        lo, hi = _world_box(self.model, self.data, _colliding_geoms(self.model, _subtree(self.model, ib)))
        pos = self.data.xpos[ia]
        touching = self.inner.check_contact(self.inner.get_object(a), self.inner.get_object(b))
        return bool(
            touching
            and self.data.xipos[ia][2] > self.data.xipos[ib][2]
            and lo[0] <= pos[0] <= hi[0]
            and lo[1] <= pos[1] <= hi[1]
        )

    def _on_region(self, body: int, region: str, z: float | None = None) -> bool:
        """body's origin is over the region's box and `z` (default: the origin's height) is on its
        surface."""
        site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, region)
        size = np.asarray(self.inner.object_sites_dict[region].size, dtype=np.float64)
        delta = self.data.site_xmat[site].reshape(3, 3) @ (self.data.xpos[body] - self.data.site_xpos[site])
        height = delta[2] if z is None else z - self.data.site_xpos[site][2]
        return bool(
            np.all(np.abs(delta[:2]) <= size[:2] + REGION_XY_TOL_M)
            and REGION_Z_BAND_M[0] <= height - size[2] <= REGION_Z_BAND_M[1]
        )

    def _visual_only(self, name: str) -> bool:
        """A fixture without colliding geoms: the toolkit's visual-only look-alikes."""
        if name not in self.inner.fixtures_dict:
            return False
        return not len(_colliding_geoms(self.model, _subtree(self.model, self.inner.obj_body_id[name])))

    def _look_alike_on_region(self, a: str, region: str) -> bool:
        """A visual-only look-alike stands on a region by its lowest point. LIBERO's own predicate
        asks for the origin at most 10 cm above the surface, which an upside-down look-alike of a
        tall object (its origin at its top) never meets."""
        body = self.inner.obj_body_id[a]
        geoms = np.flatnonzero(np.isin(self.model.geom_bodyid, list(_subtree(self.model, body))))
        return self._on_region(body, region, z=_world_box(self.model, self.data, geoms)[0][2])


def settle_trial(case: Mapping, trial: int, wait_steps: int = WAIT_STEPS) -> dict:
    """Settle one trial of one case and measure it (module docstring). JSON-ready."""
    cenv = env_for_case(case, trial, render=False, reuse=True)
    try:
        cenv.reset()
        scene = _Scene(cenv.env)
        left_table = dict.fromkeys(scene.objects, False)
        out_of_view = dict.fromkeys(scene.objects, 0)
        for step in range(wait_steps + 1):
            if step:
                cenv.step(NOOP_ACTION)
            for name, body in scene.objects.items():
                pos = scene.data.xpos[body]
                left_table[name] |= scene.off_table(pos)
                out_of_view[name] += not scene.in_view(name)
        objects = {}
        for name, body in scene.objects.items():
            speed, spin = scene.velocity(body)
            objects[name] = {
                "pose": pose(scene.data, body),
                "speed": round(speed, 6),
                "spin": round(spin, 6),
                "left_table": left_table[name],
                "out_of_view": not scene.in_view(name),
                "out_of_view_steps": out_of_view[name],
            }
        joints = joint_positions(scene.model, scene.data)
        relations = [scene.relation(list(state)) for state in scene.inner.parsed_problem["initial_state"]]
        return {
            "case": case["id"],
            "trial": trial,
            "seed": int(case["trial_seeds"][trial]),
            "inputs": dict(cenv.artifact_hashes),
            "wait_steps": wait_steps,
            "objects": objects,
            "joints": joints,
            "relations": relations,
        }
    finally:
        cenv.close()


def trial_problems(record: Mapping, speed_limit: float = SPEED_LIMIT_M_S, relations: bool = True) -> list[str]:
    """What is wrong with a settled start, one phrase each (empty: a clean start). `relations=False`:
    only what the simulator does (off the table, out of view, moving), not the :init relations."""
    problems = []
    for name, obj in record["objects"].items():
        if obj["left_table"]:
            problems.append(f"{name} off the table")
        if obj["out_of_view"]:
            problems.append(f"{name} out of view at the first frame")
        elif obj["out_of_view_steps"]:
            problems.append(f"{name} out of view for {obj['out_of_view_steps']} wait step(s)")
        if obj["speed"] > speed_limit:
            problems.append(f"{name} moving at {obj['speed']:.3f} m/s")
    if relations:
        problems += [f"not ({r['relation']})" for r in record["relations"] if not r["holds"]]
    return problems


def first_frames(
    case: Mapping, trial: int, recorded: Mapping, resolution: int = 256, wait_steps: int = WAIT_STEPS
) -> tuple[np.ndarray, np.ndarray]:
    """The third-person first frame (upright) of a trial as it settles now, and the same frame with
    the objects and joints put where a fingerprint recorded them (`objects`: name -> pose, `joints`)."""
    cenv = env_for_case(case, trial, resolution=resolution, reuse=False)
    try:
        obs = cenv.reset()
        for _ in range(wait_steps):
            obs, _ = cenv.step(NOOP_ACTION)
        current = np.asarray(obs["agentview_image"])[::-1].copy()
        inner = cenv.env.env
        model = inner.sim.model._model
        state = np.asarray(cenv.env.get_sim_state(), dtype=np.float64).copy()  # time, qpos, qvel
        for name, pose in recorded["objects"].items():
            joints = [
                j
                for j in inner.get_object(name).joints
                if model.jnt_type[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j)] == mujoco.mjtJoint.mjJNT_FREE
            ]
            if joints:
                adr = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joints[0])]
                state[1 + adr : 1 + adr + 7] = pose
        for name, value in recorded["joints"].items():
            joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if joint >= 0:
                state[1 + model.jnt_qposadr[joint]] = value
        then = cenv.env.regenerate_obs_from_state(state)
        return np.asarray(then["agentview_image"])[::-1].copy(), current
    finally:
        cenv.close()
