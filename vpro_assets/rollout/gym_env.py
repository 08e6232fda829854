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
"""
from __future__ import annotations

from typing import Any, Optional

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from vpro_assets.core import paths
from vpro_assets.benchmark.catalog import find_case
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.libero.env import CAMERAS
from vpro_assets.libero.env import NOOP_ACTION
from vpro_assets.rollout.case_env import check_available, env_for_case, release_cached_envs
from vpro_assets.rollout.episode import MAX_STEPS, WAIT_STEPS, prompt_of
from vpro_assets.rollout.policies.openpi import quat2axisangle

ENV_ID = "vpro/Case-v0"


class VProCaseEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"]}

    def __init__(self, case: str | dict, resolution: int = 256, max_steps: Optional[int] = None,
                 wait_steps: int = WAIT_STEPS, render_mode: Optional[str] = None):
        self.case = case if isinstance(case, dict) else find_case(load_catalog(paths.catalog_path()), case)
        check_available(self.case)
        self.resolution, self.wait_steps = resolution, wait_steps
        self.max_steps = max_steps or MAX_STEPS.get(self.case["suite"], 520)
        self.render_mode = render_mode
        image = spaces.Box(0, 255, (resolution, resolution, 3), np.uint8)
        self.observation_space = spaces.Dict({f"{cam}_image": image for cam in CAMERAS}
                                             | {"state": spaces.Box(-np.inf, np.inf, (8,), np.float64)})
        self.action_space = spaces.Box(-1.0, 1.0, (7,), np.float64)
        self._cenv = None
        self._raw = None
        self._steps = 0
        self._t = 0

    def _observation(self) -> tuple[dict, dict]:
        images = self._cenv.policy_images(self._raw, self._t)
        obs = {}
        for cam in CAMERAS:
            img = images.get(cam)
            obs[f"{cam}_image"] = (np.asarray(img, dtype=np.uint8) if img is not None
                                   else np.zeros((self.resolution,) * 2 + (3,), np.uint8))
        obs["state"] = np.concatenate([self._raw["robot0_eef_pos"], quat2axisangle(self._raw["robot0_eef_quat"]),
                                       self._raw["robot0_gripper_qpos"]]).astype(np.float64)
        return obs, {"available_views": [c for c in CAMERAS if images.get(c) is not None], "step": self._t,
                     "language": prompt_of(self.case)}

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None):
        super().reset(seed=seed)
        trial = int((options or {}).get("trial", 0))
        if self._cenv is not None:
            self._cenv.close()
        self._cenv = env_for_case(self.case, trial, resolution=self.resolution)
        self._raw = self._cenv.reset()
        self._t = self._steps = 0
        for _ in range(self.wait_steps):
            self._raw, _ = self._cenv.step(NOOP_ACTION)
            self._t += 1
        obs, info = self._observation()
        return obs, dict(info, trial=trial, case_id=self.case["id"])

    def step(self, action):
        self._raw, done = self._cenv.step(np.asarray(action, dtype=np.float64))
        self._t += 1
        self._steps += 1
        success = bool(done and self._cenv.success())
        obs, info = self._observation()
        info["success"] = success
        return obs, float(success), success, (not success) and self._steps >= self.max_steps, info

    def render(self):
        if self._raw is None:
            return None
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
