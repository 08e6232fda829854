"""One closed-loop episode: build the case's env, wait, then observe -> act until success or the
step limit, as openpi's and OpenVLA-OFT's LIBERO scripts do.

LIBERO's conventions: 10 no-op wait steps first (objects settle; not counted in `steps`), then at
most 220 / 280 / 300 / 520 policy steps for libero_spatial / object / goal / 10. A chunk of actions
is executed up to the policy's `replan_steps` before the next query. The result is a plain dict,
the fields of one row of the results store.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.libero.env import CAMERAS, NOOP_ACTION
from vpro_assets.libero.tasks import get_task
from vpro_assets.rollout.case_env import CaseEnv, CaseUnavailableError, check_available, env_for_case
from vpro_assets.rollout.contacts import ContactTracker
from vpro_assets.rollout.policies.base import EpisodeInfo, InfrastructureError, Observation, as_output

log = logging.getLogger(__name__)

MAX_STEPS = {"libero_spatial": 220, "libero_object": 280, "libero_goal": 300, "libero_10": 520}
WAIT_STEPS = 10


@dataclass(frozen=True)
class EpisodeSettings:
    resolution: int = 256
    wait_steps: int = WAIT_STEPS
    max_steps: dict = field(default_factory=lambda: dict(MAX_STEPS))  # per suite
    max_steps_override: int | None = None  # one limit for every suite
    video_dir: str | None = None
    render: bool = True  # False: no renderer, no camera observations (policies that act from state)

    def __post_init__(self) -> None:
        if not self.render and self.video_dir:
            raise VProError("a video needs rendered episodes: drop --video or run with rendering")

    def limit(self, suite: str) -> int:
        return self.max_steps_override if self.max_steps_override is not None else self.max_steps.get(suite, 520)

    def to_json(self) -> dict:
        return asdict(self)


def _distractors(cenv: CaseEnv) -> list[str]:
    names = cenv.scene.get("distractors") or cenv.case.get("params", {}).get("distractor_instances") or []
    return [names] if isinstance(names, str) else list(names)


def prompt_of(case: dict) -> str:
    """The instruction models are prompted with: LIBERO's benchmark language (from the task file name,
    what openpi's and OpenVLA-OFT's scripts send), falling back to the BDDL's wording."""
    task = get_task(case["task"])
    return case.get("instruction") or getattr(task, "instruction", None) or task.language


def _pid(policy) -> str:
    return str(getattr(policy, "policy_id", type(policy).__name__))


class EpisodeSession:
    """One episode of one case, driven step by step: the case's env, the seeded reset, the wait
    steps, the step limit, the success check and the perturbed views. `run_episode` (`vpro eval`)
    and outside harnesses that own the loop (`vpro_assets.integrations.vla_eval`) both run their
    episodes through it, so an episode is the same whoever asks for the actions.

        session = EpisodeSession(case, trial, settings)   # checks the case can run here
        obs = session.start()                             # env, reset, wait steps
        while not session.finished:
            images = session.policy_images(obs)           # what the policy sees (raw frame)
            obs = session.step(action)
        row_fields = session.result()                     # then session.close()
    """

    def __init__(self, case: dict, trial: int, settings: EpisodeSettings, observe: bool = True):
        """`observe=False` (render-free episodes of a policy that reads no observation, the oracle):
        the env makes no observation (`CaseEnv.step`); `start` and `step` return {}."""
        self.case, self.trial, self.settings = case, trial, settings
        self.observe = observe or settings.render
        self.seed = int(case["trial_seeds"][trial])
        self.limit = settings.limit(case["suite"])
        self.instruction = prompt_of(case)
        self.started = time.time()
        self.cenv: CaseEnv | None = None
        self.contacts: ContactTracker | None = None
        self.t = 0  # control steps since the reset, wait steps included
        self.steps = 0  # policy steps
        self.success = False
        check_available(case)

    @property
    def env(self) -> CaseEnv:
        """The episode's env (after `start`)."""
        if self.cenv is None:
            raise VProError(f"case {self.case['id']} trial {self.trial}: episode used before start()")
        return self.cenv

    @property
    def contact_tracker(self) -> ContactTracker:
        if self.contacts is None:
            raise VProError(f"case {self.case['id']} trial {self.trial}: episode used before start()")
        return self.contacts

    def episode_info(self) -> EpisodeInfo:
        return EpisodeInfo(
            instruction=self.instruction,
            case_id=self.case["id"],
            trial=self.trial,
            seed=self.seed,
            suite=self.case["suite"],
            task=self.case["task"],
        )

    def start(self, on_reset: Callable[[CaseEnv], None] | None = None) -> dict:
        """Build the env, reset it to the trial's initial state, run the wait steps; the raw observation."""
        self.cenv = env_for_case(
            self.case, self.trial, resolution=self.settings.resolution, render=self.settings.render
        )
        obs = self.cenv.reset()
        if on_reset is not None:
            on_reset(self.cenv)
        self.contacts = ContactTracker(self.cenv.sim, self.cenv.task.target, _distractors(self.cenv))
        for _ in range(self.settings.wait_steps):
            obs, _ = self.cenv.step(NOOP_ACTION, observe=self.observe)
            self.t += 1
        return obs if self.observe else {}

    def policy_images(self, obs: dict) -> dict:
        """The views the policy receives now (raw bottom-up frame; None = unavailable view, and
        every view of a render-free episode)."""
        if not self.settings.render:
            return dict.fromkeys(CAMERAS)
        return self.env.policy_images(obs, self.t)

    def observation(self, obs: dict, images: dict | None = None) -> Observation:
        images = self.policy_images(obs) if images is None else images
        return Observation.from_libero(obs, self.t, self.instruction, images=images)

    def step(self, action) -> dict:
        """One policy step; the raw observation after it ({}: not observing)."""
        obs, done = self.env.step(action, observe=self.observe)
        self.t += 1
        self.steps += 1
        self.contact_tracker.update(self.t)
        if done and self.env.success():
            self.success = True
        return obs

    @property
    def finished(self) -> bool:
        return self.success or self.steps >= self.limit

    def result(self, video: str | None = None) -> dict:
        return {
            "success": self.success,
            "steps": self.steps,
            "seed": self.seed,
            "phase_timeline": self.env.phase_timeline(),
            "contact": self.contact_tracker.summary(),
            "artifact_hashes": self.env.artifact_hashes,
            "wall_time": time.time() - self.started,
            "video": video,
            "final_state": self.env.state_digest(),
        }

    def close(self, failed: bool = False) -> None:
        """Release the env: kept for the next episode of the same scene, unless this one `failed`
        (raised: whatever state it left is not carried into the next trial)."""
        if self.cenv is not None:
            if failed:
                self.cenv.broken = True
            self.cenv.close()
            self.cenv = None


def run_episode(case: dict, trial: int, policy, settings: EpisodeSettings) -> dict:
    """Run one episode and return its row fields. Raises InfrastructureError or CaseUnavailableError."""
    # A render-free episode of a policy that reads no observation (the oracle: it reads the
    # simulator) makes none: robosuite's observables are skipped (`physics.unobserved_step`).
    session = EpisodeSession(case, trial, settings, observe=getattr(policy, "reads_observations", True))
    if not settings.render and getattr(policy, "uses_images", True):
        raise VProError(
            f"policy {_pid(policy)} acts on camera images; render-free episodes run only policies "
            "that declare uses_images = False (noop, random, oracle)"
        )
    if case.get("params", {}).get("requires_predicted_frames") and not getattr(policy, "predicts_frames", False):
        raise CaseUnavailableError(
            f"case {case['id']}: policy {_pid(policy)} does not predict frames; "
            "Prediction-Reality Divergence applies to frame-predicting policies only"
        )
    # The policy first: a server that is down is found before the env is built.
    try:
        policy.reset(session.episode_info())
    except InfrastructureError:
        raise
    except Exception as exc:
        raise InfrastructureError(f"policy {_pid(policy)}: reset raised {type(exc).__name__}: {exc}") from exc
    frames: list[np.ndarray] = []
    failed = True
    try:
        obs = session.start(on_reset=getattr(policy, "bind_env", None))
        plan: deque = deque()
        while not session.finished:
            images = None
            if not plan or settings.video_dir:
                images = session.policy_images(obs)
            if not plan:
                view = session.observation(obs, images) if session.observe else None
                try:
                    out = as_output(policy.act(view), where=f"policy {_pid(policy)}")
                except InfrastructureError:
                    raise
                except Exception as exc:
                    raise InfrastructureError(f"policy {_pid(policy)}: act raised {type(exc).__name__}: {exc}") from exc
                actions = out.actions
                n = getattr(policy, "replan_steps", None) or len(actions)
                plan.extend(actions[:n])
                if out.predicted_frames is not None:
                    session.env.feed_predicted(out.predicted_frames)
            if settings.video_dir:
                frames.append(_video_frame(obs, images))
            obs = session.step(plan.popleft())
        video = _write_video(settings.video_dir, case["id"], trial, frames) if settings.video_dir else None
        result = session.result(video)
        failed = False
        return result
    finally:
        session.close(failed)


def _video_frame(obs: dict, images: dict | None) -> np.ndarray:
    """Clean views (left) and the policy's views (right), upright."""
    clean = [obs[f"{cam}_image"] for cam in CAMERAS]
    seen = [(images or {}).get(cam) for cam in CAMERAS]
    seen = [s if s is not None else np.zeros_like(c) for s, c in zip(seen, clean)]
    return np.concatenate([np.asarray(x)[::-1] for x in clean + seen], axis=1).astype(np.uint8)


def _write_video(video_dir: str, case_id: str, trial: int, frames: list) -> str | None:
    import cv2

    if not frames:
        return None
    path = Path(video_dir) / f"{case_id.replace('/', '__')}__t{trial}.mp4"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.mp4")
    h, w = frames[0].shape[:2]
    fourcc = cv2.VideoWriter.fourcc(*"mp4v")
    writer = cv2.VideoWriter(str(tmp), fourcc, 20, (w, h))
    for f in frames:
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()
    tmp.replace(path)
    return str(path)
