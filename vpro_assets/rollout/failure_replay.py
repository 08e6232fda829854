"""Replaying an oracle trial that failed, to see why: the oracle's own log (its plan and the skills
that failed), the goal predicates still unmet at the end, and, rendered, a contact sheet of the
episode.

Episodes are deterministic (same seed, same initial state, same actions), so the replay ends in the
state its row recorded; `reproduced` says whether the final-state fingerprints agree (a render-free
and a rendered episode end in the same state, `tests/rollout/test_oracle_plan.py`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from vpro_assets.rollout.episode import EpisodeSession, EpisodeSettings
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy

SHEET_FRAMES = 6
SHEET_CAMERA = "agentview"


@dataclass
class Replay:
    case_id: str
    trial: int
    success: bool
    steps: int
    final_state: str
    unmet: list[str]  # goal predicates not holding at the end
    log: list[str]  # the oracle's plan and failure lines, in order
    stage: str | None  # the skill running when the episode ended
    frames: list[np.ndarray] = field(default_factory=list)  # upright RGB frames across the episode
    frame_steps: list[int] = field(default_factory=list)

    @property
    def reason(self) -> str:
        """One line: what was unmet, and the last skill failure (or the skill cut off by the limit)."""
        failures = [line.removeprefix("skill failed: ") for line in self.log if line.startswith("skill failed: ")]
        unmet = ", ".join(self.unmet) or "goal met after the step limit"
        if failures:
            return f"{unmet}: {failures[-1]}"
        if self.stage:
            return f"{unmet}: step limit during {self.stage}"
        return f"{unmet}: the plan ended without reaching the goal"

    def sheet(self) -> np.ndarray:
        """The frames side by side (empty when the replay was render-free)."""
        return np.concatenate(self.frames, axis=1) if self.frames else np.zeros((0, 0, 3), np.uint8)


def replay(case: dict, trial: int, settings: EpisodeSettings, render: bool, resolution: int = 256) -> Replay:
    """Run trial `trial` of `case` with the oracle again, render-free; `render`: snapshot
    SHEET_FRAMES frames of the agent view across the episode (robosuite's offscreen context on the
    episode's sim, only at those steps: the episode itself stays render-free)."""
    settings = replace(settings, render=False, video_dir=None)
    session = EpisodeSession(case, trial, settings)
    policy = OraclePolicy()
    policy.reset(session.episode_info())
    frames, frame_steps = [], []
    every = max(1, session.limit // (SHEET_FRAMES - 1))

    contexts = []

    def on_reset(cenv) -> None:
        policy.bind_env(cenv)
        if render:
            # A render-free env has no context. Making one calls `sim.forward()`: here, right after the
            # reset's own, it changes nothing; made at the first snapshot after the wait steps it
            # refreshed the positions the oracle reads, and the replay of libero_spatial-06's trial 5
            # went elsewhere (solved in 170 steps where the recorded trial failed at 220).
            # robosuite loads only once LIBERO is configured (its GL backend chosen first).
            from robosuite.utils.binding_utils import MjRenderContextOffscreen

            contexts.append(MjRenderContextOffscreen(cenv.sim, device_id=-1))

    def snapshot() -> None:
        image = session.env.sim.render(width=resolution, height=resolution, camera_name=SHEET_CAMERA)  # bottom-up
        frames.append(np.asarray(image)[::-1].copy())
        frame_steps.append(session.steps)

    try:
        session.start(on_reset=on_reset)
        while not session.finished:
            if render and session.steps % every == 0:
                snapshot()
            session.step(policy.next_action())
        if render:
            snapshot()
        controller = policy.controller
        result = session.result()
        unmet = [] if controller is None else [" ".join(g) for g in controller.goal if not controller.holds(g)]
        return Replay(
            case_id=case["id"],
            trial=trial,
            success=bool(result["success"]),
            steps=int(result["steps"]),
            final_state=str(result["final_state"]),
            unmet=unmet,
            log=list(controller.log) if controller else [],
            stage=controller.stage if controller else None,
            frames=frames[-SHEET_FRAMES:] if len(frames) > SHEET_FRAMES else frames,
            frame_steps=frame_steps[-SHEET_FRAMES:] if len(frame_steps) > SHEET_FRAMES else frame_steps,
        )
    finally:
        policy.close()
        session.close()
        for context in contexts:  # while EGL is up: freed at exit, it raised EGL_NOT_INITIALIZED
            context.gl_ctx.free()
