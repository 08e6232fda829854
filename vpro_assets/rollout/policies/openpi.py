"""A policy served by openpi's websocket protocol (`openpi-client`), as in openpi's LIBERO example.

Per request: both views rotated 180 degrees (LIBERO renders bottom-up), resized with padding to
224x224 (`image_tools.resize_with_pad`), uint8; state of 8 floats (eef position, eef axis-angle,
2 gripper joints); keys `observation/image`, `observation/wrist_image`, `observation/state`,
`prompt`. The reply's `actions` (H x 7) are executed 5 at a time before the next request.

Connection and replies are bounded in time: a refused connection, a server that does not answer
within `infer_timeout` seconds, a text (error) reply, or actions that are not finite (H, 7) raise
an InfrastructureError subclass; the connection is then dropped so the next episode reconnects on
a clean stream.

World-action models (`vpro_assets.rollout.policies.wam`): a server whose metadata sets
`episode_reset` gets a reset message with the instruction at the start of every episode; one that
sets `predicts_frames` returns predicted frames with its actions, which the adapter checks and maps
back to LIBERO's raw frame (`predicts_frames` is then true and Prediction-Reality Divergence cases
run). A plain openpi server sets neither and sees exactly openpi's LIBERO requests.
"""

from __future__ import annotations

import contextlib
import inspect
import logging
import math
from typing import Any

import numpy as np

from vpro_assets.libero.env import CAMERAS
from vpro_assets.rollout.policies.base import (
    EpisodeInfo,
    Observation,
    PolicyConnectionError,
    PolicyOutput,
    PolicyOutputError,
    PolicyTimeoutError,
    as_output,
)
from vpro_assets.rollout.policies.wam import (
    FLAG_EPISODE_RESET,
    FLAG_PREDICTS_FRAMES,
    decode_predicted_frames,
    reset_message,
    server_flag,
)

log = logging.getLogger(__name__)

RESIZE = 224
REPLAN_STEPS = 5
KEY_IMAGE, KEY_WRIST, KEY_STATE, KEY_PROMPT = (
    "observation/image",
    "observation/wrist_image",
    "observation/state",
    "prompt",
)


def quat2axisangle(quat: np.ndarray) -> np.ndarray:
    """robosuite's conversion (x, y, z, w quaternion to axis-angle), as openpi's example copies it."""
    quat = np.array(quat, dtype=np.float64)
    quat[3] = min(max(quat[3], -1.0), 1.0)
    den = math.sqrt(1.0 - quat[3] * quat[3])
    if math.isclose(den, 0.0):
        return np.zeros(3)
    return (quat[:3] * 2.0 * math.acos(quat[3])) / den


def prepare_image(raw: np.ndarray | None, size: int = RESIZE, like: np.ndarray | None = None) -> np.ndarray:
    """Raw (bottom-up) LIBERO frame -> upright, padded to size x size, uint8. A missing view is black."""
    from openpi_client import image_tools

    if raw is None:
        return np.zeros((size, size, 3), dtype=np.uint8)
    img = np.ascontiguousarray(np.asarray(raw)[::-1, ::-1])
    return image_tools.convert_to_uint8(image_tools.resize_with_pad(img, size, size))


def build_request(obs: Observation, prompt: str, size: int = RESIZE) -> dict:
    state = np.concatenate([obs.eef_pos, quat2axisangle(obs.eef_quat), obs.gripper_qpos]).astype(np.float64)
    return {
        KEY_IMAGE: prepare_image(obs.images.get(CAMERAS[0]), size),
        KEY_WRIST: prepare_image(obs.images.get(CAMERAS[1]), size),
        KEY_STATE: state,
        KEY_PROMPT: str(prompt),
    }


class OpenpiPolicy:
    """openpi websocket client with bounded connect and reply times. `episode_reset`: None follows
    the server's metadata, False never sends reset messages, True always does."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 8000,
        *,
        resize: int = RESIZE,
        replan_steps: int = REPLAN_STEPS,
        connect_timeout: float = 10.0,
        infer_timeout: float = 120.0,
        api_key: str | None = None,
        policy_id: str | None = None,
        episode_reset: bool | None = None,
    ):
        self.episode_reset = episode_reset
        self.host, self.port = host, int(port)
        self.resize, self.replan_steps = resize, replan_steps
        self.connect_timeout, self.infer_timeout = connect_timeout, infer_timeout
        self.api_key = api_key
        self.policy_id = policy_id or f"openpi@{host}:{port}"
        self._ws = None
        self.server_metadata: dict = {}
        self._flags = {FLAG_PREDICTS_FRAMES: False, FLAG_EPISODE_RESET: False}
        self._prompt = ""

    @property
    def uri(self) -> str:
        return self.host if self.host.startswith("ws") else f"ws://{self.host}:{self.port}"

    def _connect(self) -> None:
        import websockets.sync.client
        from openpi_client import msgpack_numpy

        headers = {"Authorization": f"Api-Key {self.api_key}"} if self.api_key else None
        try:
            # The connection outlives this call (as in openpi-client); websockets 17 calls that `legacy`.
            extra: dict[str, Any] = (
                {"legacy": True} if "legacy" in inspect.signature(websockets.sync.client.connect).parameters else {}
            )
            ws = websockets.sync.client.connect(
                self.uri,
                compression=None,
                max_size=None,
                additional_headers=headers,
                open_timeout=self.connect_timeout,
                **extra,
            )
        except TimeoutError:
            raise PolicyTimeoutError(
                f"policy server {self.uri}: no handshake within {self.connect_timeout:g} s"
            ) from None
        except (OSError, Exception) as exc:  # ConnectionRefusedError, InvalidHandshake, InvalidURI...
            raise PolicyConnectionError(
                f"policy server {self.uri}: cannot connect ({type(exc).__name__}: {exc})"
            ) from None
        try:
            self.server_metadata = msgpack_numpy.unpackb(ws.recv(timeout=self.connect_timeout))
        except TimeoutError:
            ws.close()
            raise PolicyTimeoutError(
                f"policy server {self.uri}: no metadata within {self.connect_timeout:g} s"
            ) from None
        except Exception as exc:
            ws.close()
            raise PolicyConnectionError(
                f"policy server {self.uri}: bad greeting ({type(exc).__name__}: {exc})"
            ) from None
        try:
            self._flags = {
                key: server_flag(self.server_metadata, key, f"policy server {self.uri}")
                for key in (FLAG_PREDICTS_FRAMES, FLAG_EPISODE_RESET)
            }
        except PolicyOutputError:
            ws.close()
            raise
        self._ws = ws

    def _drop(self) -> None:
        if self._ws is not None:
            with contextlib.suppress(Exception):  # already broken
                self._ws.close()
        self._ws = None

    @property
    def predicts_frames(self) -> bool:
        """Whether the server predicts frames, from its metadata (connects if needed)."""
        if self._ws is None:
            self._connect()
        return self._flags[FLAG_PREDICTS_FRAMES]

    def reset(self, episode: EpisodeInfo) -> None:
        self._prompt = episode.instruction
        if self._ws is None:
            self._connect()
        send = self._flags[FLAG_EPISODE_RESET] if self.episode_reset is None else self.episode_reset
        if send:
            reply = self.infer(reset_message(episode))
            if not isinstance(reply, dict):
                self._drop()
                raise PolicyOutputError(
                    f"policy server {self.uri}: reply to the episode reset is a {type(reply).__name__}, expected a dict"
                )

    def infer(self, request: dict) -> dict:
        from openpi_client import msgpack_numpy
        from websockets.exceptions import ConnectionClosed

        if self._ws is None:
            self._connect()
        assert self._ws is not None  # _connect sets it or raises
        try:
            self._ws.send(msgpack_numpy.packb(request))
            reply = self._ws.recv(timeout=self.infer_timeout)
        except TimeoutError:
            self._drop()
            raise PolicyTimeoutError(f"policy server {self.uri}: no reply within {self.infer_timeout:g} s") from None
        except (ConnectionClosed, OSError) as exc:
            self._drop()
            raise PolicyConnectionError(
                f"policy server {self.uri}: connection lost ({type(exc).__name__}: {exc})"
            ) from None
        if isinstance(reply, str):
            self._drop()
            raise PolicyOutputError(f"policy server {self.uri}: error reply: {reply.strip()[-500:]}")
        try:
            return msgpack_numpy.unpackb(reply)
        except Exception as exc:
            self._drop()
            raise PolicyOutputError(f"policy server {self.uri}: undecodable reply ({exc})") from None

    def act(self, obs: Observation) -> PolicyOutput:
        where = f"policy server {self.uri}"
        reply = self.infer(build_request(obs, self._prompt, self.resize))
        if not isinstance(reply, dict):
            raise PolicyOutputError(f"{where}: reply is a {type(reply).__name__}, expected a dict")
        out = as_output({"actions": reply["actions"]} if "actions" in reply else reply, where=where)
        if self.replan_steps and out.actions.shape[0] < self.replan_steps:
            raise PolicyOutputError(
                f"{where}: chunk of {out.actions.shape[0]} actions, "
                f"fewer than the {self.replan_steps} executed per request"
            )
        if not self._flags[FLAG_PREDICTS_FRAMES]:
            return out  # a server that does not declare predictions: any frames it sends are ignored
        shapes = {cam: np.shape(img) for cam, img in obs.images.items() if img is not None}
        frames = decode_predicted_frames(reply, shapes, self.resize, where)
        return PolicyOutput(out.actions, frames)

    def close(self) -> None:
        self._drop()
