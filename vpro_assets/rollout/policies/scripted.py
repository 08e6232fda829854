"""A single pick-and-place waypoint controller from privileged simulator state.

It reads the target's and receptacle's geometry from the simulation (never the images) and moves
the grip site through waypoints with OSC_POSE delta actions, orientation held:
above the target -> down to the grasp point -> close -> lift -> over the receptacle -> down ->
open -> up. Wide, low targets (bowls, plates) are pinched at the rim along the fingers' axis;
others are grasped at the top. Its named stages make it the fixed, predictable motion that previews,
`vpro bench` and the perturbation tests drive (a stage per manipulation phase). The `oracle` policy
of `vpro eval`, which solves every goal, is `vpro_assets.rollout.policies.oracle`.

`PickPlaceController(sim, task).action()` gives the next 7-D action for the current state.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.core.mjgeom import colliding, world_aabb
from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.rollout.policies.oracle.world import Box

log = logging.getLogger(__name__)

OSC_MAX_STEP_M = 0.05  # robosuite OSC_POSE: action 1.0 moves the goal 5 cm (output_max 0.05)
GAIN = 2.0  # proportional gain on the position error, in units of OSC_MAX_STEP_M
TOLERANCE_M = 0.008
RIM_MIN_WIDTH_M = 0.09  # targets at least this wide and lower than wide are grasped at the rim
HOVER_M = 0.10
LIFT_M = 0.12
GRIPPER_STEPS = 12  # control steps to close or open the fingers
MAX_STAGE_STEPS = 120


def world_box(model, data, geoms) -> Box:
    """World axis-aligned box around the collision geoms (visual ones where none collide)."""
    return Box(*world_aabb(model, data, colliding(model, geoms) or list(geoms)))


class PickPlaceController:
    """Closed-loop waypoint controller for one episode."""

    def __init__(self, sim, task):
        if task.target is None:
            raise VProError(f"task {task.key}: no target object to pick; the scripted policy only picks and places")
        self.sim, self.task = sim, task
        self.entities = EntityIndex(sim, task)
        m, d = sim.model._model, sim.data._data
        left = d.xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "gripper0_leftfinger")]
        right = d.xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "gripper0_rightfinger")]
        axis = (left - right)[:2]
        self.finger_axis = np.append(axis / (np.linalg.norm(axis) + 1e-9), 0.0)
        self.stage, self.stage_steps = "above", 0
        self.grasp_point: np.ndarray | None = None
        self.carry_z: float | None = None

    def _eef(self) -> np.ndarray:
        return self.sim.data._data.site_xpos[self.entities.grip_site].copy()

    def _target_box(self) -> Box:
        return world_box(self.sim.model._model, self.sim.data._data, self.entities.target.geoms)

    def _planned_grasp(self) -> np.ndarray:
        if self.grasp_point is None:  # planned in the "approach" stage, which comes first
            raise VProError("scripted policy: grasp point used before it was planned")
        return self.grasp_point

    def _plan_grasp(self) -> np.ndarray:
        box = self._target_box()
        width, height = max(box.size[0], box.size[1]), box.size[2]
        if width >= RIM_MIN_WIDTH_M and height < width:
            point = box.center + self.finger_axis * (width / 2 - 0.012)
            point[2] = box.hi[2] - min(0.02, height / 3)
        else:
            point = box.center.copy()
            point[2] = box.hi[2] - min(0.035, height / 2)
        return point

    def _place_point(self) -> np.ndarray:
        m, d = self.sim.model._model, self.sim.data._data
        if self.entities.receptacle is None:
            return self.grasp_point + np.array([0.0, 0.0, 0.0])
        rec = world_box(m, d, self.entities.receptacle.geoms)
        target = self._target_box()
        eef = self._eef()
        below = eef[2] - target.lo[2]  # how far the target hangs below the grip site
        point = rec.center.copy()
        point[:2] += eef[:2] - target.center[:2]  # put the target's centre, not the grip site, over it
        point[2] = rec.hi[2] + below + 0.02
        return point

    def _move(self, goal: np.ndarray, grip: float) -> np.ndarray:
        delta = np.clip((goal - self._eef()) / OSC_MAX_STEP_M * GAIN, -1.0, 1.0)
        return np.concatenate([delta, np.zeros(3), [grip]])

    def _advance(self, stage: str) -> None:
        log.debug("scripted policy: %s -> %s", self.stage, stage)
        self.stage, self.stage_steps = stage, 0

    def action(self) -> np.ndarray:
        self.stage_steps += 1
        if self.stage_steps > MAX_STAGE_STEPS and self.stage not in ("done",):
            self._advance("done")
        eef = self._eef()
        if self.stage == "above":
            self.grasp_point = self._plan_grasp()
            goal = self.grasp_point + [0, 0, HOVER_M]
            if np.linalg.norm(goal - eef) < 2 * TOLERANCE_M:
                self._advance("descend")
            return self._move(goal, -1.0)
        if self.stage == "descend":
            point = self._planned_grasp()
            if np.linalg.norm(point - eef) < TOLERANCE_M:
                self._advance("close")
            return self._move(point, -1.0)
        if self.stage == "close":
            if self.stage_steps >= GRIPPER_STEPS:
                self._advance("lift")
                self.carry_z = eef[2] + LIFT_M
            return self._move(self._planned_grasp(), 1.0)
        if self.stage == "lift":
            goal = np.array([eef[0], eef[1], self.carry_z])
            if abs(goal[2] - eef[2]) < 2 * TOLERANCE_M:
                self._advance("carry")
            return self._move(goal, 1.0)
        if self.stage == "carry":
            place = self._place_point()
            goal = np.array([place[0], place[1], max(self.carry_z, place[2] + 0.05)])
            if np.linalg.norm(goal[:2] - eef[:2]) < 2 * TOLERANCE_M:
                self._advance("lower")
            return self._move(goal, 1.0)
        if self.stage == "lower":
            place = self._place_point()
            if np.linalg.norm(place - eef) < 2 * TOLERANCE_M or self.stage_steps > 60:
                self._advance("release")
            return self._move(place, 1.0)
        if self.stage == "release":
            if self.stage_steps >= GRIPPER_STEPS:
                self._advance("retreat")
            return np.concatenate([np.zeros(6), [-1.0]])
        if self.stage == "retreat":
            return self._move(eef + [0, 0, 0.05], -1.0) if self.stage_steps < 15 else self._done()
        return self._done()

    def _done(self) -> np.ndarray:
        self.stage = "done"
        return np.array([0, 0, 0, 0, 0, 0, -1.0])
