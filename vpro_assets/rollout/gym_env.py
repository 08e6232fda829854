"""Every case as a gymnasium environment, so LeRobot-style loops run cases directly.

    import gymnasium as gym
    import vpro_assets.rollout.gym_env  # registers "vpro/Case-v0"
    env = gym.make("vpro/Case-v0", case="libero_goal-03/camera_staleness/wrist-delay1-v1")
    obs, info = env.reset(options={"trial": 0})

Observations are what the policy would see after the case's perturbation: both camera images in
LIBERO's raw (bottom-up) frame, as a harness expects to receive them before its own flip, plus the
8-float state (eef position, eef axis-angle, gripper joints). A view that is unavailable is a black
image and `info["available_views"]` lists the views really delivered. `reset` runs LIBERO's no-op
wait steps; an episode is truncated at the suite's step limit. Reward is 1 on success (terminated).

`obs_layout="lerobot"` returns LeRobot's LIBERO observation instead (`vpro_assets.rollout.lerobot_layout`:
`{"pixels": {"image", "image2"}, "robot_state": {...}}`, raw orientation, `obs_type` and
`camera_name_mapping` as LeRobot's), with the attributes and info LeRobot's loop reads (`task`,
`task_description`, `task_id`, `_max_episode_steps`; `info["is_success"]`), float32 actions, and
LeRobot's choice of initial state: without `options={"trial": k}`, successive resets take trials
`episode_index`, `episode_index + n_envs`, ... (modulo the case's trials). In both layouts the
simulator is seeded by the case's trial seed (the frozen scenes need it); `reset(seed=...)` seeds
only the env's `np_random`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.env import CAMERAS, NOOP_ACTION
from vpro_assets.libero.tasks import get_task
from vpro_assets.rollout import lerobot_layout
from vpro_assets.rollout.case_env import CaseEnv, check_available, env_for_case, release_cached_envs
from vpro_assets.rollout.episode import MAX_STEPS, WAIT_STEPS, prompt_of
from vpro_assets.rollout.policies.openpi import quat2axisangle

ENV_ID = "vpro/Case-v0"
LAYOUTS = ("vpro", "lerobot")


class VProCaseEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        case: str | dict,
        resolution: int = 256,
        max_steps: int | None = None,
        wait_steps: int = WAIT_STEPS,
        render_mode: str | None = None,
        obs_layout: str = "vpro",
        obs_type: str = "pixels_agent_pos",
        camera_name_mapping: dict[str, str] | None = None,
        episode_index: int = 0,
        n_envs: int = 1,
    ):
        self.case = case if isinstance(case, dict) else find_case(load_catalog(paths.catalog_path()), case)
        if obs_layout not in LAYOUTS:
            raise InvalidParameterError(
                f"case {self.case['id']}: obs_layout {obs_layout!r} is not one of {', '.join(LAYOUTS)}"
            )
        if int(n_envs) < 1 or int(episode_index) < 0:
            raise InvalidParameterError(
                f"case {self.case['id']}: need episode_index >= 0 and n_envs >= 1, got {episode_index!r} and {n_envs!r}"
            )
        check_available(self.case)
        self.obs_layout, self.obs_type = obs_layout, obs_type
        self.resolution, self.wait_steps = resolution, wait_steps
        self.max_steps = max_steps or MAX_STEPS.get(self.case["suite"], 520)
        self.render_mode = render_mode
        task = get_task(self.case["task"])
        self.task, self.task_id, self.task_description = task.name, task.index, prompt_of(self.case)
        self._max_episode_steps = self.max_steps  # what LeRobot's loop reads
        self._trials = len(self.case["trial_seeds"])
        self._next_trial, self._stride = int(episode_index), int(n_envs)
        if obs_layout == "lerobot":
            self.camera_name_mapping = lerobot_layout.check_options(self.case["id"], obs_type, camera_name_mapping)
            self.observation_space = lerobot_layout.observation_space(resolution, self.camera_name_mapping, obs_type)
            self.action_space = spaces.Box(-1.0, 1.0, (7,), np.float32)
        else:
            image = spaces.Box(0, 255, (resolution, resolution, 3), np.uint8)
            self.observation_space = spaces.Dict(
                {f"{cam}_image": image for cam in CAMERAS} | {"state": spaces.Box(-np.inf, np.inf, (8,), np.float64)}
            )
            self.action_space = spaces.Box(-1.0, 1.0, (7,), np.float64)
        self._cenv: CaseEnv | None = None
        self._raw: dict[str, Any] = {}
        self._shown: dict[str, Any] = {}
        self._steps = 0
        self._t = 0

    @property
    def _live(self) -> CaseEnv:
        if self._cenv is None:
            raise InvalidParameterError(f"case {self.case['id']}: call reset() before step()")
        return self._cenv

    def _observation(self) -> tuple[dict, dict]:
        images = self._live.policy_images(self._raw, self._t)
        self._shown = images
        info = {
            "available_views": [c for c in CAMERAS if images.get(c) is not None],
            "step": self._t,
            "language": self.task_description,
        }
        if self.obs_layout == "lerobot":
            return lerobot_layout.format_observation(
                self._raw, images, self._live.env, self.resolution, self.camera_name_mapping, self.obs_type
            ), info
        obs = {}
        for cam in CAMERAS:
            img = images.get(cam)
            obs[f"{cam}_image"] = (
                np.asarray(img, dtype=np.uint8)
                if img is not None
                else np.zeros((self.resolution,) * 2 + (3,), np.uint8)
            )
        obs["state"] = np.concatenate(
            [
                self._raw["robot0_eef_pos"],
                quat2axisangle(self._raw["robot0_eef_quat"]),
                self._raw["robot0_gripper_qpos"],
            ]
        ).astype(np.float64)
        return obs, info

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        options = options or {}
        if options.get("trial") is not None:
            trial = int(options["trial"])
        elif self.obs_layout == "lerobot":  # LeRobot's init_state_id: episode_index, then + n_envs per reset
            trial = self._next_trial % self._trials
            self._next_trial += self._stride
        else:
            trial = 0
        if self._cenv is not None:
            self._cenv.close()
        self._cenv = env_for_case(self.case, trial, resolution=self.resolution)
        self._raw = self._live.reset()
        self._t = self._steps = 0
        for _ in range(self.wait_steps):
            self._raw, _ = self._live.step(NOOP_ACTION)
            self._t += 1
        obs, info = self._observation()
        return obs, dict(info, trial=trial, case_id=self.case["id"], is_success=False)

    def step(self, action):
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (7,):
            raise InvalidParameterError(f"case {self.case['id']}: action must have shape (7,), got {action.shape}")
        self._raw, done = self._live.step(action)
        self._t += 1
        self._steps += 1
        success = bool(done and self._live.success())
        obs, info = self._observation()
        info.update(success=success, is_success=success, done=bool(done), task=self.task, task_id=self.task_id)
        return obs, float(success), success, (not success) and self._steps >= self.max_steps, info

    def render(self):
        if not self._raw:
            return None
        if self.obs_layout == "lerobot":  # as LeRobot's: the first view, rotated 180 degrees
            first = next(iter(self.camera_name_mapping))[: -len("_image")]
            view = self._shown.get(first)
            return None if view is None else np.ascontiguousarray(np.asarray(view)[::-1, ::-1])
        return np.concatenate([self._raw[f"{cam}_image"][::-1] for cam in CAMERAS], axis=1)

    def close(self):
        if self._cenv is not None:
            self._cenv.close()
            self._cenv = None
        release_cached_envs()


def register() -> None:
    if ENV_ID not in gym.registry:
        gym.register(ENV_ID, entry_point="vpro_assets.rollout.gym_env:VProCaseEnv")


register()
