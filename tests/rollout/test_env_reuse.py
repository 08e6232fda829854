"""A worker's env reused across the trials of a case (reset in place, render-free) gives the episodes
of fresh envs, bit for bit; an episode that raised leaves no env behind for the next trial."""

import numpy as np
import pytest

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.libero.settled import NOOP_ACTION
from vpro_assets.rollout import case_env
from vpro_assets.rollout.case_env import env_for_case, release_cached_envs
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.base import InfrastructureError
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy

# A kitchen scene: a cabinet and a stove placed by the trial's seed at every reset, the cabinet's
# drawer opened by the oracle (an articulation the next trial must find closed again); ~95 steps.
CASE = "libero_goal-00/normal"
RENDER_FREE = EpisodeSettings(render=False)


@pytest.fixture(scope="module")
def case():
    return find_case(load_catalog(paths.catalog_path()), CASE)


class RecordingOracle(OraclePolicy):
    """The oracle, keeping every action it sends."""

    def __init__(self):
        super().__init__()
        self.actions: list[np.ndarray] = []

    def act(self, obs=None):
        out = super().act(obs)
        self.actions.extend(np.array(a) for a in out.actions)
        return out


def _episode(case, trial: int, fresh: bool) -> tuple[dict, np.ndarray]:
    if fresh:
        release_cached_envs()
    policy = RecordingOracle()
    row = run_episode(case, trial, policy, RENDER_FREE)
    return row, np.array(policy.actions)


def _arrays(obj) -> dict[str, np.ndarray]:
    return {n: getattr(obj, n).copy() for n in dir(obj) if isinstance(getattr(obj, n, None), np.ndarray)}


def test_trials_on_one_reused_env_end_as_on_fresh_envs(case):
    release_cached_envs()
    try:
        reused = []
        for trial in (0, 1):
            row, actions = _episode(case, trial, fresh=False)
            reused.append((row, actions))
            assert case_env._ENV_CACHE, "the render-free env is kept for the next trial"
        for trial, (row, actions) in zip((0, 1), reused):
            fresh_row, fresh_actions = _episode(case, trial, fresh=True)
            assert fresh_row["success"], f"trial {trial}: the oracle opens the drawer"
            assert (row["success"], row["steps"]) == (fresh_row["success"], fresh_row["steps"])
            np.testing.assert_array_equal(actions, fresh_actions)
            assert row["final_state"] == fresh_row["final_state"]
    finally:
        release_cached_envs()


@pytest.mark.parametrize("case_id", [CASE, "libero_10-03/normal"])  # 10-03: a closed drawer's sampler draws
def test_an_in_place_reset_starts_as_a_fresh_env(case_id):
    """Every model array, the state and the random stream after an in-place reset equal a fresh
    env's, after an episode moved the arm and the objects about on the reused env."""
    case = find_case(load_catalog(paths.catalog_path()), case_id)
    release_cached_envs()
    try:
        first = env_for_case(case, 0, render=False)
        first.reset()
        for _ in range(40):
            first.step(np.array([0.6, 0.4, -0.6, 0.1, 0, 0, 1.0]), observe=False)
        first.close()
        reused = env_for_case(case, 3, render=False)
        assert reused.reset_in_place
        reused.reset()
        model, stream = _arrays(reused.sim.model._model), np.random.get_state()[1].copy()
        state = reused.env.get_sim_state().copy()
        reused.close()
    finally:
        release_cached_envs()
    fresh = env_for_case(case, 3, render=False, reuse=False)
    assert not fresh.reset_in_place
    try:
        fresh.reset()
        fresh_model = _arrays(fresh.sim.model._model)
        assert sorted(fresh_model) == sorted(model)
        assert [n for n in model if not np.array_equal(model[n], fresh_model[n], equal_nan=True)] == []
        np.testing.assert_array_equal(np.random.get_state()[1], stream)
        np.testing.assert_array_equal(fresh.env.get_sim_state(), state)
    finally:
        fresh.env.close()


class _Raises(OraclePolicy):
    def act(self, obs=None):
        raise RuntimeError("a policy bug")


def test_an_episode_that_raised_leaves_no_env_for_the_next(case):
    release_cached_envs()
    try:
        with pytest.raises(InfrastructureError):
            run_episode(case, 0, _Raises(), RENDER_FREE)
        assert not case_env._ENV_CACHE
        nxt = env_for_case(case, 1, render=False)
        assert not nxt.reset_in_place  # built anew
        nxt.reset()
        nxt.step(NOOP_ACTION, observe=False)
        nxt.close()
    finally:
        release_cached_envs()
