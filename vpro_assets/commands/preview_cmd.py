"""`vpro preview CASE --out FILE.png`: a contact sheet of what a case's perturbation does.

A short scripted rollout (the privileged pick-and-place policy where the task has a target, the
no-op action otherwise) runs through the case's pipeline; at the first step of every phase the
tracker reports (and at the steps where the setting's own clock matters: freeze and replay
starts), both views are shown clean and perturbed, upright, one row per moment.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .. import paths
from ..catalog import find_case, load_catalog
from ..env import CAMERAS, NOOP_ACTION, libero_init_states, make_env
from ..errors import VProError
from ..images import label, write_png
from ..tasks import get_task

PANEL_GRAY = 96


DESCRIPTION = ("Given an observation-level case id: run a short scripted rollout of the case and write a PNG "
               "with one row per moment (the first step of each manipulation phase, plus the setting's own key "
               "steps), columns clean and perturbed for the third-person and wrist views, upright.")


def add_parser(sub) -> None:
    existing = sub.choices.get("preview")
    if existing is not None:
        # `vpro preview TASK` (the scene gallery) is already registered: share the command, and
        # take over when the argument is a case id (it has a '/'), so both keep working.
        _add_options(existing, positional=False)
        existing.description = (existing.description or "") + " " + DESCRIPTION
        gallery = existing.get_default("run")
        existing.set_defaults(run=lambda args: _dispatch(args, gallery))
        return
    p = sub.add_parser("preview", help="contact sheet of a case's observation perturbation", description=DESCRIPTION)
    _add_options(p, positional=True)
    p.set_defaults(run=run_preview)


def _add_options(p, positional: bool) -> None:
    if positional:
        p.add_argument("case", metavar="CASE", help="case id, e.g. libero_spatial-00/camera_staleness/wrist-freeze-v1")
        p.add_argument("--out", type=Path, required=True, metavar="FILE.png", help="PNG to write")
        p.add_argument("--resolution", type=int, default=128, help="camera resolution (default 128)")
    p.add_argument("--steps", type=int, default=160, help="observation cases: longest rollout (default 160 steps)")
    p.add_argument("--trial", type=int, default=0, help="observation cases: trial, i.e. initial state and seeds (default 0)")


def _dispatch(args, gallery) -> int:
    target = getattr(args, "task", None)
    if target and "/" in target:
        args.case = target
        return run_preview(args)
    return gallery(args)


def _panel(frame, text: str, res: int) -> np.ndarray:
    if frame is None:
        frame = np.full((res, res, 3), PANEL_GRAY, np.uint8)
        text += " (absent)"
    return label(np.ascontiguousarray(frame[::-1]), text)


def key_steps(case: dict) -> set[int]:
    p = case.get("params", {})
    return {s for s in (p.get("freeze_step"), p.get("replay_start"), p.get("delay_steps")) if isinstance(s, int)}


def run_preview(args) -> int:
    from ..perturb import build_pipeline
    from ..perturb.rendering import render_rgb
    from ..scripted_policy import PickPlaceController

    case = find_case(load_catalog(paths.catalog_path()), args.case)
    if case.get("level") != "observation":
        raise VProError(f"case {case['id']} is not an observation-level case (level {case.get('level')!r}); "
                        "preview shows observation perturbations")
    task = get_task(case["task"])
    states = libero_init_states(task)
    row = case["init_states"]["rows"][args.trial] if args.trial < len(case["init_states"]["rows"]) else None
    if row is None:
        raise VProError(f"--trial {args.trial} out of range for case {case['id']}")
    pipe = build_pipeline(case, task)
    env = make_env(task, args.resolution)
    rows: list[np.ndarray] = []
    try:
        env.reset()
        pipe.reset(args.trial, env.sim)
        raw = env.set_init_state(states[row])
        controller = PickPlaceController(env.sim, task) if task.target else None
        wanted, seen_phase = key_steps(case), None
        for step in range(args.steps + 1):
            if step:
                raw, *_ = env.step(controller.action() if controller else NOOP_ACTION)
            obs = pipe.observe(raw, env.sim)
            phase = pipe.tracker.phase
            if phase != seen_phase or step in wanted:
                clean = {cam: raw[f"{cam}_image"] for cam in CAMERAS}
                if pipe.hook is not None:  # the env's own frame of an edited camera is already edited
                    for cam in pipe.hook.edits:
                        clean[cam] = render_rgb(env.sim, cam, args.resolution, args.resolution)
                panels = []
                for cam, short in zip(CAMERAS, ("3rd", "wrist")):
                    panels.append(_panel(clean[cam], f"t={step} {phase} {short} clean", args.resolution))
                    panels.append(_panel(obs.get(f"{cam}_image"), f"{short} perturbed", args.resolution))
                rows.append(np.concatenate(panels, axis=1))
                seen_phase = phase
            if controller and controller.stage == "done":
                break
    finally:
        pipe.detach()
        env.close()
    write_png(args.out, np.concatenate(rows, axis=0))
    print(f"wrote {args.out}: {case['id']}, {len(rows)} moments, phases {pipe.phase_timeline()['changes']}",
          file=sys.stderr)
    return 0
