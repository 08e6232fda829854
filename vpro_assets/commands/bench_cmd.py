"""`vpro bench perturb`: step time of each observation setting against the clean env.

For every selected setting, episodes of `--steps` steps of the scripted policy run on one env,
clean and perturbed blocks interleaved (clean, setting 1, clean, setting 2, clean, ...); a
setting's ratio is the median perturbed step time over the median of the clean blocks on both
sides of it, so slow drifts of the machine's load cancel. A step is `env.step` (physics, control
and the env's own camera renders) plus the pipeline's `observe`. The JSON file lists one object
per setting; `docs/benchmarks.md` gets a Markdown table in its own section, leaving any other
section of the file as it was.
"""
from __future__ import annotations

import json
import logging
import platform
import statistics
import sys
import time
from pathlib import Path

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.libero.env import NOOP_ACTION, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb import build_pipeline
from vpro_assets.rollout.policies.scripted import PickPlaceController

log = logging.getLogger(__name__)

GOAL_NO_EXTRA_RENDER, GOAL_EXTRA_RENDER = 1.05, 1.30
SECTION = "perturb"
DEFAULT_DOC = paths.REPO_ROOT / "docs" / "benchmarks.md"


def add_parser(sub) -> None:
    p = sub.add_parser("bench", help="measure the cost of the observation perturbations",
                       description="Benchmarks. `vpro bench perturb` measures, for each observation-level setting, "
                       "the step time of the perturbed env against the clean env in one interleaved run and "
                       "writes the ratios to a JSON file and a table to docs/benchmarks.md.")
    bsub = p.add_subparsers(dest="bench", metavar="BENCH", required=True)
    q = bsub.add_parser("perturb", help="step-time ratio of each observation setting against the clean env",
                        description="For each observation-level setting, run scripted episodes on one env with "
                        "clean and perturbed blocks interleaved; report the wall-clock step-time ratio, the "
                        "pipeline's own added work, whether extra renders (masks, scene edits) are needed, and "
                        "the goal (<= 1.05 without extra render, <= 1.30 with). Writes a JSON list and the "
                        "'perturb' section of docs/benchmarks.md.")
    q.add_argument("--out", type=Path, required=True, metavar="FILE.json", help="JSON file to write")
    q.add_argument("--select", action="append", metavar="FILTER",
                   help="narrow to settings by setting id, category, dimension or case (repeatable); default: all 74")
    q.add_argument("--steps", type=int, default=20, help="env steps measured per block (default 20)")
    q.add_argument("--task", default="libero_spatial-00",
                   help="task to run on where the setting applies to it (default libero_spatial-00, where all "
                   "74 apply); otherwise the setting's first catalog task")
    q.add_argument("--resolution", type=int, default=256, help="camera resolution (default 256, as evaluations use)")
    q.add_argument("--doc", type=Path, default=DEFAULT_DOC, help="Markdown file for the table (default docs/benchmarks.md)")
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


def _block(env, task, state, pipeline, steps: int) -> tuple[list[float], int, int, list[float]]:
    """Step times of one episode of `steps` scripted steps through `pipeline`, and the time of the
    pipeline's own work per step (`observe` plus scene edits inside the env's renders)."""

    env.sim.reset()  # a soft restart: timing only, exact physics does not matter here
    pipeline.reset(0, env.sim)
    pipeline.observe(env.set_init_state(state), env.sim)
    controller = PickPlaceController(env.sim, task) if task.target else None
    times, own, active = [], [], 0
    try:
        for _ in range(steps):
            action = controller.action() if controller else NOOP_ACTION
            edits0 = pipeline.hook.edit_seconds if pipeline.hook else 0.0
            t0 = time.perf_counter()
            raw, *_ = env.step(action)
            t1 = time.perf_counter()
            pipeline.observe(raw, env.sim)
            t2 = time.perf_counter()
            times.append(t2 - t0)
            own.append(t2 - t1 + ((pipeline.hook.edit_seconds - edits0) if pipeline.hook else 0.0))
            active += bool(pipeline.last_notes)
    finally:
        pipeline.detach()
    return times, active, pipeline.mask_renders, own


def bench(settings: list[tx.Setting], preferred_task: str, steps: int, resolution: int, progress=None) -> list[dict]:

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
            previous, _, _, previous_own = _block(env, task, state, clean_pipe, steps)
            for s in group:
                case = {"id": f"{key}/{s.id.removeprefix('vpro/')}", "setting": s.id, "params": s.param_dict}
                pipe = build_pipeline(case, task)
                perturbed, active, masks, own = _block(env, task, state, pipe, steps)
                following, _, _, following_own = _block(env, task, state, clean_pipe, steps)
                clean_med = statistics.median(previous + following)
                pert_med = statistics.median(perturbed)
                # The pipeline's own added work, timed directly, over the clean step: far less
                # sensitive to the machine's load than the wall-clock ratio.
                added = statistics.median(own) - statistics.median(previous_own + following_own)
                overhead = 1 + max(added, 0.0) / clean_med
                extra = pipe.needs_extra_render
                goal = GOAL_EXTRA_RENDER if extra else GOAL_NO_EXTRA_RENDER
                ratio = pert_med / clean_med
                rows.append({"setting": s.id, "category": s.category, "task": key, "steps": steps,
                             "resolution": resolution, "ratio": round(ratio, 4), "overhead_ratio": round(overhead, 4),
                             "added_ms": round(added * 1000, 2),
                             "clean_step_ms": round(clean_med * 1000, 2), "perturbed_step_ms": round(pert_med * 1000, 2),
                             "needs_extra_render": extra, "mask_renders_per_step": round(masks / (steps + 1), 3),
                             "active_steps": active, "goal": goal, "meets_goal": ratio <= goal,
                             "overhead_meets_goal": overhead <= goal})
                previous, previous_own = following, following_own
                if progress:
                    progress.update(1)
        finally:
            env.close()
    return rows


def markdown_table(rows: list[dict], meta: dict) -> str:
    lines = ["### Observation perturbations: step time against the clean env (`vpro bench perturb`)", "",
             f"Measured {meta['date']} on {meta['machine']}, {meta['steps']} scripted steps per block at "
             f"{meta['resolution']} px, clean and perturbed blocks interleaved; ratio = median perturbed step / "
             f"median clean step of the neighbouring clean blocks (wall clock: includes the noise of the machine's "
             f"load); overhead = 1 + the pipeline's own added work per step (observe and scene edits, timed "
             f"directly) / the clean step. Goal: <= {GOAL_NO_EXTRA_RENDER} without extra "
             f"render, <= {GOAL_EXTRA_RENDER} with masks or per-camera scene edits. `active` = steps on which the "
             "setting changed something (schedules and phases decide).", "",
             "| setting | task | extra render | clean ms | perturbed ms | ratio | added ms | overhead | active | "
             "goal met (ratio / overhead) |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| `{r['setting']}` | {r['task']} | {'yes' if r['needs_extra_render'] else 'no'} | "
                     f"{r['clean_step_ms']:.0f} | {r['perturbed_step_ms']:.0f} | {r['ratio']:.3f} | "
                     f"{r.get('added_ms', 0):.1f} | {r.get('overhead_ratio', r['ratio']):.3f} | "
                     f"{r['active_steps']}/{r['steps']} | {'yes' if r['meets_goal'] else '**no**'} / "
                     f"{'yes' if r.get('overhead_meets_goal', r['meets_goal']) else '**no**'} |")
    by_cat: dict[str, list[dict]] = {}
    for r in rows:
        by_cat.setdefault(r["category"], []).append(r)
    lines += ["", "| category | settings | median ratio | max ratio | median overhead | max overhead |",
              "|---|---:|---:|---:|---:|---:|"]
    for cat, rs in by_cat.items():
        ratios = [r["ratio"] for r in rs]
        over = [r.get("overhead_ratio", r["ratio"]) for r in rs]
        lines.append(f"| {cat} | {len(rs)} | {statistics.median(ratios):.3f} | {max(ratios):.3f} | "
                     f"{statistics.median(over):.3f} | {max(over):.3f} |")
    return "\n".join(lines) + "\n"


def update_markdown_section(path: Path, name: str, body: str, title: str = "# Benchmarks") -> None:
    """Replace the section `name` (between BEGIN/END markers) of a Markdown file, or append it;
    other sections are kept byte for byte."""
    begin, end = f"<!-- BEGIN bench:{name} -->", f"<!-- END bench:{name} -->"
    block = f"{begin}\n{body.rstrip()}\n{end}\n"
    text = path.read_text() if path.exists() else f"{title}\n\n"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        tail = rest.split(end, 1)[1].lstrip("\n")
        text = head + block + ("\n" + tail if tail else "")
    else:
        text = text.rstrip("\n") + "\n\n" + block
    write_text_atomic(path, text)


def run_bench_perturb(args) -> int:
    if args.steps < 3:
        raise VProError(f"--steps must be at least 3, got {args.steps}")
    settings = observation_settings(args.select)
    try:
        from tqdm import tqdm

        progress = tqdm(total=len(settings), desc="bench perturb", unit="setting", file=sys.stderr)
    except ImportError:  # pragma: no cover
        progress = None
    rows = bench(settings, args.task, args.steps, args.resolution, progress)
    if progress:
        progress.close()
    write_text_atomic(args.out, json.dumps(rows, indent=1) + "\n")
    meta = {"date": time.strftime("%Y-%m-%d", time.gmtime()), "steps": args.steps, "resolution": args.resolution,
            "machine": f"{platform.machine()} {platform.system()} ({_cores()} cores, no GPU: Mesa llvmpipe)"}
    update_markdown_section(args.doc, SECTION, markdown_table(rows, meta))
    missed = [r["setting"] for r in rows if not r["meets_goal"]]
    print(f"wrote {args.out} ({len(rows)} settings; {len(missed)} above their goal) and the '{SECTION}' section "
          f"of {args.doc}", file=sys.stderr)
    return 0


def _cores() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
