"""World-action models over openpi's websocket protocol: the opt-in extension for servers that
predict frames and keep a per-episode history (specified for model teams in docs/rollout.md).

A plain openpi server never sees anything new: the client reads two flags from the metadata the
server sends on connection, and only a server that sets them gets reset messages or has its
predicted frames read.

- `episode_reset: true`: at the start of every episode the client sends the message
  `{"reset": True, "prompt": <instruction>, "episode": {"case_id", "trial", "seed", "suite", "task"}}`
  (LingBot-VA's reset message plus the episode's identity) and waits for any dict reply.
- `predicts_frames: true`: every reply to an observation carries, next to `actions`,
  `predicted_frames`: camera name (`agentview`, `robot0_eye_in_hand`) -> uint8 array (h, w, 3), or
  (K, h, w, 3) for the K steps after the request, for every camera the request showed; (h, w) is the
  raw camera's size or the request image's size (224). `predicted_frames_orientation` (optional)
  says how they are turned: `raw` (the default: LIBERO's bottom-up render), `rot180` (as the
  request images: rotated 180 degrees) or `flipud` (flipped vertically only, LingBot-VA's
  convention). The client maps them back to raw orientation and the camera's size.

Every deviation is a `PolicyOutputError` naming the camera and the offending value: recorded
as an infrastructure error, never a crash and never a policy failure.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vpro_assets.libero.env import CAMERAS
from vpro_assets.rollout.policies.base import EpisodeInfo, PolicyOutputError

FLAG_PREDICTS_FRAMES = "predicts_frames"
FLAG_EPISODE_RESET = "episode_reset"
KEY_RESET, KEY_EPISODE = "reset", "episode"
KEY_FRAMES = "predicted_frames"
KEY_ORIENTATION = "predicted_frames_orientation"

# Each orientation's inverse: the map from the frame as sent back to LIBERO's raw (bottom-up) frame,
# acting on (K, h, w, 3) stacks.
TO_RAW = {
    "raw": lambda a: a,
    "rot180": lambda a: a[:, ::-1, ::-1],
    "flipud": lambda a: a[:, ::-1],
}


def server_flag(metadata: Mapping, key: str, where: str) -> bool:
    """A boolean flag of the server's metadata (absent = False), or PolicyOutputError."""
    value = metadata.get(key, False) if isinstance(metadata, Mapping) else False
    if not isinstance(value, (bool, np.bool_)):
        raise PolicyOutputError(f"{where}: metadata key {key!r} must be true or false, got {value!r}")
    return bool(value)


def reset_message(episode: EpisodeInfo) -> dict:
    return {
        KEY_RESET: True,
        "prompt": str(episode.instruction),
        KEY_EPISODE: {
            "case_id": episode.case_id,
            "trial": int(episode.trial),
            "seed": int(episode.seed),
            "suite": episode.suite,
            "task": episode.task,
        },
    }


def _unpad_resize(frames: np.ndarray, height: int, width: int) -> np.ndarray:
    """Undo openpi's `resize_with_pad` from an (h, w) original: crop the zero padding it added, then
    resize back (the same bilinear PIL resize)."""
    from openpi_client import image_tools

    size_h, size_w = frames.shape[1:3]
    ratio = max(width / size_w, height / size_h)
    inner_h, inner_w = int(height / ratio), int(width / ratio)
    top, left = max(0, (size_h - inner_h) // 2), max(0, (size_w - inner_w) // 2)
    inner = np.ascontiguousarray(frames[:, top : top + inner_h, left : left + inner_w])
    return image_tools.resize_with_pad(inner, height, width)


def decode_predicted_frames(
    reply: Mapping, shapes: Mapping[str, tuple], request_size: int, where: str
) -> dict[str, np.ndarray]:
    """The reply's predicted frames in LIBERO's raw frame: camera -> (h, w, 3) uint8, or (K, h, w, 3).

    `shapes`: the raw shape of every camera the request showed (each must be predicted);
    `request_size`: the side of the square request images.
    """
    if KEY_FRAMES not in reply:
        raise PolicyOutputError(
            f"{where}: reply has no {KEY_FRAMES!r} although the server declares "
            f"{FLAG_PREDICTS_FRAMES} (reply keys: {', '.join(sorted(map(str, reply)))})"
        )
    frames = reply[KEY_FRAMES]
    if not isinstance(frames, Mapping):
        raise PolicyOutputError(
            f"{where}: {KEY_FRAMES!r} must map camera names to uint8 arrays, got a {type(frames).__name__}"
        )
    orientation = reply.get(KEY_ORIENTATION, "raw")
    if orientation not in TO_RAW:
        raise PolicyOutputError(f"{where}: {KEY_ORIENTATION} {orientation!r} is not one of {', '.join(TO_RAW)}")
    unknown = [str(cam) for cam in frames if cam not in CAMERAS]
    if unknown:
        raise PolicyOutputError(
            f"{where}: predicted frame for unknown camera {unknown[0]!r}; cameras are {', '.join(CAMERAS)}"
        )
    missing = [cam for cam in shapes if cam not in frames]
    if missing:
        raise PolicyOutputError(
            f"{where}: no predicted frame for camera {', '.join(missing)} "
            f"(predicted: {', '.join(map(str, frames)) or 'none'})"
        )
    out = {}
    for cam, raw_shape in shapes.items():
        arr = np.asarray(frames[cam])
        if arr.dtype != np.uint8:
            raise PolicyOutputError(f"{where}: predicted frame for {cam} has dtype {arr.dtype}; expected uint8")
        stack = arr[None] if arr.ndim == 3 else arr
        allowed = (tuple(raw_shape), (request_size, request_size, 3))
        if stack.ndim != 4 or stack.shape[0] < 1 or stack.shape[1:] not in allowed:
            raise PolicyOutputError(
                f"{where}: predicted frame for {cam} has shape {arr.shape}; expected "
                f"(h, w, 3) or (K, h, w, 3) with (h, w, 3) = {allowed[0]} (the camera) or "
                f"{allowed[1]} (the request image)"
            )
        if stack.shape[1:] != tuple(raw_shape):
            stack = _unpad_resize(stack, raw_shape[0], raw_shape[1])
        stack = np.ascontiguousarray(TO_RAW[orientation](stack))
        out[cam] = stack if arr.ndim == 4 else stack[0]
    return out
