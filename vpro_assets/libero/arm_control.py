"""robosuite's arm control for the substeps between two policy steps, without its per-call overhead.

robosuite 1.4 runs the arm's controller at every one of a control step's 25 substeps. Between
policy steps the action, the goal and every index are fixed, yet each substep looks up the
end-effector site by name five times, computes each site Jacobian twice (once for the Jacobian,
once inside each site velocity), checks the action against limits rebuilt by three property calls,
and reads the torque and gripper ranges anew: about half of a substep's Python. `Arms` keeps the
indices and ranges of an env's arms once per control step and runs, per substep:

- `Controller.update` with one `mj_jacSite` call for both Jacobians and no name lookups, assigning
  the same attributes from the same NumPy operations (same values, bit for bit);
- the controller's own `run_controller` (robosuite's OSC math, its numba kernels, unchanged);
- `SingleArm.control`'s clipping, gripper action (the gripper's own stateful `format_action`) and
  actuator writes, from the kept ranges.

Policy steps (the first substep of a control step: goal set, proprioceptive buffers pushed) run
robosuite's own `_pre_action`. Anything else than single arms with robosuite's base `update` and
`SingleArm.control` runs robosuite's own code at every substep. Used by `physics._substeps` only;
tests/libero/test_physics.py holds the whole step to robosuite's, bit for bit.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np


def _robosuite(module: str, name: str):
    return getattr(importlib.import_module(module), name)


@dataclass
class _Arm:
    robot: Any  # robosuite objects: untyped
    controller: Any
    site: int
    qpos_index: np.ndarray  # the controller's index lists as arrays, converted once per control step
    qvel_index: np.ndarray
    arm_actuators: np.ndarray
    torque_low: np.ndarray
    torque_high: np.ndarray
    gripper_actuators: np.ndarray
    gripper_bias: np.ndarray
    gripper_weight: np.ndarray
    gripper_slice: slice


class Arms:
    """The arms of one robosuite env during one control step (module docstring); `None` from
    `Arms.of` where some arm needs robosuite's own control."""

    def __init__(self, inner, arms: list[_Arm]):
        self.model, self.data = inner.sim.model._model, inner.sim.data._data
        self.arms = arms

    @classmethod
    def of(cls, inner) -> Arms | None:
        single_arm = _robosuite("robosuite.robots.single_arm", "SingleArm")
        base_update = _robosuite("robosuite.controllers.base_controller", "Controller").update
        libero_env = _robosuite("libero.libero.envs.bddl_base_domain", "BDDLBaseDomain")
        if type(inner)._pre_action is not libero_env._pre_action:
            return None
        model = inner.sim.model
        arms, cutoff = [], 0
        for robot in inner.robots:
            ctrl = robot.controller
            if type(robot).control is not single_arm.control or type(ctrl).update is not base_update:
                return None
            dim = ctrl.control_dim
            grippers = [model.actuator_name2id(a) for a in robot.gripper.actuators] if robot.has_gripper else []
            ctrl_range = model.actuator_ctrlrange[grippers]
            qvel_index = np.asarray(ctrl.qvel_index)
            arms.append(
                _Arm(
                    robot=robot,
                    controller=ctrl,
                    site=model.site_name2id(ctrl.eef_name),
                    qpos_index=np.asarray(ctrl.qpos_index),
                    qvel_index=qvel_index,
                    arm_actuators=np.asarray(robot._ref_joint_actuator_indexes),
                    torque_low=model.actuator_ctrlrange[robot._ref_joint_actuator_indexes, 0],
                    torque_high=model.actuator_ctrlrange[robot._ref_joint_actuator_indexes, 1],
                    gripper_actuators=np.asarray(grippers, dtype=np.int64),
                    # robosuite's Manipulator.grip_action computes these at every call, the same way
                    gripper_bias=0.5 * (ctrl_range[:, 1] + ctrl_range[:, 0]),
                    gripper_weight=0.5 * (ctrl_range[:, 1] - ctrl_range[:, 0]),
                    gripper_slice=slice(cutoff + dim, cutoff + robot.action_dim),
                )
            )
            cutoff += robot.action_dim
        return cls(inner, arms)

    def update(self, arm: _Arm) -> None:
        """robosuite's `Controller.update` (forced), the same attributes from the same operations.
        Where robosuite copies a fancy-indexed array again (`np.array(x[index])`, which keeps its
        memory order), the fancy-indexed array itself: the same values in the same order (C or F).
        The memory order matters: robosuite's numba kernels compile one version per layout, and
        their BLAS calls round differently (its mass-matrix block is F-ordered, so it is taken as
        robosuite takes it)."""
        ctrl, data, nv = arm.controller, self.data, self.model.nv
        ctrl.ee_pos = np.array(data.site_xpos[arm.site])
        ctrl.ee_ori_mat = np.array(data.site_xmat[arm.site].reshape([3, 3]))
        jacp, jacr = np.zeros((3, nv)), np.zeros((3, nv))
        mujoco.mj_jacSite(self.model, data, jacp, jacr, arm.site)
        ctrl.ee_pos_vel = np.array(np.dot(jacp, data.qvel))
        ctrl.ee_ori_vel = np.array(np.dot(jacr, data.qvel))
        ctrl.joint_pos = data.qpos[arm.qpos_index]
        ctrl.joint_vel = data.qvel[arm.qvel_index]
        ctrl.J_pos = jacp[:, arm.qvel_index]
        ctrl.J_ori = jacr[:, arm.qvel_index]
        ctrl.J_full = np.vstack([ctrl.J_pos, ctrl.J_ori])
        mass_matrix: np.ndarray = np.ndarray(shape=(nv, nv), dtype=np.float64, order="C")
        mujoco.mj_fullM(self.model, mass_matrix, data.qM)
        ctrl.mass_matrix = mass_matrix[arm.qvel_index, :][:, arm.qvel_index]
        ctrl.new_update = False

    def control(self, action: np.ndarray) -> None:
        """`SingleArm.control` of every arm for a substep that is not a policy step."""
        data = self.data
        for arm in self.arms:
            self.update(arm)
            torques = np.clip(arm.controller.run_controller(), arm.torque_low, arm.torque_high)
            arm.robot.torques = torques
            if len(arm.gripper_actuators):
                gripper = arm.robot.gripper.format_action(action[arm.gripper_slice])
                data.ctrl[arm.gripper_actuators] = arm.gripper_bias + arm.gripper_weight * gripper
            data.ctrl[arm.arm_actuators] = torques
