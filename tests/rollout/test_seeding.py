"""Frames are a function of (case, trial): LIBERO's fixture placement is seeded per trial."""

import numpy as np

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.rollout.case_env import env_for_case, release_cached_envs


def _first_frame(case, trial):
    case_env = env_for_case(case, trial, resolution=64)
    try:
        return case_env.reset()["agentview_image"].copy()
    finally:
        release_cached_envs()
        case_env.env.close()


def test_same_trial_same_scene_other_trial_other_scene():
    case = find_case(load_catalog(paths.catalog_path()), "libero_goal-03/normal")
    first = _first_frame(case, 0)
    np.random.random(100)  # draws from the global stream in between (as other code in a worker would)
    again = _first_frame(case, 0)
    other = _first_frame(case, 1)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)
