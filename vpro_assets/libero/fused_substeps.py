"""The substeps between two policy steps of an unobserved control step in one numba call.

Substeps 1..24 of a control step read nothing but what the arm control reads, and where no
observer reads the simulator between them either (`physics._substeps` with `observe=False`:
render-free episodes, the build's settling, `vpro validate`'s drift check), what was left around
MuJoCo and `osc_kernel`'s kernel was Python: the substep loop, `Arms.control`, the kernel's
19-argument dispatch and the attributes set from its 11 results, the gripper's step, two clips, the
ctrl writes and the bindings' calls of mj_step1 and mj_step2 (about 35 us of a 230 us substep).
`substeps` runs that loop in one compiled call, per substep:
- MuJoCo's `mj_step1` and `mj_step2`, the C functions of the library the bindings loaded, called
  by address as `osc_kernel` calls `mj_jacSite`;
- `osc_kernel`'s kernel (robosuite's forced update and OSC torques), on the same arguments;
- `_clip`, numpy's clip ufunc for float64 (`_NPY_MIN(_NPY_MAX(x, low), high)` of numpy's
  clip.cpp, NaN handling included): comparisons only, the result is one of its operands;
- PandaGripper's `format_action` (`clip(current + step, -1, 1)`, the step computed once per
  control step by `Arms.grip_step`, as before) and the ctrl writes (`bias + weight * action`,
  one product and one sum per actuator, as numpy computes them elementwise).
The same floating-point operations on the same operands in the same order (numba without
fast-math neither contracts nor reorders), so the same state after every substep, bit for bit
(tests/libero/test_fused_substeps.py). The controller's, robot's and gripper's attributes are set
after the loop from its last substep, as `Arms.control` leaves them.

Used by `Arms.fused_substeps` where `Arms.control` would run the kernel for one OSC arm with a
Panda gripper; the kernel's rule for when a process compiles it (`osc_kernel.KERNEL_AFTER_STEPS`)
holds for this one too (compiled with it, about 14 s in all here). One difference: an error MuJoCo raises inside the loop
(`mju_error`: an internal fault or an arena too small) ends the process with MuJoCo's message where
the bindings would raise `mujoco.FatalError`, as it already did inside the kernel's `mj_jacSite`.
"""

from __future__ import annotations

import ctypes
import functools

import numpy as np

from vpro_assets.libero import osc_kernel


def _mujoco_steps():
    """MuJoCo's `mj_step1` and `mj_step2` from the library its Python bindings loaded."""
    lib = osc_kernel.mujoco_library()
    if lib is None:
        return None
    step1, step2 = lib.mj_step1, lib.mj_step2
    for fn in (step1, step2):
        fn.restype = None
        fn.argtypes = [ctypes.c_size_t, ctypes.c_size_t]  # mjModel*, mjData*: addresses as integers
    return step1, step2


@functools.cache
def kernel():
    """The compiled-on-first-call `substeps`, or None where `osc_kernel.kernel()` is None."""
    osc_substep = osc_kernel.kernel()
    steps = _mujoco_steps()
    if osc_substep is None or steps is None:
        return None
    import numba

    return _compile(numba, osc_substep, *steps)


def _compile(numba, osc_substep, step1, step2):
    @numba.njit
    def _clip(x, low, high):
        """numpy's clip of one float64: `_NPY_MIN(_NPY_MAX(x, low), high)` (module docstring)."""
        a = x if np.isnan(x) else (x if x > low else low)
        return a if np.isnan(a) else (a if a < high else high)

    @numba.njit
    def _substep(model, data, site, jacp, jacr, full_mass, site_xpos, site_xmat, qpos, qvel, qM, qfrc_bias,
                 qpos_index, qvel_index, goal_pos, goal_ori, kp, kd, initial_joint, uncoupling, torque_low,
                 torque_high, arm_actuators, ctrl, grip_step, current, gripper_actuators, gripper_bias,
                 gripper_weight):  # fmt: skip
        """One substep: `physics._substeps`'s mj_step1, `Arms.control`, mj_step2."""
        step1(model, data)
        out = osc_substep(model, data, site, jacp, jacr, full_mass, site_xpos, site_xmat, qpos, qvel, qM, qfrc_bias,
                          qpos_index, qvel_index, goal_pos, goal_ori, kp, kd, initial_joint, uncoupling)  # fmt: skip
        raw = out[0]
        torques = np.empty(raw.shape[0])
        for i in range(raw.shape[0]):
            torques[i] = _clip(raw[i], torque_low[i], torque_high[i])
        gripper = np.empty(current.shape[0])
        for i in range(current.shape[0]):
            gripper[i] = _clip(current[i] + grip_step[i], -1.0, 1.0)
        for i in range(gripper_actuators.shape[0]):
            ctrl[gripper_actuators[i]] = gripper_bias[i] + gripper_weight[i] * gripper[i]
        for i in range(arm_actuators.shape[0]):
            ctrl[arm_actuators[i]] = torques[i]
        step2(model, data)
        return out, torques, gripper

    @numba.njit
    def substeps(count, model, data, site, jacp, jacr, full_mass, site_xpos, site_xmat, qpos, qvel, qM, qfrc_bias,
                 qpos_index, qvel_index, goal_pos, goal_ori, kp, kd, initial_joint, uncoupling, torque_low,
                 torque_high, arm_actuators, ctrl, grip_step, current, gripper_actuators, gripper_bias,
                 gripper_weight):  # fmt: skip
        """`count` (>= 1) substeps of one arm; returns the last one's kernel results (the raw
        torques and the attributes `update` sets), clipped torques and gripper action."""
        out, torques, current = _substep(
            model, data, site, jacp, jacr, full_mass, site_xpos, site_xmat, qpos, qvel, qM, qfrc_bias, qpos_index,
            qvel_index, goal_pos, goal_ori, kp, kd, initial_joint, uncoupling, torque_low, torque_high,
            arm_actuators, ctrl, grip_step, current, gripper_actuators, gripper_bias, gripper_weight,
        )  # fmt: skip
        for _ in range(count - 1):
            out, torques, current = _substep(
                model, data, site, jacp, jacr, full_mass, site_xpos, site_xmat, qpos, qvel, qM, qfrc_bias,
                qpos_index, qvel_index, goal_pos, goal_ori, kp, kd, initial_joint, uncoupling, torque_low,
                torque_high, arm_actuators, ctrl, grip_step, current, gripper_actuators, gripper_bias,
                gripper_weight,
            )  # fmt: skip
        return out, torques, current

    return substeps
