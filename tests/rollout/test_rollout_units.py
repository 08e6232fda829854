"""Fast checks of the rollout layer's parts: policy specs, adapters, metrics, progress, gym env."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from vpro_assets.commands.eval_cmd import episode_outcome, outcome_summary
from vpro_assets.core.errors import VProError
from vpro_assets.report.metrics import Rate, drop, rate
from vpro_assets.rollout.policies.base import EpisodeInfo, Observation, PolicyOutputError, as_output
from vpro_assets.rollout.spec import make_policy, parse_openpi

EP = EpisodeInfo("pick it", "libero_goal-03/normal", 1, 7, "libero_goal", "libero_goal-03")


def _obs():
    return Observation(
        images={"agentview": None, "robot0_eye_in_hand": None},
        eef_pos=np.zeros(3),
        eef_quat=np.array([0, 0, 0, 1.0]),
        gripper_qpos=np.zeros(2),
        joint_pos=np.zeros(7),
        step=0,
    )


def shift_left(obs, episode):  # an in-process policy for the py: spec
    assert episode.instruction == "pick it"
    return {"actions": np.tile([-0.1, 0, 0, 0, 0, 0, -1.0], (3, 1))}


class Constant:
    replan_steps = 2

    def reset(self, episode):
        self.case = episode.case_id

    def act(self, obs):
        return np.zeros((4, 7))


def test_specs_build_each_kind_of_policy():
    assert make_policy("noop").act(_obs()).actions.shape == (5, 7)
    policy = make_policy("random")
    policy.reset(EP)
    first = policy.act(_obs()).actions
    policy.reset(EP)
    assert np.array_equal(first, policy.act(_obs()).actions)  # seeded by (case, trial)
    assert parse_openpi("openpi:127.0.0.1:8000") == ("127.0.0.1", 8000)
    assert parse_openpi("ws://localhost:9") == ("localhost", 9)
    assert make_policy("openpi:127.0.0.1:8000", {"replan_steps": 8}).replan_steps == 8
    fn = make_policy(f"py:{__name__}:shift_left")
    fn.reset(EP)
    assert fn.act(_obs()).actions[0, 0] == -0.1
    obj = make_policy(f"{__name__}:Constant")
    obj.reset(EP)
    assert obj.replan_steps == 2 and obj.act(_obs()).actions.shape == (4, 7)
    with pytest.raises(VProError, match="unknown policy"):
        make_policy("nonsense")
    with pytest.raises(VProError, match="has no attribute"):
        make_policy(f"py:{__name__}:missing")


def test_outputs_are_validated():
    assert as_output(np.zeros(7)).actions.shape == (1, 7)
    with pytest.raises(PolicyOutputError, match="no 'actions' key"):
        as_output({"action": np.zeros((2, 7))})
    with pytest.raises(PolicyOutputError, match=r"shape \(2, 8\)"):
        as_output(np.zeros((2, 8)))


def test_wilson_interval_and_drop():
    r = rate([{"status": "ok", "success": 1}] * 8 + [{"status": "ok", "success": 0}] * 2 + [{"status": "error"}])
    assert (r.successes, r.trials, r.errors) == (8, 10, 1) and r.sr == 80.0
    lo, hi = r.ci
    assert 49.0 < lo < 50.0 and 94.0 < hi < 95.0  # Wilson 95% for 8/10: [49.0, 94.3]
    assert Rate(0, 0).sr is None and Rate(0, 0).ci is None
    rows = [{"category": "normal", "task": "t", "status": "ok", "success": 1}] * 4 + [
        {"category": "x", "task": "t", "status": "ok", "success": s} for s in (1, 0, 0, 0)
    ]
    assert drop([r for r in rows if r["category"] == "x"], rows) == 75.0


def test_progress_postfix_counts_success_errors_and_unavailable():
    tally = Counter()
    for row in (
        {"status": "ok", "success": True},
        {"status": "ok", "success": False},
        {"status": "error"},
        {"status": "unavailable"},
    ):
        tally.update(episode_outcome(row))
    assert outcome_summary(tally) == "success 50.0% of 2, 1 error(s), 1 unavailable"
    assert outcome_summary(Counter()) == "success -"


def test_gym_env_runs_a_case(monkeypatch):
    import gymnasium as gym

    import vpro_assets.rollout.gym_env  # noqa: F401  (registers vpro/Case-v0)

    env = gym.make("vpro/Case-v0", case="libero_goal-03/normal", resolution=32, wait_steps=1, max_steps=2)
    obs, info = env.reset(options={"trial": 1})
    assert obs["agentview_image"].shape == (32, 32, 3) and obs["state"].shape == (8,)
    assert info["available_views"] == ["agentview", "robot0_eye_in_hand"] and info["trial"] == 1
    obs, reward, terminated, truncated, info = env.step(np.array([0, 0, 0, 0, 0, 0, -1.0]))
    assert (reward, terminated, truncated) == (0.0, False, False)
    *_, truncated, _ = env.step(np.array([0, 0, 0, 0, 0, 0, -1.0]))
    assert truncated
    env.close()


def test_unbuilt_scene_case_is_unavailable_not_a_crash(tmp_path, monkeypatch):
    from vpro_assets.benchmark.catalog import load_catalog
    from vpro_assets.core import paths
    from vpro_assets.rollout.case_env import CaseUnavailableError, check_available

    monkeypatch.setenv("VPRO_OUT", str(tmp_path))
    case = next(c for c in load_catalog(paths.catalog_path())["cases"] if c["level"] == "scene")
    with pytest.raises(CaseUnavailableError, match="not built; run vpro build"):
        check_available(case)


class ConstantPredictor:
    """Predicts a flat grey frame for each camera; records what it is shown."""

    predicts_frames = True
    replan_steps = None
    policy_id = "constant-predictor"

    def __init__(self):
        self.seen = []

    def reset(self, episode):
        self.seen.clear()

    def act(self, obs):
        self.seen.append({cam: None if img is None else img.copy() for cam, img in obs.images.items()})
        frames = {cam: np.full_like(img, 7) for cam, img in obs.images.items()}
        return {"actions": np.array([[0, 0, 0, 0, 0, 0, -1.0]]), "predicted_frames": frames}

    def close(self):
        pass


def test_prediction_reality_divergence_feeds_predicted_frames_back():
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.rollout.case_env import CaseUnavailableError
    from vpro_assets.rollout.episode import EpisodeSettings, run_episode
    from vpro_assets.rollout.policies.reference import NoopPolicy

    case = find_case(
        load_catalog(paths.catalog_path()),
        "libero_spatial-00/prediction_reality_divergence/recursive_self_prediction-v1",
    )
    settings = EpisodeSettings(resolution=32, wait_steps=1, max_steps_override=3)
    with pytest.raises(CaseUnavailableError, match="does not predict frames"):
        run_episode(case, 0, NoopPolicy(), settings)
    policy = ConstantPredictor()
    result = run_episode(case, 0, policy, settings)
    assert result["steps"] == 3 and len(policy.seen) == 3
    assert policy.seen[0]["agentview"].std() > 0  # ground truth at the start
    for later in policy.seen[1:]:  # then the model's own predictions
        assert all(np.all(img == 7) for img in later.values())


class CrashOnFirstTrial:
    """Kills its worker process in trial 0 (as a simulator segfault would)."""

    policy_id = "crasher"
    replan_steps = None

    def reset(self, episode):
        self.trial = episode.trial

    def act(self, obs):
        if self.trial == 0:
            import os

            os._exit(3)
        return np.zeros((1, 7))

    def close(self):
        pass


@pytest.mark.slow  # two worker start-ups: about a minute or two on 2 shared cores
def test_a_dying_worker_is_an_error_row_and_is_replaced(tmp_path):
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.rollout.episode import EpisodeSettings
    from vpro_assets.rollout.runner import run_eval
    from vpro_assets.rollout.store import ResultsStore

    case = find_case(load_catalog(paths.catalog_path()), "libero_goal-03/normal")
    summary = run_eval(
        [case],
        results=tmp_path / "r.sqlite",
        policy_spec=f"py:{__name__}:CrashOnFirstTrial",
        trials=2,
        backend="local",
        workers=1,
        retries=0,
        settings=EpisodeSettings(resolution=32, wait_steps=1, max_steps_override=2),
    )
    first, second = ResultsStore(tmp_path / "r.sqlite").episodes(summary.run_id)
    assert first["status"] == "error" and first["error_kind"] == "WorkerDied" and "exit code 3" in first["error"]
    assert second["status"] == "ok" and second["steps"] == 2
