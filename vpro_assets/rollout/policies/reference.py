"""Reference policies: `noop` (holds still, gripper open) and `random` (seeded random motions).

They need no model and make every code path of the runner run; `random` draws from the stream
`seeding.rng(case_id, trial, "policy")`, so its episodes are reproducible on any backend.
`oracle` is the privileged oracle of `vpro_assets.rollout.policies.oracle` (every goal of the 40
tasks from simulator state); it receives the live environment through `bind_env` (the one policy
allowed to see it). None of them reads images, so all three run in render-free episodes.
"""

from __future__ import annotations

import logging

import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.core.seeding import rng
from vpro_assets.libero.env import NOOP_ACTION
from vpro_assets.rollout.policies.base import EpisodeInfo, Observation, PolicyOutput
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy

log = logging.getLogger(__name__)


class NoopPolicy:
    """LIBERO's no-op action at every step."""

    policy_id = "noop"
    replan_steps = None
    uses_images = False

    def __init__(self, chunk: int = 5):
        self.chunk = chunk

    def reset(self, episode: EpisodeInfo) -> None:
        pass

    def act(self, obs: Observation) -> PolicyOutput:
        return PolicyOutput(np.tile(NOOP_ACTION, (self.chunk, 1)))

    def close(self) -> None:
        pass


class RandomPolicy:
    """Uniform random end-effector motions (scaled), gripper open or closed at random per chunk."""

    policy_id = "random"
    replan_steps = None
    uses_images = False

    def __init__(self, chunk: int = 5, scale: float = 0.5):
        self.chunk, self.scale = chunk, scale
        self._rng: np.random.Generator | None = None

    def reset(self, episode: EpisodeInfo) -> None:
        self._rng = rng(episode.case_id, episode.trial, "policy")

    def act(self, obs: Observation) -> PolicyOutput:
        if self._rng is None:
            raise VProError("RandomPolicy.act called before reset")
        motion = self._rng.uniform(-self.scale, self.scale, size=(self.chunk, 6))
        gripper = np.full((self.chunk, 1), self._rng.choice([-1.0, 1.0]))
        return PolicyOutput(np.concatenate([motion, gripper], axis=1))

    def close(self) -> None:
        pass


REFERENCE_POLICIES = {"noop": NoopPolicy, "random": RandomPolicy, "oracle": OraclePolicy}
