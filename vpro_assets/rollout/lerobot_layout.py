"""LeRobot's LIBERO observation layout (`lerobot.envs.libero.LiberoEnv`), for `vpro/Case-v0` with
`obs_layout="lerobot"`, so that LeRobot's evaluation loop runs a case unchanged.

What LeRobot's env returns, and so what this layout returns (read from huggingface/lerobot,
`src/lerobot/envs/libero.py` and `src/lerobot/processor/env_processor.py`):

    {"pixels": {"image": agentview, "image2": eye_in_hand},          # obs_type "pixels" stops here
     "robot_state": {"eef": {"pos": (3,), "quat": (4,) x y z w, "mat": (3, 3)},
                     "gripper": {"qpos": (2,), "qvel": (2,)},
                     "joints": {"pos": (7,), "vel": (7,)}}}

Images are HxWx3 uint8 in LIBERO's raw (bottom-up) frame, exactly as LeRobot's env hands them out:
LeRobot's `LiberoProcessorStep` rotates them 180 degrees and builds the 8-float state (eef
position, eef axis-angle, gripper joints) afterwards, in the policy's preprocessing. Here the
images are the case's perturbed views; the state is the simulator's (observation cases perturb
pixels only). `mat` is the controller's end-effector orientation matrix, as LeRobot reads it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from gymnasium import spaces

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.env import CAMERAS

OBS_TYPES = ("pixels_agent_pos", "pixels")
DEFAULT_CAMERA_NAMES = {f"{CAMERAS[0]}_image": "image", f"{CAMERAS[1]}_image": "image2"}
STATE_SHAPES: dict[str, dict[str, tuple[int, ...]]] = {
    "eef": {"pos": (3,), "quat": (4,), "mat": (3, 3)},
    "gripper": {"qpos": (2,), "qvel": (2,)},
    "joints": {"pos": (7,), "vel": (7,)},
}
RAW_STATE_KEYS = {
    ("eef", "pos"): "robot0_eef_pos",
    ("eef", "quat"): "robot0_eef_quat",
    ("gripper", "qpos"): "robot0_gripper_qpos",
    ("gripper", "qvel"): "robot0_gripper_qvel",
    ("joints", "pos"): "robot0_joint_pos",
    ("joints", "vel"): "robot0_joint_vel",
}


def check_options(case_id: str, obs_type: str, camera_name_mapping: Mapping[str, str] | None) -> dict[str, str]:
    """The camera -> pixel key mapping, after checking the options (bad values name the case)."""
    if obs_type not in OBS_TYPES:
        raise InvalidParameterError(f"case {case_id}: obs_type {obs_type!r} is not one of {', '.join(OBS_TYPES)}")
    mapping = dict(DEFAULT_CAMERA_NAMES if camera_name_mapping is None else camera_name_mapping)
    unknown = sorted(set(mapping) - set(DEFAULT_CAMERA_NAMES))
    if unknown or len(set(mapping.values())) != len(mapping) or not mapping:
        raise InvalidParameterError(
            f"case {case_id}: camera_name_mapping {mapping!r} must map some of "
            f"{', '.join(DEFAULT_CAMERA_NAMES)} to distinct names"
        )
    return mapping


def observation_space(resolution: int, mapping: Mapping[str, str], obs_type: str) -> spaces.Dict:
    image = spaces.Box(0, 255, (resolution, resolution, 3), np.uint8)
    layout: dict[str, spaces.Space] = {"pixels": spaces.Dict(dict.fromkeys(mapping.values(), image))}
    if obs_type == "pixels_agent_pos":
        layout["robot_state"] = spaces.Dict(
            {
                group: spaces.Dict({k: spaces.Box(-np.inf, np.inf, shape, np.float64) for k, shape in fields.items()})
                for group, fields in STATE_SHAPES.items()
            }
        )
    return spaces.Dict(layout)


def format_observation(
    raw: Mapping,
    images: Mapping[str, np.ndarray | None],
    libero_env,
    resolution: int,
    mapping: Mapping[str, str],
    obs_type: str,
) -> dict:
    """LeRobot's observation dict from LIBERO's raw observation and the case's views (camera ->
    raw frame, None for an unavailable view, delivered black)."""
    pixels = {}
    for key, name in mapping.items():
        img = images.get(key[: -len("_image")])
        pixels[name] = (
            np.asarray(img, dtype=np.uint8) if img is not None else np.zeros((resolution, resolution, 3), np.uint8)
        )
    if obs_type == "pixels":
        return {"pixels": pixels}
    mat = np.asarray(libero_env.robots[0].controller.ee_ori_mat, dtype=np.float64).reshape(3, 3)
    state = {
        group: {
            field: mat
            if (group, field) == ("eef", "mat")
            else np.asarray(raw[RAW_STATE_KEYS[group, field]], dtype=np.float64)
            for field in fields
        }
        for group, fields in STATE_SHAPES.items()
    }
    return {"pixels": pixels, "robot_state": state}
