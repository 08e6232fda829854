"""robosuite's arm control for the substeps between two policy steps, without its per-call overhead.

robosuite 1.4 runs the arm's controller at every one of a control step's 25 substeps. Between
policy steps the action, the goal and every index are fixed, yet each substep looks up the
end-effector site by name five times, computes each site Jacobian twice (once for the Jacobian,
once inside each site velocity), checks the action against limits rebuilt by three property calls,
reads the torque and gripper ranges anew, and copies arrays it only reads: about half of a
substep's Python. `Arms` keeps the indices, ranges and MuJoCo output buffers of an env's arms
(found once, kept on the env until a reset makes new controllers) and runs, per substep:

- `Controller.update` with one `mj_jacSite` call for both Jacobians and no name lookups, assigning
  the same attributes from the same NumPy operations (same values, bit for bit);
- the OSC controller's `run_controller` written out (`Arms.osc_torques`): robosuite's numba kernels
  on the same arrays, its `np.dot` calls on the same operands, its elementwise operations in the
  same order, without the copies of arrays it only reads;
- where `osc_kernel` has its kernel (numpy's bundled OpenBLAS, robosuite's numba, MuJoCo's C API:
  this toolkit's environment), those two in one numba call instead (`Arms.osc_substep`, half the
  time of the NumPy path): the same operations again, numpy's own `cblas_dgemv` for its `np.dot`;
- `SingleArm.control`'s clipping, gripper action (PandaGripper's `format_action`, its step kept
  for the control step) and actuator writes, from the kept ranges;
- where nothing observes the substeps (`physics._substeps` with `observe=False`) and the kernel
  is at hand, for one OSC arm with a Panda gripper: all of a control step's remaining substeps,
  MuJoCo's split step included, in one compiled call (`Arms.fused_substeps`, `fused_substeps`).

Every operation that rounds is robosuite's own, on the same operands in the same memory order (the
numba kernels compile one version per layout, and BLAS rounds by layout too); what changed is
only lookups, copies and allocations. So states are robosuite's bit for bit:
tests/libero/test_arm_control.py compares every substep's state, controls and controller
attributes with robosuite's `SingleArm.control`, tests/libero/test_physics.py the whole step.

Policy steps (the first substep of a control step: goal set, proprioceptive buffers pushed) run
robosuite's own `_pre_action`. Anything else than single arms with robosuite's base `update` and
`SingleArm.control` runs robosuite's own code at every substep; another controller (or OSC with
variable gains or interpolators) its own `run_controller`, another gripper its own
`format_action`. Used by `physics._substeps` only.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from vpro_assets.libero import fused_substeps, osc_kernel

# np.clip's own ufunc: np.clip reaches it through three Python calls (ndarray.clip, _methods._clip)
_CLIP = np.core.umath.clip  # type: ignore[attr-defined]  # numpy < 2 (pyproject.toml)


def _robosuite(module: str, name: str):
    return getattr(importlib.import_module(module), name)


def forget(inner) -> None:
    """Drop the arms an env keeps (`Arms.of`): they hold its model and data, which a hard reset is
    about to replace (`physics.physics_env` calls this; elsewhere they go at the next control step)."""
    inner.__dict__.pop("_vpro_arms", None)


@dataclass
class _Arm:
    robot: Any  # robosuite objects: untyped
    controller: Any
    site: int
    qpos_index: np.ndarray  # the controller's index lists as arrays, converted once
    qvel_index: np.ndarray
    arm_actuators: np.ndarray
    torque_low: np.ndarray
    torque_high: np.ndarray
    gripper_actuators: np.ndarray
    gripper_bias: np.ndarray
    gripper_weight: np.ndarray
    gripper_slice: slice
    jacp: np.ndarray  # mj_jacSite's and mj_fullM's outputs, written whole at each substep
    jacr: np.ndarray
    mass_matrix: np.ndarray
    osc: bool  # robosuite's OSC `run_controller` as written out in `Arms.osc_torques`
    panda_gripper: bool  # the gripper's `format_action` is PandaGripper's (`Arms.grip`)


def _handled_osc(ctrl) -> bool:
    """Whether `Arms.osc_torques` is this controller's `run_controller`: robosuite's OSC class itself
    with fixed gains and no interpolators (LIBERO's OSC_POSE and OSC_POSITION)."""
    osc = _robosuite("robosuite.controllers.osc", "OperationalSpaceController")
    return (
        type(ctrl).run_controller is osc.run_controller
        and ctrl.interpolator_pos is None
        and ctrl.interpolator_ori is None
        and ctrl.impedance_mode == "fixed"
    )


class Arms:
    """The arms of one robosuite env during one control step (module docstring); `None` from
    `Arms.of` where some arm needs robosuite's own control."""

    def __init__(self, inner, arms: list[_Arm]):
        self.model, self.data = inner.sim.model._model, inner.sim.data._data
        self.arms = arms
        # MjData's arrays, looked up once: each attribute access makes a new view of the same
        # memory, which MuJoCo never moves during a data's life
        data = self.data
        self.site_xpos, self.site_xmat, self.qpos, self.qvel = data.site_xpos, data.site_xmat, data.qpos, data.qvel
        self.qM, self.qfrc_bias, self.ctrl = data.qM, data.qfrc_bias, data.ctrl
        self.grip_steps: dict[int, np.ndarray] = {}  # per arm: the gripper's step in this control step
        self.kernel = osc_kernel.kernel_if_worth_it()  # None: the NumPy path below
        self.addresses = (self.model._address, self.data._address) if self.kernel is not None else (0, 0)
        # the substeps between policy steps in one call (`fused_substeps`): one OSC arm, a Panda gripper
        one_panda = len(arms) == 1 and arms[0].osc and arms[0].panda_gripper and len(arms[0].gripper_actuators) > 0
        self.fused = fused_substeps.kernel() if self.kernel is not None and one_panda else None
        # robosuite's numba kernels as its OSC module binds them (`from control_utils import *`)
        osc = importlib.import_module("robosuite.controllers.osc")
        self.orientation_error = osc.orientation_error
        self.opspace_matrices = osc.opspace_matrices
        self.nullspace_torques = osc.nullspace_torques

    @classmethod
    def of(cls, inner) -> Arms | None:
        """The env's arms for this control step: those of its previous control step while the env
        keeps its model, data, robots, controllers and grippers (a reset makes new controllers, a
        hard reset new everything), else found anew (about 0.2 ms, mostly robosuite's name lookups)."""
        osc_kernel.step_run()
        key = (id(inner.sim.model._model), id(inner.sim.data._data)) + tuple(
            (id(robot), id(robot.controller), id(getattr(robot, "gripper", None))) for robot in inner.robots
        )
        # the kept Arms references every object of the key, so no id in it can be reused meanwhile
        kept = getattr(inner, "_vpro_arms", None)
        if kept is not None and kept[0] == key:
            arms = kept[1]
        else:
            arms = cls.find(inner)
            inner._vpro_arms = (key, arms)
        if arms is not None:
            arms.grip_steps.clear()  # a new control step, a new action
        return arms

    @classmethod
    def find(cls, inner) -> Arms | None:
        single_arm = _robosuite("robosuite.robots.single_arm", "SingleArm")
        base_update = _robosuite("robosuite.controllers.base_controller", "Controller").update
        libero_env = _robosuite("libero.libero.envs.bddl_base_domain", "BDDLBaseDomain")
        panda_gripper = _robosuite("robosuite.models.grippers.panda_gripper", "PandaGripper")
        if type(inner)._pre_action is not libero_env._pre_action:
            return None
        model = inner.sim.model
        nv = model.nv
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
                    jacp=np.zeros((3, nv)),
                    jacr=np.zeros((3, nv)),
                    mass_matrix=np.zeros((nv, nv)),
                    osc=_handled_osc(ctrl),
                    panda_gripper=robot.has_gripper
                    and type(robot.gripper).format_action is panda_gripper.format_action,
                )
            )
            cutoff += robot.action_dim
        return cls(inner, arms)

    def update(self, arm: _Arm) -> None:
        """robosuite's `Controller.update` (forced), the same attributes from the same operations.
        Where robosuite copies a fresh array again (`np.array(x[index])`, `np.array(np.dot(..))`,
        which keep its memory order), the fresh array itself; where it stacks the two Jacobians
        (`np.vstack`: `np.concatenate` of its arguments made 2-d), `np.concatenate`: the same
        values in the same order (C or F). The memory order matters: robosuite's numba kernels
        compile one version per layout, and their BLAS calls round differently (its mass-matrix
        block is F-ordered, so it is taken as robosuite takes it). The Jacobians and the mass
        matrix are written into the arm's buffers (mj_jacSite and mj_fullM write every element)
        and copied out by the fancy indexing, so no attribute shares a buffer."""
        ctrl, model, index = arm.controller, self.model, arm.qvel_index
        ctrl.ee_pos = np.array(self.site_xpos[arm.site])
        ctrl.ee_ori_mat = np.array(self.site_xmat[arm.site].reshape([3, 3]))
        jacp, jacr, qvel = arm.jacp, arm.jacr, self.qvel
        mujoco.mj_jacSite(model, self.data, jacp, jacr, arm.site)
        ctrl.ee_pos_vel = np.dot(jacp, qvel)
        ctrl.ee_ori_vel = np.dot(jacr, qvel)
        ctrl.joint_pos = self.qpos[arm.qpos_index]
        ctrl.joint_vel = qvel[index]
        ctrl.J_pos = jacp[:, index]
        ctrl.J_ori = jacr[:, index]
        ctrl.J_full = np.concatenate([ctrl.J_pos, ctrl.J_ori])
        mujoco.mj_fullM(model, arm.mass_matrix, self.qM)
        ctrl.mass_matrix = arm.mass_matrix[index, :][:, index]
        ctrl.new_update = False

    def osc_torques(self, arm: _Arm) -> np.ndarray:
        """robosuite's `OperationalSpaceController.run_controller` after its `update` (done) for fixed
        gains and no interpolators (`_handled_osc`), operation for operation: the same numba kernels
        on the same arrays, the same `np.dot` calls on the same operands, the same elementwise
        operations in the same order. Left out: the copies robosuite takes of arrays it only reads
        (`np.array(position_error)`, `np.array(self.kp[0:3])`, `np.array(self.goal_pos)`), whose
        values are the same; kept: the copy of the goal orientation a numba kernel receives (a copy
        is contiguous, and the kernel's layout decides its compiled version)."""
        ctrl = arm.controller
        ori_error = self.orientation_error(np.array(ctrl.goal_ori), ctrl.ee_ori_mat)
        kp, kd = ctrl.kp, ctrl.kd
        desired_force = np.multiply(ctrl.goal_pos - ctrl.ee_pos, kp[0:3]) + np.multiply(-ctrl.ee_pos_vel, kd[0:3])
        desired_torque = np.multiply(ori_error, kp[3:6]) + np.multiply(-ctrl.ee_ori_vel, kd[3:6])
        lambda_full, lambda_pos, lambda_ori, nullspace_matrix = self.opspace_matrices(
            ctrl.mass_matrix, ctrl.J_full, ctrl.J_pos, ctrl.J_ori
        )
        if ctrl.uncoupling:
            decoupled_wrench = np.concatenate([np.dot(lambda_pos, desired_force), np.dot(lambda_ori, desired_torque)])
        else:
            decoupled_wrench = np.dot(lambda_full, np.concatenate([desired_force, desired_torque]))
        torques = np.dot(ctrl.J_full.T, decoupled_wrench) + self.qfrc_bias[arm.qvel_index]
        torques += self.nullspace_torques(
            ctrl.mass_matrix, nullspace_matrix, ctrl.initial_joint, ctrl.joint_pos, ctrl.joint_vel
        )
        ctrl.torques = torques
        ctrl.new_update = True  # robosuite's base `run_controller`
        return torques

    def osc_substep(self, arm: _Arm) -> np.ndarray:
        """`update` and `osc_torques` in one call of `osc_kernel`'s kernel (the same operations),
        the controller's attributes set from what it returns."""
        ctrl = arm.controller
        out = self.kernel(
            *self.addresses, arm.site, arm.jacp, arm.jacr, arm.mass_matrix, self.site_xpos, self.site_xmat,
            self.qpos, self.qvel, self.qM, self.qfrc_bias, arm.qpos_index, arm.qvel_index, ctrl.goal_pos,
            np.array(ctrl.goal_ori), ctrl.kp, ctrl.kd, ctrl.initial_joint, ctrl.uncoupling,
        )  # fmt: skip
        (torques, ctrl.ee_pos, ctrl.ee_ori_mat, ctrl.ee_pos_vel, ctrl.ee_ori_vel, ctrl.joint_pos, ctrl.joint_vel,
         ctrl.J_pos, ctrl.J_ori, ctrl.J_full, ctrl.mass_matrix) = out  # fmt: skip
        ctrl.torques = torques
        ctrl.new_update = True  # robosuite's base `run_controller`
        return torques

    def control(self, action: np.ndarray) -> None:
        """`SingleArm.control` of every arm for a substep that is not a policy step."""
        ctrl = self.ctrl
        for n, arm in enumerate(self.arms):
            if arm.osc and self.kernel is not None:
                raw = self.osc_substep(arm)
            else:
                self.update(arm)
                raw = self.osc_torques(arm) if arm.osc else arm.controller.run_controller()
            torques = _CLIP(raw, arm.torque_low, arm.torque_high)
            arm.robot.torques = torques
            if len(arm.gripper_actuators):
                gripper_action = action[arm.gripper_slice]
                if arm.panda_gripper:
                    gripper = self.grip(n, arm.robot.gripper, gripper_action)
                else:
                    gripper = arm.robot.gripper.format_action(gripper_action)
                ctrl[arm.gripper_actuators] = arm.gripper_bias + arm.gripper_weight * gripper
            ctrl[arm.arm_actuators] = torques

    def grip(self, n: int, gripper, action: np.ndarray) -> np.ndarray:
        """robosuite's `PandaGripper.format_action` for arm `n`: `clip(current + [-1, 1] * speed *
        sign(action), -1, 1)`, its step from `grip_step`; the clip is np.clip's own ufunc."""
        gripper.current_action = _CLIP(gripper.current_action + self.grip_step(n, gripper, action), -1.0, 1.0)
        return gripper.current_action

    def grip_step(self, n: int, gripper, action: np.ndarray) -> np.ndarray:
        """PandaGripper's step (`[-1, 1] * speed * sign(action)`, the same product in the same order):
        it depends on the action only, so it is computed at the control step's first substep here and
        kept."""
        step = self.grip_steps.get(n)
        if step is None:
            assert len(action) == gripper.dof
            step = self.grip_steps[n] = np.array([-1.0, 1.0]) * gripper.speed * np.sign(action)
        return step

    def fused_substeps(self, action: np.ndarray, count: int) -> bool:
        """`count` whole substeps (mj_step1, `control`, mj_step2) in one call of `fused_substeps`'s
        kernel, where it applies (one OSC arm with a Panda gripper, the kernel at hand, the gripper's
        action of its step's shape); the attributes `control` sets, set from the last of them.
        Returns whether it ran (False: nothing was done)."""
        if self.fused is None or count < 1:
            return False
        arm = self.arms[0]
        ctrl, robot = arm.controller, arm.robot
        gripper = robot.gripper
        step = self.grip_step(0, gripper, action[arm.gripper_slice])
        current = gripper.current_action
        if current.shape != step.shape or current.dtype != np.float64:
            return False  # before the gripper's first format_action (never after a policy step's)
        out, robot.torques, gripper.current_action = self.fused(
            count, *self.addresses, arm.site, arm.jacp, arm.jacr, arm.mass_matrix, self.site_xpos, self.site_xmat,
            self.qpos, self.qvel, self.qM, self.qfrc_bias, arm.qpos_index, arm.qvel_index, ctrl.goal_pos,
            np.array(ctrl.goal_ori), ctrl.kp, ctrl.kd, ctrl.initial_joint, ctrl.uncoupling, arm.torque_low,
            arm.torque_high, arm.arm_actuators, self.ctrl, step, current, arm.gripper_actuators, arm.gripper_bias,
            arm.gripper_weight,
        )  # fmt: skip
        (ctrl.torques, ctrl.ee_pos, ctrl.ee_ori_mat, ctrl.ee_pos_vel, ctrl.ee_ori_vel, ctrl.joint_pos, ctrl.joint_vel,
         ctrl.J_pos, ctrl.J_ori, ctrl.J_full, ctrl.mass_matrix) = out  # fmt: skip
        ctrl.new_update = True  # robosuite's base `run_controller`
        return True
