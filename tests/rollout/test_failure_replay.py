"""A failed trial's replay ends where the recorded trial did, with its pictures taken."""

from __future__ import annotations

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.failure_replay import replay
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy


def test_rendered_replay_ends_in_the_recorded_trials_final_state():
    """libero_spatial-06's trial 5 (one the oracle fails): the rendered replay's snapshots must not
    touch the physics. Its render context, once made mid-episode, sent the replay elsewhere (solved
    in 170 steps where the recorded trial ran out at 220)."""
    case = find_case(load_catalog(paths.catalog_path()), "libero_spatial-06/normal")
    recorded = run_episode(case, 5, OraclePolicy(), EpisodeSettings(render=False))
    again = replay(case, 5, EpisodeSettings(render=False), render=True, resolution=64)
    assert again.frames and again.frames[0].shape == (64, 64, 3)
    assert (again.final_state, again.steps, again.success) == (
        recorded["final_state"],
        recorded["steps"],
        bool(recorded["success"]),
    )
