"""`vpro preview TASK_OR_CASE --out FILE.png`: pictures of what the benchmark changes.

A task key gives the gallery of its built scene variants (`vpro_assets.scene.gallery`). A case id
gives a contact sheet of the case's observation perturbation: a short scripted rollout (the privileged pick-and-place policy where the task has a target, the
no-op action otherwise) runs through the case's pipeline; at the first step of every phase the
tracker reports (and at the steps where the setting's own clock matters: freeze and replay
starts), both views are shown clean and perturbed, upright, one row per moment.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.core.images import label, write_png
from vpro_assets.libero.env import CAMERAS, NOOP_ACTION, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb import build_pipeline
from vpro_assets.perturb.rendering import render_rgb
from vpro_assets.rollout.policies.scripted import PickPlaceController
from vpro_assets.scene.gallery import write_gallery

PANEL_GRAY = 96


DESCRIPTION = (
    "Pictures of what the benchmark changes. Given a task key (libero_goal-03): the agentview image "
    "of the first initial state of every built scene case of the task, plus the unchanged task, in one "
    "labelled gallery. Given an observation-level case id: a short scripted rollout of the case, one row "
    "per moment (the first step of each manipulation phase, plus the setting's own key steps), columns "
    "clean and perturbed for the third-person and wrist views, upright."
)


def add_parser(sub) -> None:
    p = sub.add_parser(
        "preview", help="PNG of a task's scene variants (gallery) or of a case's perturbation", description=DESCRIPTION
    )
    p.add_argument(
        "target",
        metavar="TASK_OR_CASE",
        help="task key (gallery of its scene variants) or observation case id "
        "(e.g. libero_spatial-00/camera_staleness/wrist-freeze-v1)",
    )
    p.add_argument("--out", type=Path, required=True, metavar="FILE.png", help="PNG to write")
    p.add_argument(
        "--resolution", type=int, default=None, help="pixels per image (default 256 for a gallery, 128 for a case)"
    )
    p.add_argument("--steps", type=int, default=160, help="case: longest rollout (default 160 steps)")
    p.add_argument("--trial", type=int, default=0, help="case: trial, i.e. initial state and seeds (default 0)")
    p.add_argument("--catalog", type=Path, default=None, help="catalog to read (default: catalog.json)")
    p.set_defaults(run=run_preview)


def run_preview(args) -> int:
    catalog = load_catalog(args.catalog or paths.catalog_path())
    if "/" in args.target:
        return _case_sheet(catalog, args.target, args.out, args.resolution or 128, args.steps, args.trial)
    return _gallery(catalog, args.target, args.out, args.resolution or 256)


def _gallery(catalog: dict, task: str, out: Path, resolution: int) -> int:

    shown = write_gallery(catalog, task, out, resolution)
    if not shown:
        raise VProError(f"task {task}: no built scene case; run `vpro build --select {task}`")
    print(f"wrote {out}: {shown} panel(s)", file=sys.stderr)
    return 0


def _panel(frame, text: str, res: int) -> np.ndarray:
    if frame is None:
        frame = np.full((res, res, 3), PANEL_GRAY, np.uint8)
        text += " (absent)"
    return label(np.ascontiguousarray(frame[::-1]), text)


def key_steps(case: dict) -> set[int]:
    p = case.get("params", {})
    return {s for s in (p.get("freeze_step"), p.get("replay_start"), p.get("delay_steps")) if isinstance(s, int)}


def _case_sheet(catalog: dict, case_id: str, out: Path, resolution: int, steps: int, trial: int) -> int:

    case = find_case(catalog, case_id)
    if case.get("level") != "observation":
        raise VProError(
            f"case {case['id']} is not an observation-level case (level {case.get('level')!r}); "
            "preview shows observation perturbations"
        )
    task = get_task(case["task"])
    states = libero_init_states(task)
    row = case["init_states"]["rows"][trial] if trial < len(case["init_states"]["rows"]) else None
    if row is None:
        raise VProError(f"--trial {trial} out of range for case {case['id']}")
    pipe = build_pipeline(case, task)
    env = make_env(task, resolution)
    rows: list[np.ndarray] = []
    try:
        env.reset()
        pipe.reset(trial, env.sim)
        raw = env.set_init_state(states[row])
        controller = PickPlaceController(env.sim, task) if task.target else None
        wanted, seen_phase = key_steps(case), None
        for step in range(steps + 1):
            if step:
                raw, *_ = env.step(controller.action() if controller else NOOP_ACTION)
            obs = pipe.observe(raw, env.sim)
            phase = pipe.tracker.phase if pipe.tracker is not None else None
            if phase != seen_phase or step in wanted:
                clean = {cam: raw[f"{cam}_image"] for cam in CAMERAS}
                if pipe.hook is not None:  # the env's own frame of an edited camera is already edited
                    for cam in pipe.hook.edits:
                        clean[cam] = render_rgb(env.sim, cam, resolution, resolution)
                panels = []
                for cam, short in zip(CAMERAS, ("3rd", "wrist")):
                    panels.append(_panel(clean[cam], f"t={step} {phase} {short} clean", resolution))
                    panels.append(_panel(obs.get(f"{cam}_image"), f"{short} perturbed", resolution))
                rows.append(np.concatenate(panels, axis=1))
                seen_phase = phase
            if controller and controller.stage == "done":
                break
    finally:
        pipe.detach()
        env.close()
    write_png(out, np.concatenate(rows, axis=0))
    print(f"wrote {out}: {case['id']}, {len(rows)} moments, phases {pipe.phase_timeline()['changes']}", file=sys.stderr)
    return 0
