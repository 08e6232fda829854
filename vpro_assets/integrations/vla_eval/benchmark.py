"""`LiberoVProBenchmark`: LIBERO-VPro cases as tasks of vla-eval, the evaluation harness.

In a vla-eval config (`vla-eval run --no-docker -c CONFIG`) the one line that changes from a LIBERO
evaluation is the benchmark's import string:

    benchmarks:
      - benchmark: "vpro_assets.integrations.vla_eval.benchmark:LiberoVProBenchmark"
        episodes_per_task: 10            # the case's trials 0..9
        params: {select: [camera_staleness, normal]}

Tasks are catalog cases, chosen with the filters of `vpro eval --select` (case, setting, category,
dimension, suite, task, `normal`); episode k of a task is trial k of the case. An episode is
`vpro eval`'s own (`vpro_assets.rollout.episode.EpisodeSession`): the case's env (LIBERO's for
Normal and observation cases, the built scene for scene cases), the trial's initial-state row and
seed, the wait steps, the per-suite step limit, LIBERO's success check, the case's observation
perturbations in the loop. What a model server receives follows vla-eval's own LIBERO benchmark,
whose `make_obs` this class inherits: images under `images/agentview` (and `images/wrist` with
`send_wrist_image`), flipped upright on both axes, uint8, `states` = eef position, eef axis-angle,
gripper joints (with `send_state`), `task_description` = LIBERO's instruction. The images are the
views after the case's perturbation; a view the case removes arrives black. Actions follow
vla-eval's LIBERO: one 7-D action per step, gripper discretised to -1/+1 by its sign.

Every episode result (`metrics` in vla-eval's recording) carries the case id, trial, seed, suite,
task, dimension, category, setting, indicator and level, plus `vpro eval`'s row fields (steps,
phase timeline, contact composition, artifact hashes, final-state digest), so `vpro report` reads
a vla-eval results directory (`vpro_assets.report.vla_eval_results`).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.integrations.vla_eval import require_vla_eval

require_vla_eval()

from vla_eval.benchmarks.base import StepResult  # noqa: E402
from vla_eval.benchmarks.libero.benchmark import LIBEROBenchmark  # noqa: E402
from vla_eval.protocol.numpy_codec import set_image_format  # noqa: E402
from vla_eval.types import Action, EpisodeResult, Observation, Task  # noqa: E402

from vpro_assets.benchmark.catalog import library_versions, load_catalog  # noqa: E402
from vpro_assets.benchmark.selection import select_cases  # noqa: E402
from vpro_assets.core import paths  # noqa: E402
from vpro_assets.libero.env import CAMERAS  # noqa: E402
from vpro_assets.rollout.case_env import CaseEnv, CaseUnavailableError, check_available, release_cached_envs  # noqa: E402
from vpro_assets.rollout.episode import WAIT_STEPS, EpisodeSession, EpisodeSettings, prompt_of  # noqa: E402
from vpro_assets.rollout.policies.base import PolicyOutputError, validate_actions  # noqa: E402

log = logging.getLogger(__name__)

BENCHMARK = "vpro_assets.integrations.vla_eval.benchmark:LiberoVProBenchmark"
# vla-eval's LIBERO names for LIBERO's two cameras
WIRE_FORMATS = ("png", "raw")  # vla-eval's lossless image encodings (its third, jpeg, changes the pixels)
IMAGE_KEYS = {"agentview": "agentview_image", "robot0_eye_in_hand": "robot0_eye_in_hand_image"}


class BenchmarkConfigError(VProError, SystemExit):
    """A bad `params` entry of the config: one line, no traceback (vla-eval does not catch errors
    raised while it builds the benchmark, so this exits the run with the message)."""

    def __init__(self, message: str):
        VProError.__init__(self, message)
        SystemExit.__init__(self, f"LIBERO-VPro: {message}")
        self.code = f"LIBERO-VPro: {message}"

    def __str__(self) -> str:
        return str(self.code)


def case_labels(case: dict) -> dict[str, Any]:
    """The labels of a case that results are broken down by (the same as `vpro eval`'s rows)."""
    normal = not case.get("setting")
    labels = {
        "case_id": case["id"],
        "suite": case["suite"],
        "task": case["task"],
        "category": "normal" if normal else case["category"],
        "level": "normal" if normal else case["level"],
    }
    if not normal:
        labels.update(setting=case["setting"], dimension=case["dimension"], indicator=case["indicator"])
    return labels


def _filters(select: str | Sequence[str] | None) -> list[str]:
    if select is None:
        return []
    if isinstance(select, str):
        return [select]
    if not all(isinstance(f, str) for f in select):
        raise BenchmarkConfigError(f"params.select must be a filter or a list of filters, got {select!r}")
    return list(select)


class LiberoVProBenchmark(LIBEROBenchmark):
    """LIBERO-VPro for vla-eval (see the module docstring).

    Args:
        select: `--select` filters (a string or a list); none = every perturbed case (not Normal).
        catalog: catalog file (default: the toolkit's committed catalog, `VPRO_CATALOG`).
        num_steps_wait: no-op steps before the first observation (LIBERO's 10).
        max_steps: one step limit for every suite (default: 220 / 280 / 300 / 520 per suite).
        resolution: camera resolution (256, as vla-eval's LIBERO renders).
        send_wrist_image, send_state, quat_no_antipodal, absolute_action: as in vla-eval's LIBERO
            (model servers set them through their observation params).
        predicts_frames: the model server returns `predicted_frames` with its actions (world-action
            models); Prediction-Reality Divergence cases run only then, else their episodes are
            recorded as unavailable, as `vpro eval` does.
        image_format: how images travel to the server: `raw` (default: unencoded, 390 kB per
            step) or `png` (vla-eval's own default: 2.5x smaller, but about 33 ms of CPU per step
            to encode both views, 12% on top of an episode; for a server across a slow link). Both
            are lossless: the server decodes the same pixels. vla-eval's codec is process-wide, so
            the choice also applies to other benchmark entries of the same run.
    """

    def __init__(
        self,
        select: str | list[str] | None = None,
        catalog: str | None = None,
        num_steps_wait: int = WAIT_STEPS,
        max_steps: int | None = None,
        resolution: int = 256,
        send_wrist_image: bool = False,
        send_state: bool = False,
        quat_no_antipodal: bool = False,
        absolute_action: bool = False,
        predicts_frames: bool = False,
        image_format: str = "raw",
    ) -> None:
        super().__init__(
            suite="libero_vpro",
            seed=0,
            num_steps_wait=num_steps_wait,
            send_wrist_image=send_wrist_image,
            send_state=send_state,
            absolute_action=absolute_action,
            max_steps=max_steps,
            quat_no_antipodal=quat_no_antipodal,
        )
        if max_steps is not None and (not isinstance(max_steps, int) or max_steps < 1):
            raise BenchmarkConfigError(f"params.max_steps must be a positive integer, got {max_steps!r}")
        if not isinstance(num_steps_wait, int) or num_steps_wait < 0:
            raise BenchmarkConfigError(f"params.num_steps_wait must be an integer >= 0, got {num_steps_wait!r}")
        self.settings = EpisodeSettings(resolution=resolution, wait_steps=num_steps_wait, max_steps_override=max_steps)
        self.predicts_frames = bool(predicts_frames)
        if image_format not in WIRE_FORMATS:
            raise BenchmarkConfigError(
                f"params.image_format must be one of {', '.join(WIRE_FORMATS)} (lossless), got {image_format!r}"
            )
        set_image_format(image_format)  # vla-eval's codec of this process (the harness side)
        self.filters = _filters(select)
        try:
            self.catalog = load_catalog(paths.catalog_path() if catalog is None else Path(catalog))
            self.cases = select_cases(self.catalog, self.filters)
            for case in self.cases:  # an unbuilt scene case names its build command before any episode
                check_available(case)
        except VProError as exc:
            raise BenchmarkConfigError(str(exc)) from None
        if not self.cases:
            raise BenchmarkConfigError(f"params.select {self.filters!r} selects no case")
        self._session: EpisodeSession | None = None
        self._versions = library_versions()

    # -- tasks ---------------------------------------------------------------------------------

    def get_tasks(self) -> list[Task]:
        return [{"name": case["id"], "instruction": prompt_of(case), **case_labels(case)} for case in self.cases]

    def get_metadata(self) -> dict[str, Any]:
        return {
            "max_steps": max(self.settings.limit(c["suite"]) for c in self.cases),
            "max_episodes_per_task": min(len(c["trial_seeds"]) for c in self.cases),
            "suite": "libero_vpro",
            "cases": len(self.cases),
            "settings": self.settings.to_json(),
        }

    def _case(self, task: Task) -> dict:
        for case in self.cases:
            if case["id"] == task["case_id"]:
                return case
        raise VProError(f"case {task['case_id']!r} is not in this benchmark's selection {self.filters!r}")

    # -- episode -------------------------------------------------------------------------------

    @property
    def session(self) -> EpisodeSession:
        """The episode in progress (vla-eval calls reset before any step)."""
        if self._session is None or self._session.cenv is None:
            raise VProError("LiberoVProBenchmark: no episode in progress; vla-eval calls reset(task) first")
        return self._session

    def _case_env(self) -> CaseEnv:
        cenv = self.session.cenv
        assert cenv is not None  # checked by `session`
        return cenv

    def _close_session(self) -> None:
        if self._session is not None:
            self._session.close()
            self._session = None

    def _policy_obs(self, obs: dict) -> dict:
        """The raw observation with each camera image replaced by the view the policy gets (raw
        frame; a removed view black), for vla-eval's LIBERO `make_obs` to flip and package."""
        images = self.session.policy_images(obs)
        out = dict(obs)
        for cam in CAMERAS:
            img = images.get(cam)
            key = IMAGE_KEYS[cam]
            out[key] = np.asarray(img, dtype=np.uint8) if img is not None else np.zeros_like(obs[key])
        return out

    def reset(self, task: Task) -> Any:
        self._close_session()  # an episode the harness abandoned (server gone) returns its env
        case = self._case(task)
        trial = int(task.get("episode_idx", 0))
        if not 0 <= trial < len(case["trial_seeds"]):
            raise VProError(
                f"case {case['id']}: episode {trial} has no trial (the case has "
                f"{len(case['trial_seeds'])}; set episodes_per_task <= {len(case['trial_seeds'])})"
            )
        if case.get("params", {}).get("requires_predicted_frames") and not self.predicts_frames:
            raise CaseUnavailableError(
                f"case {case['id']}: the model server does not predict frames "
                "(params.predicts_frames: false); Prediction-Reality Divergence applies "
                "to frame-predicting policies only"
            )
        self._session = EpisodeSession(case, trial, self.settings)
        obs = self._session.start()
        self._env = self._case_env().env  # vla-eval's LIBERO reads the controller state from it
        if self.absolute_action:
            for robot in self._env.robots:
                robot.controller.use_delta = False
        policy_obs = self._policy_obs(obs)
        self._recorder.record_video(self._extract_frame(policy_obs))
        return policy_obs

    def step(self, action: Action) -> StepResult:
        raw = action.get("actions", action.get("action")) if isinstance(action, dict) else None
        if raw is None:
            raise PolicyOutputError(f"model server reply has no 'actions' (keys: {sorted(action or {})})")
        chunk = validate_actions(raw, where="model server")
        if len(chunk) != 1:
            raise PolicyOutputError(
                f"model server sent {len(chunk)} actions for one step; LIBERO takes one 7-D "
                "action per observation (set the server's chunk_size)"
            )
        processed = chunk[0].copy()
        processed[-1] = -1.0 if processed[-1] < 0 else 1.0  # vla-eval's LIBERO gripper convention
        if action.get("predicted_frames") is not None:
            self._case_env().feed_predicted(action["predicted_frames"])
        session = self.session
        obs = session.step(processed)
        policy_obs = self._policy_obs(obs)
        self._recorder.record_video(self._extract_frame(policy_obs))
        self._recorder.record_step(
            reward=float(session.success),
            done=session.finished,
            success=session.success,
            action=processed.astype(np.float32),
            state=self._proprio_state(obs).astype(np.float32),
        )
        return StepResult(
            obs=policy_obs, reward=float(session.success), done=session.finished, info={"success": session.success}
        )

    def make_obs(self, raw_obs: Any, task: Task) -> Observation:
        obs = super().make_obs(raw_obs, task)
        obs["task_description"] = task["instruction"]
        return obs

    def check_done(self, step_result: StepResult) -> bool:
        return bool(step_result.done)

    def get_step_result(self, step_result: StepResult) -> EpisodeResult:
        session = self.session
        result = session.result()
        result["contact_detail"] = result["contact"]
        result["contact"] = result["contact"]["composition"]
        out = {**case_labels(session.case), "trial": session.trial, **result, "versions": self._versions}
        self._close_session()
        return out

    def cleanup(self) -> None:
        self._close_session()
        self._env = None
        release_cached_envs()
