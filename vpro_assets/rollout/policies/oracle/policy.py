"""`OraclePolicy`: the `oracle` of `vpro eval`, the plan's skills one action per call.

It receives the live environment through `bind_env` (the one policy allowed to see the simulator)
and never reads the observation's images. At the first action of an episode it plans from LIBERO's
parsed goal of the env and the current state; the skills' actions follow one per call. A skill that
fails (`SkillFailed`: a grasp slipped, a drawer did not move) is logged and the plan is made again
from the state then, up to `MAX_REPLANS` times; when nothing is left to do it holds still.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator

import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.libero.env import NOOP_ACTION
from vpro_assets.perturb.prediction import PolicyOutput
from vpro_assets.rollout.policies.oracle.plan import Step, plan
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

log = logging.getLogger(__name__)

MAX_REPLANS = 3


def libero_goal(env) -> list[tuple[str, ...]]:
    """LIBERO's parsed goal of a LIBERO env (OffScreenRenderEnv or ControlEnv)."""
    return [tuple(g) for g in env.env.parsed_problem["goal_state"]]


def libero_holds(env):
    """LIBERO's own predicate check, with the predicate name in any case."""
    problem = env.env

    def holds(pred: tuple[str, ...]) -> bool:
        return bool(problem._eval_predicate([pred[0].lower(), *pred[1:]]))

    return holds


class OracleController:
    """The oracle for one episode on one sim: plan, then the skills' actions in order."""

    def __init__(self, env, task):
        self.env = env
        self.holds = libero_holds(env)
        self.world = World(env.sim, task, self.holds)
        self.goal = libero_goal(env)
        self.replans = 0
        self.steps: list[Step] = []
        self.current: Step | None = None
        self.log: list[str] = []  # "plan: ...", "skill failed: ..." in order
        self._actions: Iterator[np.ndarray] | None = None
        self._replan()

    @property
    def sim(self):
        return self.env.sim

    def _replan(self) -> None:
        self.steps = plan(self.world, self.goal, self.holds)
        self.log.append("plan: " + ", ".join(map(str, self.steps)) if self.steps else "plan: nothing to do")
        log.debug("oracle %s", self.log[-1])

    def action(self) -> np.ndarray:
        self.world.step += 1
        while True:
            if self._actions is None:
                if not self.steps:
                    if self.replans < MAX_REPLANS and not all(self.holds(g) for g in self.goal):
                        self.replans += 1
                        self._replan()
                    if not self.steps:
                        return NOOP_ACTION.copy()
                self.current = self.steps.pop(0)
                self._actions = self.current.run(self.world)
            try:
                return np.asarray(next(self._actions), dtype=np.float64)
            except StopIteration:
                self._actions = None
            except SkillFailed as exc:
                self.log.append(f"skill failed: {self.current}: {exc}")
                log.debug("oracle %s", self.log[-1])
                self._actions = None
                self.steps = []

    @property
    def stage(self) -> str | None:
        return str(self.current) if self.current else None


class OraclePolicy:
    """The `oracle` reference policy (rollout policy protocol: reset, act, close, bind_env)."""

    policy_id = "oracle"
    replan_steps = 1
    uses_images = False  # acts from simulator state only; runs in render-free episodes
    reads_observations = False  # nor reads the observation: a render-free episode makes none (`act(None)`)

    def __init__(self, **_ignored):
        self._env = None
        self._controller: OracleController | None = None

    def bind_env(self, case_env) -> None:
        """Receive the live case environment (an object with `.env`, `.sim` and `.task`)."""
        self._env = case_env
        self._controller = None

    def reset(self, episode=None) -> None:
        self._controller = None

    def act(self, obs=None) -> PolicyOutput:
        return PolicyOutput(self.next_action()[None])

    def next_action(self) -> np.ndarray:
        if self._env is None:
            raise VProError("the oracle needs the live env: call bind_env(case_env) first")
        if self._controller is None or self._controller.sim is not self._env.sim:
            self._controller = OracleController(self._env.env, self._env.task)
        return self._controller.action()

    @property
    def controller(self) -> OracleController | None:
        return self._controller

    def close(self) -> None:
        self._env = None
        self._controller = None
