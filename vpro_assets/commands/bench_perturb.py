"""`vpro bench perturb`: step time of each observation setting against the clean env.

For every selected setting, blocks of `--steps` steps of the scripted policy run on one env,
clean and perturbed blocks interleaved (clean, control, clean, setting 1, clean, setting 2, ...),
and the whole sequence is repeated `--rounds` times. A step is `env.step` (physics, control and
the env's own camera renders) plus the pipeline's `observe`. Per setting:
- ratio: median perturbed step over the median step of the clean blocks next to its blocks,
  pooled over the rounds (slow drifts of the machine's load cancel); its spread is the range of
  the per-round ratios, and the `control` row (an identity pipeline measured like a setting)
  shows the noise floor of the measurement;
- overhead: 1 + the pipeline's own added work per step (`observe`, scene edits and scene
  captures inside the env's renders, timed directly) over the clean step, far less sensitive to
  the load than the wall clock.
Goals (issue 15): mask settings <= 1.05, every other setting <= 1.02. The JSON file lists one
object per setting; `docs/benchmarks.md` gets a Markdown table in its own section, leaving any
other section of the file as it was.
"""

from __future__ import annotations

import json
import logging
import os
import platform
import statistics
import sys
import time
from pathlib import Path

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.commands.bench_doc import DEFAULT_DOC, cores, update_markdown_section
from vpro_assets.commands.bench_perturb_table import CONTROL, GOAL_MASK, GOAL_OTHER, markdown_table
from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.libero.env import NOOP_ACTION, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb import ObservationPipeline, build_pipeline
from vpro_assets.rollout.policies.scripted import PickPlaceController

log = logging.getLogger(__name__)

SECTION = "perturb"


def add_parser(bsub) -> None:
    q = bsub.add_parser(
        "perturb",
        help="step-time ratio of each observation setting against the clean env",
        description="For each observation-level setting, run scripted episodes on one env with "
        "clean and perturbed blocks interleaved; report the wall-clock step-time ratio, the "
        "pipeline's own added work, whether extra renders (masks, scene edits) are needed, and "
        f"the goal (<= {GOAL_MASK} for mask settings, <= {GOAL_OTHER} for the others). Writes a JSON list and the "
        "'perturb' section of docs/benchmarks.md.",
    )
    q.add_argument("--out", type=Path, required=True, metavar="FILE.json", help="JSON file to write")
    q.add_argument(
        "--select",
        action="append",
        metavar="FILTER",
        help="narrow to settings by setting id, category, dimension or case (repeatable); default: all 74",
    )
    q.add_argument("--steps", type=int, default=8, help="env steps measured per block (default 8)")
    q.add_argument(
        "--rounds",
        type=int,
        default=3,
        help="repetitions of the whole interleaved sequence; the spread of a ratio is its range "
        "over the rounds (default 3)",
    )
    q.add_argument(
        "--mask-path",
        choices=("capture", "reference", "both"),
        default="capture",
        help="how mask settings get their masks: from the scene the env drew (capture, the default), "
        "from full-scene segmentation renders (reference, the path before issue 15), or both side by side",
    )
    q.add_argument(
        "--task",
        default="libero_spatial-00",
        help="task to run on where the setting applies to it (default libero_spatial-00, where all "
        "74 apply); otherwise the setting's first catalog task",
    )
    q.add_argument("--resolution", type=int, default=256, help="camera resolution (default 256, as evaluations use)")
    q.add_argument(
        "--doc", type=Path, default=DEFAULT_DOC, help="Markdown file for the table (default docs/benchmarks.md)"
    )
    q.set_defaults(run=run_bench_perturb)


def observation_settings(filters) -> list[tx.Setting]:
    obs = [s for s in tx.SETTINGS if tx.category(s.category).level == tx.OBSERVATION]
    if not filters:
        return obs
    wanted = {f.strip() for f in filters}
    direct = {s.id for s in obs if s.id in wanted or s.id.removeprefix("vpro/") in wanted}
    rest = [f for f in wanted if f not in {s.id for s in obs} | {s.id.removeprefix("vpro/") for s in obs}]
    chosen = set(direct)
    if rest:
        chosen |= {c["setting"] for c in select_cases(load_catalog(paths.catalog_path()), rest)}
    picked = [s for s in obs if s.id in chosen]
    if not picked:
        raise VProError(f"--select {' '.join(filters)} selects no observation-level setting")
    return picked


def task_for(setting: tx.Setting, preferred: str, catalog: dict) -> str:
    tasks = [c["task"] for c in catalog["cases"] if c["setting"] == setting.id]
    if not tasks:
        raise VProError(f"setting {setting.id} has no case in the catalog")
    return preferred if preferred in tasks else tasks[0]


def _block(env, task, state, pipeline, steps: int) -> dict:
    """One episode of `steps` scripted steps through `pipeline`: step times, the pipeline's own
    work per step (`observe`, scene edits and scene captures inside the env's renders), steps on
    which it changed something, and the mask passes it rendered."""

    env.sim.reset()  # a soft restart: timing only, exact physics does not matter here
    pipeline.reset(0, env.sim)
    pipeline.observe(env.set_init_state(state), env.sim)
    controller = PickPlaceController(env.sim, task) if task.target else None
    hook = pipeline.hook
    times, own, active = [], [], 0
    renders0, reference0 = pipeline.mask_renders, pipeline.reference_mask_renders
    try:
        for _ in range(steps):
            action = controller.action() if controller else NOOP_ACTION
            inside0 = hook.edit_seconds + hook.capture_seconds if hook else 0.0
            t0 = time.perf_counter()
            raw, *_ = env.step(action)
            t1 = time.perf_counter()
            pipeline.observe(raw, env.sim)
            t2 = time.perf_counter()
            times.append(t2 - t0)
            own.append(t2 - t1 + ((hook.edit_seconds + hook.capture_seconds - inside0) if hook else 0.0))
            active += bool(pipeline.last_notes)
    finally:
        pipeline.detach()
    return {
        "times": times,
        "own": own,
        "active": active,
        "mask_renders": pipeline.mask_renders - renders0,
        "reference_mask_renders": pipeline.reference_mask_renders - reference0,
    }


def bench(
    settings: list[tx.Setting],
    preferred_task: str,
    steps: int,
    resolution: int,
    progress=None,
    rounds: int = 3,
    mask_path: str = "capture",
) -> list[dict]:

    catalog = load_catalog(paths.catalog_path())
    by_task: dict[str, list[tx.Setting]] = {}
    for s in settings:
        by_task.setdefault(task_for(s, preferred_task, catalog), []).append(s)
    rows = []
    for key, group in by_task.items():
        task = get_task(key)
        # Blocks restart softly from the initial state; a horizon beyond every block keeps robosuite
        # from ending the episode across them.
        env = make_env(task, resolution, horizon=10**9)
        try:
            env.reset()
            state = libero_init_states(task)[0]
            clean_pipe = build_pipeline({"id": f"{key}/normal", "setting": None}, task)
            pipes: list[tuple[tx.Setting | None, ObservationPipeline]] = [(None, clean_pipe)]
            for s in group:
                case = {"id": f"{key}/{s.id.removeprefix('vpro/')}", "setting": s.id, "params": s.param_dict}
                mask_paths = ("capture", "reference") if mask_path == "both" else (mask_path,)
                for k, path in enumerate(mask_paths):
                    pipe = build_pipeline(case, task)
                    pipe.capture_masks = path == "capture"
                    if k == 0 or pipe.mask_labels:  # settings without masks are measured once
                        pipes.append((s, pipe))
            runs: dict[int, list[tuple[dict, dict, dict]]] = {i: [] for i in range(len(pipes))}
            previous = _block(env, task, state, clean_pipe, steps)
            for _ in range(rounds):
                for i, (_, pipe) in enumerate(pipes):
                    perturbed = _block(env, task, state, pipe, steps)
                    following = _block(env, task, state, clean_pipe, steps)
                    runs[i].append((previous, perturbed, following))
                    previous = following
                    if progress:
                        progress.update(1)
            for i, (setting, pipe) in enumerate(pipes):
                rows.append(_row(setting, pipe, key, steps, resolution, runs[i]))
        finally:
            env.close()
    return rows


def _row(
    s: tx.Setting | None, pipe, key: str, steps: int, resolution: int, runs: list[tuple[dict, dict, dict]]
) -> dict:
    med = statistics.median
    clean = [t for before, _, after in runs for t in before["times"] + after["times"]]
    clean_own = [t for before, _, after in runs for t in before["own"] + after["own"]]
    pert = [t for _, p, _ in runs for t in p["times"]]
    own = [t for _, p, _ in runs for t in p["own"]]
    per_round = [med(p["times"]) / med(before["times"] + after["times"]) for before, p, after in runs]
    ratio = med(pert) / med(clean)
    added = med(own) - med(clean_own)  # the pipeline's own added work, timed directly
    overhead = 1 + max(added, 0.0) / med(clean)
    masks = bool(pipe.mask_labels)
    goal = GOAL_MASK if masks else GOAL_OTHER
    n = len(runs) * steps
    reference = bool(pipe.mask_labels) and not pipe.capture_masks
    return {
        "setting": s.id if s else CONTROL,
        "category": s.category if s else "control",
        "task": key,
        "mask_path": ("reference" if reference else "capture") if pipe.mask_labels else None,
        "steps": steps,
        "rounds": len(runs),
        "resolution": resolution,
        "ratio": round(ratio, 4),
        "ratio_min": round(min(per_round), 4),
        "ratio_max": round(max(per_round), 4),
        "ratio_rounds": [round(r, 4) for r in per_round],
        "overhead_ratio": round(overhead, 4),
        "added_ms": round(added * 1000, 2),
        "clean_step_ms": round(med(clean) * 1000, 2),
        "perturbed_step_ms": round(med(pert) * 1000, 2),
        "needs_extra_render": pipe.needs_extra_render,
        "masks": masks,
        "mask_renders_per_step": round(sum(p["mask_renders"] for _, p, _ in runs) / n, 3),
        "reference_mask_renders": sum(p["reference_mask_renders"] for _, p, _ in runs),
        "active_steps": sum(p["active"] for _, p, _ in runs),
        "measured_steps": n,
        "goal": goal,
        "meets_goal": ratio <= goal,
        "overhead_meets_goal": overhead <= goal,
    }


# Long on purpose: the table's columns and its legend, in print order.
def run_bench_perturb(args) -> int:
    if args.steps < 3:
        raise VProError(f"--steps must be at least 3, got {args.steps}")
    if args.rounds < 1:
        raise VProError(f"--rounds must be at least 1, got {args.rounds}")
    settings = observation_settings(args.select)
    try:
        from tqdm import tqdm

        per_setting = 2 if args.mask_path == "both" else 1  # an upper bound: only mask settings double
        progress = tqdm(
            total=(len(settings) * per_setting + 1) * args.rounds, desc="bench perturb", unit="block", file=sys.stderr
        )
    except ImportError:  # pragma: no cover
        progress = None
    load0, t0 = os.getloadavg()[0], time.time()
    rows = bench(settings, args.task, args.steps, args.resolution, progress, args.rounds, args.mask_path)
    load1, wall = os.getloadavg()[0], time.time() - t0
    if progress:
        progress.close()
    write_text_atomic(args.out, json.dumps(rows, indent=1) + "\n")
    meta = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t0)),
        "steps": args.steps,
        "rounds": args.rounds,
        "resolution": args.resolution,
        "wall": f"{wall / 60:.0f} min",
        "load": f"{load0:.1f} at the start, {load1:.1f} at the end",
        "command": "vpro " + " ".join(sys.argv[1:]),
        "machine": f"{platform.machine()} {platform.system()} ({cores()} cores, no GPU: Mesa llvmpipe)",
    }
    update_markdown_section(args.doc, SECTION, markdown_table(rows, meta))
    missed = [r["setting"] for r in rows if r["setting"] != CONTROL and not r["meets_goal"]]
    print(
        f"wrote {args.out} ({len(rows) - 1} settings and the control; {len(missed)} above their goal) and the "
        f"'{SECTION}' section of {args.doc}",
        file=sys.stderr,
    )
    return 0
