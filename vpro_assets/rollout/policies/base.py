"""The policy protocol every adapter implements, and the errors that are not the policy's fault.

An episode talks to a policy in two calls:

    policy.reset(EpisodeInfo(...))            # once per episode: instruction, case, trial, seed
    out = policy.act(Observation(...))         # whenever the runner needs new actions
    out.actions                                # (H, 7) float array, executed in order

The runner executes at most `policy.replan_steps` actions of a chunk (all of it when None) before
asking again, as openpi's LIBERO example does with its action plan.

Images reach adapters in LIBERO's raw frame (bottom-up, OpenGL convention), one entry per camera
(`agentview`, `robot0_eye_in_hand`). A view that is unavailable (View Unavailability with
`single_view`) is `None`: adapters decide how their model handles a missing view (the openpi
adapter sends a black image, as the model's own image mask would not reach the server). Constant and
duplicate replacements arrive as ordinary images, made by the perturbation layer.

A policy may also return predicted frames (world-action models); the runner passes them back to the
perturbation layer for Prediction-Reality Divergence. Such a policy says so with an attribute
`predicts_frames = True` (the openpi adapter reads it from the server's metadata, see
`vpro_assets.rollout.policies.wam`); Prediction-Reality Divergence cases are unavailable to other
policies.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.libero.env import CAMERAS
from vpro_assets.perturb.prediction import PolicyOutput

ACTION_DIM = 7


class InfrastructureError(VProError):
    """Something outside the policy's decisions failed: server down or slow, malformed reply,
    simulator exception. Recorded as an error and retried, never counted as a policy failure."""


class PolicyConnectionError(InfrastructureError):
    """The policy server refused the connection or went away."""


class PolicyTimeoutError(InfrastructureError):
    """The policy server did not answer in time."""


class PolicyOutputError(InfrastructureError):
    """The policy answered with something that is not a chunk of finite 7-D actions."""


class SimulatorError(InfrastructureError):
    """The simulator raised while building, resetting or stepping."""


@dataclass(frozen=True)
class EpisodeInfo:
    instruction: str
    case_id: str
    trial: int
    seed: int
    suite: str
    task: str


@dataclass
class Observation:
    """What the policy sees at one step, after any observation perturbation."""

    images: Mapping[str, np.ndarray | None]  # camera -> HxWx3 uint8, bottom-up; None if unavailable
    eef_pos: np.ndarray  # (3,)
    eef_quat: np.ndarray  # (4,) x, y, z, w
    gripper_qpos: np.ndarray  # (2,)
    joint_pos: np.ndarray  # (7,)
    step: int  # control step of the episode, wait steps included
    instruction: str = ""

    @classmethod
    def from_libero(cls, obs: Mapping, step: int, instruction: str, images: Mapping | None = None) -> Observation:

        imgs = images if images is not None else {cam: obs.get(f"{cam}_image") for cam in CAMERAS}
        return cls(
            images=dict(imgs),
            eef_pos=np.asarray(obs["robot0_eef_pos"], dtype=np.float64),
            eef_quat=np.asarray(obs["robot0_eef_quat"], dtype=np.float64),
            gripper_qpos=np.asarray(obs["robot0_gripper_qpos"], dtype=np.float64),
            joint_pos=np.asarray(obs["robot0_joint_pos"], dtype=np.float64),
            step=step,
            instruction=instruction,
        )


@runtime_checkable
class Policy(Protocol):
    policy_id: str
    replan_steps: int | None

    def reset(self, episode: EpisodeInfo) -> None: ...

    def act(self, obs: Observation) -> PolicyOutput: ...

    def close(self) -> None: ...


def validate_actions(actions, where: str = "policy") -> np.ndarray:
    """A (H, 7) float64 chunk of finite actions, or PolicyOutputError naming what is wrong."""
    try:
        arr = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise PolicyOutputError(f"{where}: actions are not numeric ({exc})") from None
    if arr.ndim == 1 and arr.shape[0] == ACTION_DIM:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != ACTION_DIM or arr.shape[0] < 1:
        raise PolicyOutputError(
            f"{where}: expected actions of shape (H, {ACTION_DIM}) with H >= 1, got shape {arr.shape}"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        raise PolicyOutputError(
            f"{where}: non-finite action value {arr[row, col]!r} at chunk index {row}, "
            f"dimension {col} ({int(bad.sum())} non-finite values)"
        )
    return arr


def as_output(result, where: str = "policy") -> PolicyOutput:
    """Accept a PolicyOutput, a dict with 'actions' (and optional 'predicted_frames'), or an array."""
    if isinstance(result, PolicyOutput):
        return PolicyOutput(validate_actions(result.actions, where), result.predicted_frames, dict(result.info))
    if hasattr(result, "actions") and not isinstance(result, np.ndarray):  # a user's own record with .actions
        return PolicyOutput(validate_actions(result.actions, where), getattr(result, "predicted_frames", None))
    if isinstance(result, Mapping):
        if "actions" not in result:
            raise PolicyOutputError(f"{where}: reply has no 'actions' key (keys: {sorted(map(str, result))})")
        return PolicyOutput(validate_actions(result["actions"], where), result.get("predicted_frames"))
    return PolicyOutput(validate_actions(result, where))
