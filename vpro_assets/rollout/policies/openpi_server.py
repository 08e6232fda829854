"""A minimal policy server speaking openpi's websocket protocol, for smoke tests of a harness.

Same wire format as openpi's `WebsocketPolicyServer`: on connection the server sends its metadata
(msgpack-numpy), then answers each packed observation dict with a packed dict holding `actions`;
on an exception it sends the traceback as a text frame and closes. `infer` is any function of the
observation dict; every request is kept in `requests` so a test can inspect what a client sent.

`faults` makes the server misbehave on its first N requests, for fault-injection tests:
`nan` (actions containing NaN), `shape` (actions of shape (H, 6)), `slow` (reply after `delay`
seconds), `error` (text error frame). It listens on loopback only.
"""
from __future__ import annotations

import logging
import threading
import time
from typing import Callable, Optional

import numpy as np

log = logging.getLogger(__name__)

FAULTS = ("nan", "shape", "slow", "error")


def noop_chunk(obs: dict, horizon: int = 10) -> dict:
    return {"actions": np.tile(np.array([0, 0, 0, 0, 0, 0, -1.0]), (horizon, 1))}


class LoopbackPolicyServer:
    def __init__(self, infer: Callable[[dict], dict] = noop_chunk, *, fault: Optional[str] = None,
                 fault_count: int = 0, delay: float = 2.0, metadata: Optional[dict] = None, host: str = "127.0.0.1"):
        if fault is not None and fault not in FAULTS:
            raise ValueError(f"fault must be one of {FAULTS}, got {fault!r}")
        if not host.startswith("127.") and host not in ("localhost", "::1"):
            raise ValueError(f"the loopback server listens on loopback addresses only, got {host!r}")
        self.infer, self.fault, self.fault_count, self.delay = infer, fault, fault_count, delay
        self.metadata = metadata or {"server": "vpro-loopback"}
        self.host = host
        self.requests: list[dict] = []
        self.connections = 0
        self._server = None
        self._thread = None
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

    def start(self) -> "LoopbackPolicyServer":
        from websockets.sync.server import serve

        self._server = serve(self._handle, self.host, 0, compression=None, max_size=None)
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._thread.join(timeout=5)
            self._server = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
