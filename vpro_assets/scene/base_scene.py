"""The measured base scene of a task: what generators read to place things.

Built once per task (a render-free LIBERO env of the base BDDL with LIBERO's own initial states):
joint layout (to carry states into variants), where every object and fixture sits in each of the
trial rows, the target's familiar position (mean over all of LIBERO's initial states) and the
workspace (fixture name, offset of LIBERO's region coordinates).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.core.seeding import TRIALS_PER_CASE
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.env import libero_init_states
from vpro_assets.libero.tasks import TaskRecord, get_task
from vpro_assets.scene import sim
from vpro_assets.scene.bddl_doc import BaseBDDL, read_base


@dataclass
class BaseScene:
    task: TaskRecord
    bddl: BaseBDDL
    rows: np.ndarray  # LIBERO's initial states (all of them)
    trial_rows: list[int]  # LIBERO row each trial starts from: row k, unless LIBERO's own row k is unsound
    slots: dict  # joint name -> JointSlot of the base model
    layouts: list[dict]  # per trial: instance -> {kind, pos, lo, hi} in its LIBERO row
    mean_pos: dict[str, np.ndarray]  # instance -> mean world position over every LIBERO row
    workspace: str  # fixture the regions are on ("main_table", "kitchen_table", "floor", ...)
    workspace_offset: np.ndarray  # world position of LIBERO's region coordinate origin
    object_classes: dict  # instance -> LIBERO object (for rotation, footprints)
    site_joints: dict  # region or fixture name -> joint names that articulate it
    fixture_z: float  # height LIBERO's fixture sampler places a fixture's bottom site at
    surface_z: float  # height of the surface objects rest on (LIBERO's first state, settled)
    camera: tuple  # agentview (position, 3x3 orientation, vertical field of view in degrees)
    ray_scene: tuple  # (MjModel, MjData) of the settled first state, for visibility rays
    gripper_xy: np.ndarray  # mean xy of the gripper (end-effector site) over the trial rows: where reaches start

    def in_view(self, xy, z: float | None = None, margin: float = 0.85) -> bool:
        """Whether a point on the table is inside the central `margin` of the agentview image."""
        pos, mat, fovy = self.camera
        p = np.array([xy[0], xy[1], self.surface_z if z is None else z]) - pos
        c = mat.T @ p  # camera frame: looks along -z, y up
        if c[2] >= 0:
            return False
        t = np.tan(np.radians(fovy) / 2) * margin
        if not (abs(c[0] / -c[2]) < t and abs(c[1] / -c[2]) < t):
            return False
        # Not hidden behind a fixture or object: the camera ray to a point 3 cm above the table
        # meets nothing before it (LIBERO's first state, settled).
        model, data = self.ray_scene
        target = np.array([xy[0], xy[1], (self.surface_z if z is None else z) + 0.03])
        vec = target - pos
        dist = np.linalg.norm(vec)
        geom = np.array([-1], dtype=np.int32)
        hit = mujoco.mj_ray(model, data, pos, vec / dist, None, 1, -1, geom)
        return hit < 0 or hit >= dist - 0.02

    def on_surface(self, xy) -> bool:
        """Whether a point is over the surface objects stand on (a ray down from 5 cm above it meets
        something within 8 cm), not beyond the table's edge."""
        model, data = self.ray_scene
        start = np.array([xy[0], xy[1], self.surface_z + 0.05])
        geom = np.array([-1], dtype=np.int32)
        hit = mujoco.mj_ray(model, data, start, np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
        return 0 <= hit <= 0.08

    def to_region_xy(self, world_xy) -> np.ndarray:
        return np.asarray(world_xy, dtype=float) - self.workspace_offset[:2]


BASE_FIXTURE_SEED = 0


# One kept per process: a build worker takes the cases of one task at a time, and each base scene
# holds its env's MjModel (ray_scene), 70-120 MB for a LIBERO scene without textures (8 of them,
# with textures, were 1.6 GB per worker).
@functools.lru_cache(maxsize=1)
def base_scene(task_key: str) -> BaseScene:
    task = get_task(task_key)
    path = libero_bridge.bddl_path(task.suite, task.name)
    bddl = read_base(path)
    rows = libero_init_states(task)
    env = sim.physics_env(str(path))
    try:
        # Fixtures where LIBERO's reset puts them after seed 0: the measured layouts (and so every
        # generator's choice) are the same in every process; trials re-place them per trial seed.
        sim.place_fixtures(env, BASE_FIXTURE_SEED)
        slots = sim.joint_slots(env)
        positions: dict[str, list] = {}
        for k in range(len(rows)):
            sim.load_state(env, rows[k])
            for name, v in sim.body_layout(env).items():
                positions.setdefault(name, []).append(v["pos"])
        raw = sim.raw(env)
        trial_rows = _sound_rows(env, rows, TRIALS_PER_CASE, task.key)
        layouts, grippers = [], []
        for k in trial_rows:
            sim.load_state(env, rows[k])
            layouts.append(sim.body_layout(env))
            grippers.append(np.array(raw.sim.data.site_xpos[raw.robots[0].eef_site_id][:2]))
        sim.load_state(env, rows[0])
        sim.settle(env)
        surface = float(np.median([v["lo"][2] for v in sim.body_layout(env).values() if v["kind"] == "object"]))
        return BaseScene(
            task=task,
            bddl=bddl,
            rows=rows,
            trial_rows=trial_rows,
            slots=slots,
            layouts=layouts,
            mean_pos={k: np.mean(v, axis=0) for k, v in positions.items()},
            workspace=raw.workspace_name,
            workspace_offset=np.asarray(raw.workspace_offset, dtype=float),
            object_classes={**raw.objects_dict, **raw.fixtures_dict},
            site_joints=_site_joints(env),
            fixture_z=float(raw.workspace_offset[2] + getattr(raw, "z_offset", 0.0)),
            surface_z=surface,
            camera=_camera(env, "agentview"),
            ray_scene=_ray_scene(env),
            gripper_xy=np.mean(grippers, axis=0),
        )
    finally:
        sim.close(env)


def _sound_rows(env, rows: np.ndarray, count: int, task_key: str) -> list[int]:
    """The LIBERO rows trials start from: row k for trial k, except where LIBERO's own row k is
    unsound (an object falls off the table within one second of zero actions: under MuJoCo 3.8.1
    libero_10-00 row 2 drops the cream cheese on the floor; under the pinned 3.3.7 no row of the 40
    tasks does), which is replaced by the next sound row after the first `count` (in order), so a
    scene variant never inherits a defect of the base task's state."""

    def sound(k: int) -> bool:
        sim.load_state(env, rows[k])
        sim.settle(env)
        lows = [v["lo"][2] for v in sim.body_layout(env).values() if v["kind"] == "object"]
        return min(lows) >= float(np.median(lows)) - sim.DROP_TOL

    spare = iter(k for k in range(count, len(rows)) if sound(k))
    out = []
    for k in range(count):
        if sound(k):
            out.append(k)
        else:
            replacement = next(spare, None)
            if replacement is None:
                raise VProError(f"task {task_key}: fewer than {count} sound LIBERO initial states")
            out.append(replacement)
    return out


def _site_joints(env) -> dict[str, list[str]]:
    """Joints that move each region site (drawers) and each articulated fixture (all its joints)."""
    raw = sim.raw(env)
    m = raw.sim.model._model
    out = {}
    for name, site in raw.object_sites_dict.items():
        joints = [j for j in (getattr(site, "joints", None) or []) if j]
        if joints:
            out[name] = joints
    for name, fixture in raw.fixtures_dict.items():
        root = raw.sim.model.body_name2id(fixture.root_body)
        joints = [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            for j in range(m.njnt)
            if int(m.body_rootid[m.jnt_bodyid[j]]) == root
        ]
        if joints:
            out[name] = joints
    return out


def _camera(env, name: str) -> tuple:
    raw = sim.raw(env)
    cid = raw.sim.model.camera_name2id(name)
    return (
        np.array(raw.sim.data.cam_xpos[cid]),
        np.array(raw.sim.data.cam_xmat[cid]).reshape(3, 3),
        float(raw.sim.model.cam_fovy[cid]),
    )


def _ray_scene(env) -> tuple:
    raw = sim.raw(env)
    model = raw.sim.model._model
    data = mujoco.MjData(model)
    data.qpos[:] = raw.sim.data._data.qpos
    mujoco.mj_forward(model, data)
    return model, data
