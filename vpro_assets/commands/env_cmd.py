"""`vpro env`: build a task's or case's LIBERO env headless and snapshot both views."""

from __future__ import annotations

import sys
from pathlib import Path

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.core.errors import UnknownIdError, VProError
from vpro_assets.core.images import write_png
from vpro_assets.libero.env import DEFAULT_RESOLUTION, NOOP_ACTION, libero_init_states, task_env, views_side_by_side
from vpro_assets.libero.init_states import read_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene.build import built_case


def add_parser(sub) -> None:
    p = sub.add_parser(
        "env",
        help="build an env headless and render both views to a PNG",
        description="Build the LIBERO env of a base task or case headless (MUJOCO_GL chosen "
        "automatically; a scene case from its built BDDL and frozen states), load an initial state, step once with the no-op action and write both "
        "views side by side (upright; third-person left, wrist right).",
    )
    p.add_argument("target", metavar="CASE_OR_TASK", help="task key (libero_goal-03), LIBERO task name, or case id")
    p.add_argument("--snapshot", type=Path, required=True, metavar="FILE.png", help="PNG to write")
    p.add_argument("--resolution", type=int, default=DEFAULT_RESOLUTION, help="camera height and width (default 256)")
    p.add_argument("--init-state", type=int, default=0, help="row of LIBERO's initial states to load (default 0)")
    p.set_defaults(run=run_env)


def resolve(target: str):
    """A task record from a task key, a LIBERO task name, or a case id in the catalog."""
    try:
        return get_task(target), None
    except UnknownIdError as task_error:
        if "/" not in target:
            raise task_error
    case = find_case(load_catalog(paths.catalog_path()), target)
    return get_task(case["task"]), case


def run_env(args) -> int:
    task, case = resolve(args.target)
    bddl = None
    if case is not None and case.get("level") == "scene":
        built = built_case(case["id"])
        bddl, states = str(built["bddl"]), read_init_states(built["init_states"])
    else:
        states = libero_init_states(task)
    if not 0 <= args.init_state < len(states):
        raise VProError(f"--init-state {args.init_state} out of range: {args.target} has {len(states)} initial states")
    with task_env(task, args.resolution, bddl_file=bddl) as env:
        env.reset()
        env.set_init_state(states[args.init_state])
        obs, *_ = env.step(NOOP_ACTION)
        write_png(args.snapshot, views_side_by_side(obs), labels=("agentview", "robot0_eye_in_hand"))
    print(f"wrote {args.snapshot} ({task.key}: {task.language})", file=sys.stderr)
    return 0
