"""`vpro/Case-v0` in LeRobot's layout: a LeRobot-style evaluation loop (lerobot_eval.rollout's calls,
on a gymnasium vector env, with LeRobot's LIBERO preprocessing ported to numpy) runs a VPro case
unchanged, and sees the same perturbed views and state as the toolkit's own layout."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import vpro_assets.rollout.gym_env  # noqa: F401  (registers vpro/Case-v0)
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.rollout.policies.openpi import quat2axisangle

CASE = "libero_goal-03/camera_staleness/third_person-delay2-v1"
KW = {"case": CASE, "resolution": 32, "wait_steps": 1, "max_steps": 13}  # the case delays its view by 10 steps
MOVE = np.array([0.6, 0.3, 0.0, 0.0, 0.0, 0.0, -1.0], np.float32)

# LeRobot's LiberoEnv (obs_type "pixels_agent_pos"), src/lerobot/envs/libero.py: nested keys and shapes.
LEROBOT_LAYOUT = {
    "pixels": {"image": (32, 32, 3), "image2": (32, 32, 3)},
    "robot_state": {
        "eef": {"pos": (3,), "quat": (4,), "mat": (3, 3)},
        "gripper": {"qpos": (2,), "qvel": (2,)},
        "joints": {"pos": (7,), "vel": (7,)},
    },
}


def _shapes(space):
    return {k: _shapes(v) for k, v in space.items()} if isinstance(space, (gym.spaces.Dict, dict)) else space.shape


def lerobot_preprocess(observation: dict) -> dict:
    """preprocess_observation + LiberoProcessorStep, in numpy: images (B, C, H, W) float in [0, 1]
    rotated 180 degrees, state (B, 8) = eef pos, eef axis-angle, gripper qpos."""
    out = {}
    for key, img in observation["pixels"].items():
        assert img.dtype == np.uint8 and img.shape[-1] == 3
        out[f"observation.images.{key}"] = np.flip(img.transpose(0, 3, 1, 2).astype(np.float32) / 255, axis=(2, 3))
    rs = observation["robot_state"]
    axis = np.stack([quat2axisangle(q) for q in rs["eef"]["quat"]])
    out["observation.state"] = np.concatenate([rs["eef"]["pos"], axis, rs["gripper"]["qpos"]], axis=-1).astype(
        np.float32
    )
    return out


def lerobot_rollout(env, select_action, seeds):
    """The calls lerobot_eval.rollout makes on its vector env, in its order."""
    observation, info = env.reset(seed=seeds, options={"lerobot_new_rollout": True})
    max_steps = env.call("_max_episode_steps")[0]
    done = np.array([False] * env.num_envs)
    step, seen, successes = 0, [], []
    while not np.all(done) and step < max_steps:
        batch = lerobot_preprocess(observation)
        batch["task"] = list(env.call("task_description"))
        seen.append((observation, batch))
        action = select_action(batch)
        assert action.ndim == 2, "Action dimensions should be (batch, action_dim)"
        observation, reward, terminated, truncated, info = env.step(action)
        successes.append(list(info["is_success"]) if "is_success" in info else [False] * env.num_envs)
        done = terminated | truncated | done
        step += 1
    seen.append((observation, lerobot_preprocess(observation)))
    return seen, successes, step


def test_a_lerobot_style_loop_runs_a_case_unchanged():
    env = gym.vector.SyncVectorEnv([lambda: gym.make("vpro/Case-v0", obs_layout="lerobot", **KW)])
    assert _shapes(env.single_observation_space) == LEROBOT_LAYOUT
    assert env.single_action_space.dtype == np.float32 and env.single_action_space.shape == (7,)
    ours = gym.make("vpro/Case-v0", **KW)  # the toolkit's own layout, stepped alongside
    ours_obs, _ = ours.reset(options={"trial": 0})
    mine, clean = [ours_obs], [ours.unwrapped._raw["agentview_image"].copy()]

    def select_action(batch):
        nonlocal ours_obs
        assert batch["observation.state"].shape == (1, 8) and batch["observation.images.image"].shape == (1, 3, 32, 32)
        ours_obs, *_ = ours.step(MOVE)
        mine.append(ours_obs)
        clean.append(ours.unwrapped._raw["agentview_image"].copy())
        return MOVE[None].copy()

    seen, successes, steps = lerobot_rollout(env, select_action, seeds=[0])
    assert steps == 13 and successes == [[False]] * 13
    task = env.call("task_description")[0]
    assert task == ours.unwrapped.task_description and task == ours.unwrapped.case.get("instruction", task)
    moved, offsets = 0, []
    for (raw, batch), vpro in zip(seen, mine, strict=True):
        # The views are the case's perturbed views, in LIBERO's raw orientation, as LeRobot's env gives them.
        assert np.array_equal(raw["pixels"]["image"][0], vpro["agentview_image"])
        assert np.array_equal(raw["pixels"]["image2"][0], vpro["robot0_eye_in_hand_image"])
        # LeRobot's processing turns them upright and builds the same 8-float state.
        assert np.array_equal(
            batch["observation.images.image"][0],
            vpro["agentview_image"][::-1, ::-1].transpose(2, 0, 1) / np.float32(255),
        )
        assert np.allclose(batch["observation.state"][0], vpro["state"], atol=1e-6)
        mat = raw["robot_state"]["eef"]["mat"][0]
        assert np.allclose(mat @ mat.T, np.eye(3), atol=1e-6)
        quat = raw["robot_state"]["eef"]["quat"][0]  # x, y, z, w
        body = np.zeros(9)
        mujoco.mju_quat2Mat(body, np.array([quat[3], *quat[:3]]))
        offsets.append(body.reshape(3, 3).T @ mat)  # the controller's frame (grip site) vs the hand body
        moved += not np.allclose(raw["robot_state"]["eef"]["pos"][0], seen[0][0]["robot_state"]["eef"]["pos"][0])
    assert moved >= 12  # the arm moved
    assert all(np.allclose(o, offsets[0], atol=0.02) for o in offsets)  # `mat` turns with the hand
    # The third-person view is `delay_steps` behind the render (the staleness the case claims); the
    # wrist view is current. (clean[k] is the render of observation k; the reset frame comes before.)
    delay = ours.unwrapped.case["params"]["delay_steps"]
    assert delay == 10
    for k in range(delay, len(seen)):
        assert np.array_equal(seen[k][0]["pixels"]["image"][0], clean[k - delay])
        assert not np.array_equal(clean[k], clean[k - delay])
    assert all(np.array_equal(seen[k][0]["pixels"]["image"][0], seen[0][0]["pixels"]["image"][0]) for k in range(delay))
    env.close()
    ours.close()


def test_lerobot_initial_state_order_and_bad_options():
    env = gym.make("vpro/Case-v0", obs_layout="lerobot", obs_type="pixels", episode_index=1, n_envs=2, **KW)
    obs, info = env.reset()
    assert set(obs) == {"pixels"} and info["trial"] == 1 and info["is_success"] is False
    assert env.unwrapped._next_trial == 3  # the next reset takes trial 3: LeRobot's init_state_id += n_envs
    assert env.render().shape == (32, 32, 3)
    with pytest.raises(InvalidParameterError, match=r"action must have shape \(7,\), got \(1, 7\)"):
        env.step(MOVE[None])
    env.close()
    with pytest.raises(InvalidParameterError, match=f"case {CASE}: obs_layout 'openvla' is not one of vpro, lerobot"):
        gym.make("vpro/Case-v0", obs_layout="openvla", **KW)
    with pytest.raises(InvalidParameterError, match="obs_type 'state' is not one of pixels_agent_pos, pixels"):
        gym.make("vpro/Case-v0", obs_layout="lerobot", obs_type="state", **KW)
