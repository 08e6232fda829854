"""Prediction-Reality Divergence and the policy-side protocol for predicted frames.

A frame-predicting policy (a world-action model) returns, with its actions, the frames it expects
the cameras to show next (`PolicyOutput.predicted_frames`: camera -> raw, bottom-up uint8 frame of
the camera's shape; an adapter that flips or resizes must map predictions back to that form).
The harness passes them to `PerturbedEnv.step(action, predicted_frames=...)` (or the pipeline's
`observe`). Under this setting the policy sees the rendered frames only at the first observation
(`ground_truth_steps`); afterwards each camera shows the latest frame predicted for it, and the
last shown frame again when no new prediction came. Under every other setting predicted frames
are ignored.

`FramePredictingPolicy` is the protocol; `EchoPredictor` is a test policy: it wraps any action
function and predicts, for every camera, the frame it observed with a step counter stamped into
its first row, so a test can tell which prediction an observation came from.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.perturb.base import Episode, Perturbation, Step, param


@dataclass(frozen=True)
class PolicyOutput:
    """What one policy call returns (the one type the perturbation layer and the rollout layer
    share): actions (7 floats, or a chunk of them, one row per step), optionally predicted frames
    per camera (raw orientation, same shape as the camera's image; or (H', h, w, 3) for a chunk)
    and whatever the policy wants logged (`info`)."""

    actions: np.ndarray
    predicted_frames: Mapping[str, np.ndarray] | None = None
    info: Mapping = field(default_factory=dict)


@runtime_checkable
class FramePredictingPolicy(Protocol):
    def reset(self) -> None: ...

    def __call__(self, obs: Mapping[str, np.ndarray]) -> PolicyOutput: ...


def validate_predictions(
    case_id: str, predicted: Mapping[str, np.ndarray] | None, clean: Mapping[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Predicted frames checked against the cameras' frames (known camera, same shape, uint8)."""
    out = {}
    for cam, frame in (predicted or {}).items():
        if cam not in clean:
            raise InvalidParameterError(
                f"case {case_id}: predicted frame for unknown camera {cam!r}; cameras are {', '.join(clean)}"
            )
        frame = np.asarray(frame)
        if frame.shape != clean[cam].shape or frame.dtype != np.uint8:
            raise InvalidParameterError(
                f"case {case_id}: predicted frame for {cam} has shape {frame.shape} and "
                f"dtype {frame.dtype}; expected {clean[cam].shape} uint8 (raw, bottom-up)"
            )
        out[cam] = frame
    return out


class PredictionFeedback(Perturbation):
    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.ground_truth_steps = param(case_id, params, "ground_truth_steps", int, lambda v: v >= 1)
        self.shown: dict[str, np.ndarray] = {}

    def reset(self, episode: Episode) -> None:
        self.shown = {}

    def apply(self, frames, step: Step) -> None:
        predicted = validate_predictions(self.case_id, step.predicted, step.clean)
        for cam in list(frames):
            if step.index < self.ground_truth_steps:
                self.shown[cam] = frames[cam]
                continue
            if cam in predicted:
                self.shown[cam] = predicted[cam].copy()
                step.note(cam, "predicted frame")
            else:
                step.note(cam, "last shown frame (no new prediction)")
            frames[cam] = self.shown[cam]


def stamp(frame: np.ndarray, value: int) -> np.ndarray:
    """A copy of `frame` whose first row carries `value` (mod 256) in every pixel."""
    out = frame.copy()
    out[0] = value % 256
    return out


class EchoPredictor:
    """A frame-predicting test policy: actions from `act(obs)`, predictions = the observed frames
    stamped with the call counter (see `stamp`)."""

    def __init__(self, act: Callable[[Mapping[str, np.ndarray]], np.ndarray], cameras: tuple[str, ...]):
        self.act, self.cameras, self.calls = act, cameras, 0

    def reset(self) -> None:
        self.calls = 0

    def __call__(self, obs: Mapping[str, np.ndarray]) -> PolicyOutput:
        self.calls += 1
        frames = {cam: stamp(obs[f"{cam}_image"], self.calls) for cam in self.cameras if f"{cam}_image" in obs}
        return PolicyOutput(np.asarray(self.act(obs), dtype=np.float64), frames)
