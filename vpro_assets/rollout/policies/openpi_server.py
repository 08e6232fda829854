"""A minimal policy server speaking openpi's websocket protocol, for smoke tests of a harness.

Same wire format as openpi's `WebsocketPolicyServer`: on connection the server sends its metadata
(msgpack-numpy), then answers each packed observation dict with a packed dict holding `actions`;
on an exception it sends the traceback as a text frame and closes. `infer` is any function of the
observation dict; every request is kept in `requests` so a test can inspect what a client sent.

`faults` makes the server misbehave on its first N requests, for fault-injection tests:
`nan` (actions containing NaN), `shape` (actions of shape (H, 6)), `slow` (reply after `delay`
seconds), `error` (text error frame). It listens on loopback only.

`EchoWorldModel` is the `infer` of a loopback world-action model speaking the extension of
`vpro_assets.rollout.policies.wam` (pass it with its `metadata`): it keeps per-episode state and
predicts frames, with its own faults for the frames it returns.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

FAULTS = ("nan", "shape", "slow", "error")
FRAME_FAULTS = ("missing_frames", "frame_shape", "frame_dtype")
REQUEST_IMAGES = {"agentview": "observation/image", "robot0_eye_in_hand": "observation/wrist_image"}


def noop_chunk(obs: dict, horizon: int = 10) -> dict:
    return {"actions": np.tile(np.array([0, 0, 0, 0, 0, 0, -1.0]), (horizon, 1))}


class LoopbackPolicyServer:
    def __init__(
        self,
        infer: Callable[[dict], dict] = noop_chunk,
        *,
        fault: str | None = None,
        fault_count: int = 0,
        delay: float = 2.0,
        metadata: dict | None = None,
        host: str = "127.0.0.1",
    ):
        if fault is not None and fault not in FAULTS:
            raise ValueError(f"fault must be one of {FAULTS}, got {fault!r}")
        if not host.startswith("127.") and host not in ("localhost", "::1"):
            raise ValueError(f"the loopback server listens on loopback addresses only, got {host!r}")
        self.infer, self.fault, self.fault_count, self.delay = infer, fault, fault_count, delay
        self.metadata = metadata or {"server": "vpro-loopback"}
        self.host = host
        self.requests: list[dict] = []
        self.connections = 0
        self._server: Any = None  # websockets' sync Server once started
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    @property
    def port(self) -> int:
        return self._server.socket.getsockname()[1]

    def _handle(self, ws) -> None:
        from openpi_client import msgpack_numpy

        with self._lock:
            self.connections += 1
        ws.send(msgpack_numpy.packb(self.metadata))
        while True:
            try:
                message = ws.recv()
            except Exception:
                return
            obs = msgpack_numpy.unpackb(message)
            with self._lock:
                self.requests.append(obs)
                faulty = self.fault is not None and len(self.requests) <= self.fault_count
            try:
                reply = dict(self.infer(obs))
                if faulty and self.fault == "nan":
                    reply["actions"] = np.array(reply["actions"], dtype=np.float64)
                    reply["actions"][0, 2] = np.nan
                elif faulty and self.fault == "shape":
                    reply["actions"] = np.asarray(reply["actions"])[:, :6]
                elif faulty and self.fault == "slow":
                    time.sleep(self.delay)
                elif faulty and self.fault == "error":
                    raise RuntimeError("injected server failure")
                ws.send(msgpack_numpy.packb(reply))
            except Exception as exc:
                try:
                    ws.send(f"Traceback (most recent call last): {type(exc).__name__}: {exc}")
                    ws.close()
                except Exception:
                    pass
                return

    def start(self) -> LoopbackPolicyServer:
        from websockets.sync.server import serve

        self._server = server = serve(self._handle, self.host, 0, compression=None, max_size=None)
        self._thread = thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        return self

    def stop(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            if self._thread is not None:
                self._thread.join(timeout=5)
            self._server = self._thread = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()


class EchoWorldModel:
    """A stateful, frame-predicting model for the loopback server.

    - A reset message (`{"reset": True, "prompt": ..., "episode": {...}}`) starts an episode: the
      history is cleared and the prompt and episode kept (`episodes` lists them). An observation
      before any reset, or with another prompt than the reset's, is answered with an error.
    - Each observation is appended to the episode's `history`; the reply holds `horizon` no-op
      actions and, for every camera of the request, one predicted frame in the request's size: a
      uniform frame of value `10 * n` (n = observations so far in this episode, mod 256) with a
      white `MARK` x `MARK` block in its top-left corner as the request image shows it (upright),
      sent in `orientation` (`rot180`: as the request; `raw`; `flipud`).
    `fault` in FRAME_FAULTS spoils the frames of the first `fault_count` observation replies:
    no `predicted_frames`, frames one pixel short, float32 frames.
    """

    MARK = 24

    def __init__(self, orientation: str = "rot180", horizon: int = 10, fault: str | None = None, fault_count: int = 0):
        if orientation not in ("rot180", "raw", "flipud"):
            raise ValueError(f"orientation must be rot180, raw or flipud, got {orientation!r}")
        if fault is not None and fault not in FRAME_FAULTS:
            raise ValueError(f"fault must be one of {FRAME_FAULTS}, got {fault!r}")
        self.orientation, self.horizon, self.fault, self.fault_count = orientation, horizon, fault, fault_count
        self.metadata = {"server": "vpro-loopback-wam", "predicts_frames": True, "episode_reset": True}
        self.episodes: list[dict] = []
        self.history: list[dict] = []
        self.prompt: str | None = None
        self.observations = 0
        self._lock = threading.Lock()

    @classmethod
    def frame(cls, n: int, size: int) -> np.ndarray:
        """The prediction for the n-th observation of an episode, upright as the request shows it."""
        img = np.full((size, size, 3), (10 * n) % 256, np.uint8)
        img[: cls.MARK, : cls.MARK] = 255
        return img

    def __call__(self, message: dict) -> dict:
        with self._lock:
            if message.get("reset"):
                self.prompt = str(message.get("prompt"))
                self.episodes.append({"prompt": self.prompt, "episode": message.get("episode")})
                self.history = []
                return {}
            if self.prompt is None:
                raise RuntimeError("observation before any episode reset")
            if message.get("prompt") != self.prompt:
                raise RuntimeError(f"prompt {message.get('prompt')!r} differs from the episode's {self.prompt!r}")
            self.history.append(message)
            self.observations += 1
            n = len(self.history)
            faulty = self.fault is not None and self.observations <= self.fault_count
        frames = {}
        for cam, key in REQUEST_IMAGES.items():
            if key not in message:
                continue
            upright = self.frame(n, np.shape(message[key])[0])
            frames[cam] = {"rot180": upright, "raw": upright[::-1, ::-1], "flipud": upright[:, ::-1]}[self.orientation]
        reply = {
            "actions": np.tile(np.array([0, 0, 0, 0, 0, 0, -1.0]), (self.horizon, 1)),
            "predicted_frames": frames,
            "predicted_frames_orientation": self.orientation,
        }
        if faulty and self.fault == "missing_frames":
            del reply["predicted_frames"]
        elif faulty and self.fault == "frame_shape":
            reply["predicted_frames"] = {cam: f[:-1] for cam, f in frames.items()}
        elif faulty and self.fault == "frame_dtype":
            reply["predicted_frames"] = {cam: f.astype(np.float32) / 255 for cam, f in frames.items()}
        return reply
