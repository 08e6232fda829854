"""The substeps between policy steps in one compiled call (`vpro_assets.libero.fused_substeps`)
against the split step's Python loop and robosuite's own step: the same state and the same
controller, robot and gripper attributes after every control step, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from vpro_assets.libero import arm_control, fused_substeps, osc_kernel, physics
from vpro_assets.libero.env import libero_init_states, make_env
from vpro_assets.libero.settled import seeded_reset
from vpro_assets.libero.tasks import get_task

CONTROLLER_FIELDS = ("torques", "ee_pos", "ee_ori_mat", "ee_pos_vel", "ee_ori_vel", "joint_pos", "joint_vel",
                     "J_pos", "J_ori", "J_full", "mass_matrix", "new_update")  # fmt: skip
STATE_FIELDS = ("qpos", "qvel", "act", "ctrl", "qacc_warmstart", "qacc", "xpos", "sensordata", "time")


def _actions(steps: int) -> np.ndarray:
    """Down onto the scene first, then arm commands up to twice the action limits (robosuite clips
    them, and the torques reach their limits); the gripper closes, opens or idles (0: no motion)."""
    rng = np.random.default_rng(17)
    arm = rng.uniform(-2, 2, (steps, 6))
    arm[:30, 2] = -2.0
    grip = np.array([1.0, -1.0, 0.0, 0.4, -0.3])[(np.arange(steps) // 9) % 5][:, None]
    return np.concatenate([arm, grip], axis=1)


def _run(task_key: str, steps: int, path: str) -> list:
    """After every control step: the state, the arm's torques, the gripper's action and every
    controller attribute (values, dtype and memory order); `path`: robosuite's own step, the split
    step's Python loop (`unfused`) or the fused call."""
    task = get_task(task_key)
    env = make_env(task, render=False)
    try:
        seeded_reset(env, 5)
        env.set_init_state(libero_init_states(task)[0])
        inner = env.env
        data, robot = inner.sim.data._data, inner.robots[0]
        out = []
        for action in _actions(steps):
            physics.unobserved_step(env, action)
            values = [np.array(getattr(data, name)) for name in STATE_FIELDS]
            values += [robot.torques, robot.gripper.current_action]
            values += [np.asarray(getattr(robot.controller, name)) for name in CONTROLLER_FIELDS]
            out.append(
                [(v.dtype.str, v.shape, v.flags.c_contiguous, v.flags.f_contiguous, v.tobytes()) for v in values]
            )
        return out
    finally:
        env.close()


@pytest.mark.parametrize("task_key", ["libero_goal-03"])
def test_fused_substeps_step_as_the_split_loop_and_robosuite(task_key, monkeypatch):
    """libero_goal-03 (a cabinet with drawers, the bowl and the plate in contact) over 150 control
    steps of large, changing actions, unobserved: after every step the state (qpos, qvel, act,
    ctrl, qacc_warmstart, qacc, body positions, sensors, time), the robot's torques, the gripper's
    action and every controller attribute with its memory order equal the split step's Python loop
    and robosuite's own step; and the fused call ran for every step."""
    assert fused_substeps.kernel() is not None, "numpy's OpenBLAS or MuJoCo's C API not found here"
    monkeypatch.setattr(osc_kernel, "KERNEL_AFTER_STEPS", 0)  # a short test: the kernels from the start
    with physics.reference():
        robosuite = _run(task_key, 150, "robosuite")
    fused = arm_control.Arms.fused_substeps
    with monkeypatch.context() as patch:
        patch.setattr(arm_control.Arms, "fused_substeps", lambda self, action, count: False)
        unfused = _run(task_key, 150, "unfused")
    calls = []

    def counted(self, action, count):
        calls.append(count)
        return fused(self, action, count)

    monkeypatch.setattr(arm_control.Arms, "fused_substeps", counted)
    got = _run(task_key, 150, "fused")
    assert calls == [24] * 150
    names = STATE_FIELDS + ("robot.torques", "gripper.current_action") + CONTROLLER_FIELDS
    for step, (ref, split, new) in enumerate(zip(robosuite, unfused, got, strict=True)):
        for name, a, b, c in zip(names, ref, split, new, strict=True):
            assert a == b, f"{task_key}: {name} of the split loop differs from robosuite's after step {step}"
            assert b == c, f"{task_key}: {name} of the fused call differs after step {step}"


def test_the_fused_call_runs_only_where_nothing_observes(monkeypatch):
    """An observed step (robosuite's observables after every substep), a step inside `metered()`
    (its timers wrap the bindings' MuJoCo calls) and an env whose kernel is not at hand run the
    substeps in Python."""
    monkeypatch.setattr(osc_kernel, "KERNEL_AFTER_STEPS", 0)
    calls = []
    fused = arm_control.Arms.fused_substeps
    monkeypatch.setattr(arm_control.Arms, "fused_substeps", lambda self, a, c: calls.append(c) or fused(self, a, c))
    task = get_task("libero_spatial-00")
    env = make_env(task, render=False)
    try:
        seeded_reset(env, 5)
        action = np.array([0.1, 0, -0.2, 0, 0, 0, 1.0])
        env.step(action)
        with physics.metered():
            physics.unobserved_step(env, action)
        assert calls == []
        physics.unobserved_step(env, action)
        assert calls == [24]
        arm_control.forget(env.env)
        monkeypatch.setattr(osc_kernel, "KERNEL_AFTER_STEPS", 10**9)  # the NumPy path: no kernel, no fused call
        arms = arm_control.Arms.of(env.env)
        assert arms is not None and arms.kernel is None and arms.fused is None
    finally:
        env.close()
