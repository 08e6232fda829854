"""An in-process Python policy named `module:attribute`.

The attribute may be
- a class (or factory) whose instances have `reset(episode)` and `act(obs)` (the Policy protocol),
  constructed with no arguments in each worker; or
- a function `f(obs)` or `f(obs, episode)` returning actions ((H, 7) array, a dict with `actions`,
  or a PolicyOutput).
"""

from __future__ import annotations

import importlib
import inspect

from vpro_assets.core.errors import VProError
from vpro_assets.rollout.policies.base import EpisodeInfo, Observation, PolicyOutput, as_output


def load_attribute(target: str):
    module_name, _, attr = target.partition(":")
    if not module_name or not attr:
        raise VProError(f"python policy {target!r}: expected 'module:attribute'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise VProError(f"python policy {target!r}: cannot import {module_name!r} ({exc})") from None
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise VProError(f"python policy {target!r}: {module_name} has no attribute {attr!r}")
        obj = getattr(obj, part)
    return obj


class FunctionPolicy:
    """Wraps a plain function as a Policy."""

    replan_steps = None

    def __init__(self, fn, policy_id: str):
        self.fn, self.policy_id = fn, policy_id
        try:
            params = [
                p
                for p in inspect.signature(fn).parameters.values()
                if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
            ]
            self._wants_episode = len(params) >= 2
        except (TypeError, ValueError):
            self._wants_episode = False
        self._episode: EpisodeInfo | None = None

    def reset(self, episode: EpisodeInfo) -> None:
        self._episode = episode

    def act(self, obs: Observation) -> PolicyOutput:
        result = self.fn(obs, self._episode) if self._wants_episode else self.fn(obs)
        return as_output(result, where=f"python policy {self.policy_id}")

    def close(self) -> None:
        pass


class _Checked:
    """Validates the outputs of a protocol-following object."""

    def __init__(self, inner, policy_id: str):
        self.inner, self.policy_id = inner, getattr(inner, "policy_id", policy_id)
        self.replan_steps = getattr(inner, "replan_steps", None)
        self.predicts_frames = bool(getattr(inner, "predicts_frames", False))
        if hasattr(inner, "bind_env"):
            self.bind_env = inner.bind_env

    def reset(self, episode: EpisodeInfo) -> None:
        self.inner.reset(episode)

    def act(self, obs: Observation) -> PolicyOutput:
        return as_output(self.inner.act(obs), where=f"python policy {self.policy_id}")

    def close(self) -> None:
        if hasattr(self.inner, "close"):
            self.inner.close()


def make_python_policy(target: str):
    obj = load_attribute(target)
    if inspect.isclass(obj):
        return _Checked(obj(), target)
    if hasattr(obj, "act") and hasattr(obj, "reset"):
        return _Checked(obj, target)
    if callable(obj):
        return FunctionPolicy(obj, target)
    raise VProError(f"python policy {target!r} is neither a class, a policy object nor a function")
