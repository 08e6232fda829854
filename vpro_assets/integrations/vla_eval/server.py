"""`ScriptedModelServer`: a vla-eval model server without a model, on vla-eval's own base class.

It answers every observation with the next action of a fixed sequence (LIBERO's no-op by default,
or the rows of an `.npy` file, replayed from the first row at each episode start, the no-op once
the file is exhausted). For smoke runs and tests of the harness:

    python -m vpro_assets.integrations.vla_eval.server --port 8000
    python -m vpro_assets.integrations.vla_eval.server --port 8000 --args.actions actions.npy

`record_dir` keeps what the server received, one `.npz` per episode (images per camera, states,
task description), named after the case and trial, written atomically when the episode ends.
`disconnect_episode` / `disconnect_step` drop the connection at that step of the n-th episode the
server sees (counted from 0 over the server's life): a server that dies mid-episode.
"""

from __future__ import annotations

import io
import logging
import threading
from pathlib import Path
from typing import Any

import numpy as np

from vpro_assets.core.atomic import write_bytes_atomic
from vpro_assets.integrations.vla_eval import require_vla_eval
from vpro_assets.libero.env import NOOP_ACTION

require_vla_eval()

import websockets  # noqa: E402
from vla_eval.model_servers.base import SessionContext  # noqa: E402
from vla_eval.model_servers.predict import PredictModelServer  # noqa: E402
from vla_eval.model_servers.serve import run_server  # noqa: E402
from vla_eval.specs import GRIPPER_CLOSE_POS, IMAGE_RGB, LANGUAGE, POSITION_DELTA, ROTATION_AA, DimSpec  # noqa: E402
from vla_eval.types import Action, Observation  # noqa: E402

log = logging.getLogger(__name__)


class ScriptedModelServer(PredictModelServer):
    def __init__(
        self,
        actions: str | None = None,
        record_dir: str | None = None,
        disconnect_episode: int = -1,
        disconnect_step: int = 0,
        send_wrist_image: bool = True,
        send_state: bool = True,
    ) -> None:
        super().__init__()
        self.actions = np.load(actions).astype(np.float32) if actions else np.zeros((0, 7), np.float32)
        if self.actions.ndim != 2 or self.actions.shape[1] != 7:
            raise ValueError(f"{actions}: expected an (N, 7) action array, got shape {self.actions.shape}")
        self.record_dir = Path(record_dir) if record_dir else None
        self.disconnect_episode, self.disconnect_step = disconnect_episode, disconnect_step
        self.send_wrist_image, self.send_state = send_wrist_image, send_state
        self._lock = threading.Lock()
        self._episodes_seen = 0
        self._episode: dict[str, dict[str, Any]] = {}  # session id -> {index, task, frames}

    def get_observation_params(self) -> dict[str, Any]:
        return {"send_wrist_image": self.send_wrist_image, "send_state": self.send_state}

    def get_action_spec(self) -> dict[str, DimSpec]:
        return {"position": POSITION_DELTA, "rotation": ROTATION_AA, "gripper": GRIPPER_CLOSE_POS}

    def get_observation_spec(self) -> dict[str, DimSpec]:
        return {"agentview": IMAGE_RGB, "language": LANGUAGE}

    async def on_episode_start(self, config: dict[str, Any], ctx: SessionContext) -> None:
        with self._lock:
            index = self._episodes_seen
            self._episodes_seen += 1
        self._episode[ctx.session_id] = {"index": index, "task": dict(config.get("task") or {}), "obs": []}
        await super().on_episode_start(config, ctx)

    async def on_observation(self, obs: Observation, ctx: SessionContext) -> None:
        episode = self._episode.get(ctx.session_id, {})
        if episode.get("index") == self.disconnect_episode and ctx.step == self.disconnect_step:
            log.info("dropping the connection at episode %d step %d", self.disconnect_episode, ctx.step)
            raise websockets.exceptions.ConnectionClosed(None, None)
        await super().on_observation(obs, ctx)

    def predict(self, obs: Observation, ctx: SessionContext) -> Action:
        episode = self._episode.get(ctx.session_id)
        if episode is not None and self.record_dir is not None:
            episode["obs"].append(
                {
                    "images": {k: np.asarray(v) for k, v in (obs.get("images") or {}).items()},
                    "states": None if obs.get("states") is None else np.asarray(obs["states"]),
                    "task_description": obs.get("task_description", ""),
                }
            )
        row = self.actions[ctx.step] if ctx.step < len(self.actions) else np.asarray(NOOP_ACTION, np.float32)
        return {"actions": np.asarray(row, dtype=np.float32)}

    async def on_episode_end(self, result: dict[str, Any], ctx: SessionContext) -> None:
        episode = self._episode.pop(ctx.session_id, None)
        if episode is not None and self.record_dir is not None and episode["obs"] and result:
            self._write(episode)
        await super().on_episode_end(result, ctx)

    def _write(self, episode: dict[str, Any]) -> None:
        if self.record_dir is None:
            return
        task, frames = episode["task"], episode["obs"]
        arrays: dict[str, np.ndarray] = {}
        for cam in frames[0]["images"]:
            arrays[f"image_{cam}"] = np.stack([f["images"][cam] for f in frames])
        if frames[0]["states"] is not None:
            arrays["states"] = np.stack([f["states"] for f in frames])
        arrays["task_description"] = np.asarray(frames[0]["task_description"])
        name = f"{str(task.get('case_id', 'task')).replace('/', '__')}__t{task.get('episode_idx', 0)}.npz"
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        write_bytes_atomic(self.record_dir / name, buf.getvalue())


if __name__ == "__main__":
    run_server(ScriptedModelServer)
