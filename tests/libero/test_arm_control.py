"""The arm control between policy steps (`vpro_assets.libero.arm_control`) against robosuite's own
`SingleArm.control`, substep by substep: the same state, controls and controller attributes, bit
for bit, whatever the action (beyond the action limits, the gripper closing, opening or idle)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from vpro_assets.libero import arm_control, osc_kernel, physics
from vpro_assets.libero.env import libero_init_states, make_env
from vpro_assets.libero.settled import seeded_reset
from vpro_assets.libero.tasks import get_task

CONTROLLER_FIELDS = ("torques", "ee_pos", "ee_ori_mat", "ee_pos_vel", "ee_ori_vel", "joint_pos", "joint_vel",
                     "J_pos", "J_ori", "J_full", "mass_matrix", "new_update")  # fmt: skip


def _actions(steps: int) -> np.ndarray:
    """Arm commands up to three times the action limits (robosuite clips them), down onto the scene
    first; the gripper closes, opens or idles (0: no motion) in turns of seven steps."""
    rng = np.random.default_rng(11)
    arm = rng.uniform(-3, 3, (steps, 6))
    arm[:25, 2] = -3.0
    grip = np.array([1.0, -1.0, 0.0, 0.4])[(np.arange(steps) // 7) % 4][:, None]
    return np.concatenate([arm, grip], axis=1)


def _substep_states(task_key: str, steps: int, lean: bool) -> list:
    """Every substep's state of a split control step (physics._substeps, line for line) with the arm
    control of `arm_control` (`lean`) or robosuite's `_pre_action` at every substep."""
    task = get_task(task_key)
    env = make_env(task, render=False)
    try:
        seeded_reset(env, 5)
        env.set_init_state(libero_init_states(task)[0])
        inner = env.env
        sim = inner.sim
        model, data = sim.model._model, sim.data._data
        out = []
        for action in _actions(steps):
            arms = arm_control.Arms.of(inner) if lean else None
            for substep in range(int(inner.control_timestep / inner.model_timestep)):
                mujoco.mj_step1(model, data)
                if substep and arms is not None:
                    arms.control(action)
                else:
                    sim.forward = physics._forward_done
                    try:
                        inner._pre_action(action, substep == 0)
                    finally:
                        del sim.forward
                mujoco.mj_step2(model, data)
                robot = inner.robots[0]
                ctrl = robot.controller
                out.append(
                    (
                        [
                            data.qpos.copy(),
                            data.qvel.copy(),
                            data.ctrl.copy(),
                            data.act.copy(),
                            data.qacc_warmstart.copy(),
                        ],
                        [robot.torques.copy(), robot.gripper.current_action.copy()]
                        + [np.array(getattr(ctrl, name)) for name in CONTROLLER_FIELDS],
                        [
                            (getattr(ctrl, name).flags.c_contiguous, getattr(ctrl, name).flags.f_contiguous)
                            for name in ("J_pos", "J_ori", "J_full", "mass_matrix")
                        ],  # fmt: skip
                    )
                )
            inner._post_process()
        return out
    finally:
        env.close()


@pytest.mark.parametrize("path", ["kernel", "numpy"])
def test_arm_control_is_robosuites_substep_for_substep(path, monkeypatch):
    """libero_goal-03 (drawers, the bowl and the plate in contact) over 40 control steps of large
    actions: after each of the 1,000 substeps qpos, qvel, ctrl, act and qacc_warmstart, the torques,
    the gripper's action and every attribute the controller's update sets (with their memory order,
    which decides the numba kernels' compiled version) equal robosuite's; with `osc_kernel`'s
    kernel and with the NumPy path taken where it is not at hand."""
    reference = _substep_states("libero_goal-03", 40, lean=False)
    if path == "numpy":
        monkeypatch.setattr(osc_kernel, "kernel", lambda: None)
    else:
        assert osc_kernel.kernel() is not None, "numpy's OpenBLAS or MuJoCo's C API not found here"
        monkeypatch.setattr(osc_kernel, "KERNEL_AFTER_STEPS", 0)  # a short test: the kernel from the start
    lean = _substep_states("libero_goal-03", 40, lean=True)
    assert len(reference) == len(lean) == 1000
    for n, (ref, got) in enumerate(zip(reference, lean, strict=True)):
        step, substep = divmod(n, 25)
        for name, a, b in zip(("qpos", "qvel", "ctrl", "act", "qacc_warmstart"), ref[0], got[0], strict=True):
            assert np.array_equal(a, b), f"{name} differs after step {step} substep {substep}"
        for name, a, b in zip(("torques", "gripper") + CONTROLLER_FIELDS, ref[1], got[1], strict=True):
            assert a.dtype == b.dtype and np.array_equal(a, b), f"{name} differs after step {step} substep {substep}"
        assert ref[2] == got[2], f"memory order differs after step {step} substep {substep}"


def test_every_arm_of_libero_is_handled_and_kept_until_a_reset():
    """LIBERO's Panda with OSC_POSE takes the written-out controller and gripper, not the fallback;
    the env keeps its `Arms` from one control step to the next, drops them at a hard reset (they hold
    the model it replaces) and finds them anew after it (new model, robots and controllers)."""
    task = get_task("libero_goal-03")
    env = make_env(task, render=False)
    try:
        seeded_reset(env, 5)
        arms = arm_control.Arms.of(env.env)
        assert arms is not None
        assert [(arm.osc, arm.panda_gripper) for arm in arms.arms] == [(True, True)]
        env.step(np.zeros(7))
        assert arm_control.Arms.of(env.env) is arms
        seeded_reset(env, 6)  # a hard reset: a new model, and the kept arms (holding the old one) dropped
        assert "_vpro_arms" not in vars(env.env)
        again = arm_control.Arms.of(env.env)
        assert again is not arms and again is not None
        assert again.arms[0].controller is env.env.robots[0].controller
    finally:
        env.close()


def test_a_process_compiles_the_kernel_only_once_it_has_run_enough_steps(monkeypatch):
    """The kernel (compiled in each process) is taken from the first env reset after
    KERNEL_AFTER_STEPS control steps; before, the NumPy path (the same bits, no compile)."""
    monkeypatch.setattr(osc_kernel, "KERNEL_AFTER_STEPS", 3)
    monkeypatch.setattr(osc_kernel, "_STEPS_RUN", [0])
    for _ in range(2):
        osc_kernel.step_run()
        assert osc_kernel.kernel_if_worth_it() is None
    osc_kernel.step_run()
    assert osc_kernel.kernel_if_worth_it() is osc_kernel.kernel() is not None
