"""Split substeps (`vpro_assets.libero.physics`): every env the toolkit builds steps with MuJoCo's
mj_step1/mj_step2 around robosuite's controllers instead of robosuite's three forward passes per
substep. Whatever a policy or a check can read after a step must be robosuite's own, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from vpro_assets.benchmark import certificate
from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.libero import physics
from vpro_assets.libero.env import libero_init_states, make_env
from vpro_assets.libero.settled import seeded_reset
from vpro_assets.libero.tasks import get_task
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy


def _actions(steps: int) -> np.ndarray:
    """Down onto the scene for 30 steps, then wandering; the gripper closes and opens every 20."""
    rng = np.random.default_rng(3)
    arm = rng.uniform(-1, 1, (steps, 6)) * [1, 1, 1, 0.3, 0.3, 0.3]
    arm[:30, 2] = -1.0
    grip = np.where((np.arange(steps) // 20) % 2, 1.0, -1.0)[:, None]
    return np.concatenate([arm, grip], axis=1)


def _episode(task_key: str, steps: int, render: bool) -> list:
    env = make_env(get_task(task_key), resolution=64, render=render)
    try:
        seeded_reset(env, 5)
        env.set_init_state(libero_init_states(get_task(task_key))[0])
        out = []
        for action in _actions(steps):
            obs, reward, done, _info = env.step(action)
            data = env.env.sim.data._data
            state = np.concatenate([data.qpos, data.qvel, data.act, data.ctrl, data.qacc_warmstart, data.qacc,
                                    data.xpos.ravel(), data.sensordata, [data.time]])  # fmt: skip
            out.append((state.tobytes(), {k: np.asarray(v).tobytes() for k, v in obs.items()}, reward, done))
        return out
    finally:
        env.close()


@pytest.mark.parametrize(("task_key", "render", "steps"), [("libero_goal-03", False, 80), ("libero_10-09", True, 12)])
def test_split_substeps_step_as_robosuite_bit_for_bit(task_key, render, steps):
    """libero_goal-03 (a cabinet with drawers, contacts with the bowl and the plate) render-free over
    80 steps, libero_10-09 (the microwave) rendered: state, every observation (images included),
    reward and success after every step equal to robosuite's own step."""
    with physics.reference():
        reference = _episode(task_key, steps, render)
    fast = _episode(task_key, steps, render)
    for step, (ref, got) in enumerate(zip(reference, fast)):
        assert ref[0] == got[0], f"{task_key}: state differs after step {step}"
        assert ref[1] == got[1], f"{task_key}: observations differ after step {step}"
        assert ref[2:] == got[2:], f"{task_key}: reward or success differs after step {step}"


def test_an_unobserved_step_leaves_the_state_an_observed_step_leaves():
    """`physics.unobserved_step` (render-free episodes of the oracle, which reads no observation)
    skips robosuite's observables: after every one of 80 steps of libero_goal-03 (drawers, the bowl
    and the plate in contact, the gripper opening and closing) the simulator's state, the success
    and LIBERO's step counter and time are those of the observed step, bit for bit."""
    task = get_task("libero_goal-03")
    runs = []
    for observe in (True, False):
        env = make_env(task, render=False)
        try:
            seeded_reset(env, 5)
            env.set_init_state(libero_init_states(task)[0])
            out = []
            for action in _actions(80):
                done = env.step(action)[2] if observe else physics.unobserved_step(env, action)
                data, inner = env.env.sim.data._data, env.env
                state = np.concatenate([data.qpos, data.qvel, data.act, data.ctrl, data.qacc_warmstart, data.qacc,
                                        data.xpos.ravel(), data.sensordata, [data.time]])  # fmt: skip
                out.append((state.tobytes(), bool(done), inner.timestep, inner.cur_time))
            runs.append(out)
        finally:
            env.close()
    for step, (observed, unobserved) in enumerate(zip(*runs, strict=True)):
        assert observed == unobserved, f"step {step}"


def test_a_certified_trial_ends_in_its_recorded_final_state():
    """The committed certificate's trial 1 of libero_spatial-00 (recorded with robosuite's own step,
    on another machine's CPU) replays with split substeps to the same steps and final-state
    fingerprint: the oracle's whole closed loop, not only a scripted one."""
    recorded = certificate.load()["cases"]["libero_spatial-00/normal"]
    k = recorded["trial_ids"].index(1)
    case = find_case(load_catalog(paths.catalog_path()), "libero_spatial-00/normal")
    row = run_episode(case, 1, OraclePolicy(), EpisodeSettings(render=False))
    assert (row["steps"], row["final_state"]) == (recorded["steps"][k], recorded["final_state"][k])
