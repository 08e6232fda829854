"""Split substeps against robosuite's own substep loop, side by side in one process.

Three ways through LIBERO's control step (observables, reward and success included, render-free):
- `robosuite`: robosuite 1.4's loop per substep: mj_forward, the controllers (whose update runs
  mj_forward again), mj_step (a third forward inside);
- `split`: mj_step1, robosuite's controllers with their forward skipped, mj_step2;
- `split+lean`: the same, with the arm control between policy steps from `libero.arm_control`
  (the toolkit's step: its numba kernel, `libero.osc_kernel`, where it has one);
- `split+lean numpy`: the same with `arm_control`'s NumPy path (what runs where the kernel does not);
- `split+lean@REV` (`--against REV`): the same with `libero/arm_control.py` as it was at git
  revision REV, loaded beside this tree's (old and new arm control side by side in one process).
Each round times `--steps` control steps of every variant in turn on one env (a seeded sequence of
arm motions and gripper commands); then `--episodes` render-free oracle episodes (trial 1 of the
task's Normal baseline) with robosuite's loop and with the toolkit's step (and REV's), alternating.
Ratios are medians over rounds of the same minute, so a loaded machine slows both sides alike.

    .venv/bin/python scripts/bench_control_step.py --task libero_goal-03 --task libero_spatial-00
    .venv/bin/python scripts/bench_control_step.py --task libero_goal-03 --against main --episodes 3
"""

from __future__ import annotations  # noqa: I001 (vpro_assets before numpy: its import pins the kernels)

import argparse
import contextlib
import copy
import importlib.util
import json
import subprocess
import sys
import time
from pathlib import Path

import vpro_assets  # noqa: F401
import numpy as np

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.libero import arm_control, osc_kernel, physics
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.env import libero_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy
from vpro_assets.scene import sim

SPLIT = physics._substeps
ARMS = arm_control.Arms.of
AGAINST: dict[str, object] = {}  # variant name -> arm_control module of another revision


def load_arm_control(rev: str):
    """`vpro_assets/libero/arm_control.py` as it was at git revision `rev`, as a module of its own."""
    root = Path(__file__).resolve().parent.parent
    source = subprocess.run(
        ["git", "show", f"{rev}:vpro_assets/libero/arm_control.py"],
        cwd=root,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    name = f"arm_control_at_{rev}".replace("-", "_").replace("/", "_")
    spec = importlib.util.spec_from_loader(name, loader=None)
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    sys.modules[name] = module  # dataclasses look their module up
    exec(compile(source, f"{rev}:vpro_assets/libero/arm_control.py", "exec"), module.__dict__)
    return module


def _robosuite_substeps(inner, action, observe: bool) -> None:
    """robosuite 1.4's `MujocoEnv.step` loop, call for call."""
    policy_step = True
    for _ in range(int(inner.control_timestep / inner.model_timestep)):
        inner.sim.forward()
        inner._pre_action(action, policy_step)
        inner.sim.step()
        if observe:
            inner._update_observables()
        policy_step = False


@contextlib.contextmanager
def variant(name: str):
    if name == "robosuite":
        physics._substeps = _robosuite_substeps
    elif name == "split":
        arm_control.Arms.of = classmethod(lambda cls, inner: None)
    elif name in AGAINST:
        physics.arm_control = AGAINST[name]
    elif name == "split+lean numpy":
        arm_control.Arms.of = classmethod(lambda cls, inner: _numpy_path(ARMS(inner)))  # type: ignore[method-assign,assignment]
    try:
        yield
    finally:
        physics._substeps, arm_control.Arms.of, physics.arm_control = SPLIT, ARMS, arm_control


def _numpy_path(arms):
    """The env's kept arms without the kernel (a copy: the env keeps its own)."""
    if arms is None:
        return None
    arms = copy.copy(arms)
    arms.kernel = None
    return arms


def control_steps(task_key: str, steps: int, rounds: int) -> dict:
    task = get_task(task_key)
    env = sim.physics_env(str(libero_bridge.bddl_path(task.suite, task.name)))
    sim.place_fixtures(env, 0)
    env.set_init_state(libero_init_states(task)[0])
    rng = np.random.default_rng(0)
    actions = [np.concatenate([rng.uniform(-0.3, 0.3, 6), [1.0 if (i // 30) % 2 else -1.0]]) for i in range(steps)]
    times: dict[str, list[float]] = {
        "robosuite": [], "split": [], **{k: [] for k in AGAINST}, "split+lean numpy": [], "split+lean": []
    }  # fmt: skip
    for _ in range(rounds):
        for name, out in times.items():
            with variant(name):
                started = time.perf_counter()
                for action in actions:
                    env.step(action)
                out.append((time.perf_counter() - started) / steps * 1e3)
    env.close()
    return times


def episodes(task_key: str, rounds: int) -> dict:
    case = find_case(load_catalog(paths.catalog_path()), f"{task_key}/normal")
    run_episode(case, 1, OraclePolicy(), EpisodeSettings(render=False))  # builds the env, compiles numba
    times: dict[str, list[float]] = {"robosuite": [], **{k: [] for k in AGAINST}, "split+lean": []}
    for _ in range(rounds):
        for name, out in times.items():
            with variant(name):
                started = time.perf_counter()
                row = run_episode(case, 1, OraclePolicy(), EpisodeSettings(render=False))
                out.append(time.perf_counter() - started)
    return {**times, "steps": row["steps"]}


def _ratio(times: dict, slow: str, fast: str) -> float:
    """Median over rounds of each round's slow / fast time (neighbours in time: the machine's load cancels)."""
    return float(np.median(np.array(times[slow]) / np.array(times[fast])))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", action="append", required=True, help="task key, e.g. libero_goal-03 (repeatable)")
    parser.add_argument("--steps", type=int, default=60, help="control steps per variant and round")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--episodes", type=int, default=3, help="rounds of oracle episodes (0: none)")
    parser.add_argument("--against", help="git revision whose arm control runs beside this tree's (split+lean@REV)")
    parser.add_argument("--json", help="write the raw times here")
    args = parser.parse_args()
    osc_kernel.KERNEL_AFTER_STEPS = 0  # the steady state: the kernel from the first step, not after 2,000
    if args.against:
        AGAINST[f"split+lean@{args.against}"] = load_arm_control(args.against)
    old = next(iter(AGAINST), None)
    raw = {}
    columns = ["robosuite", "split", *AGAINST, "split+lean numpy", "split+lean"]
    print(
        "| task | "
        + " | ".join(f"{c} ms/step" for c in columns)
        + " | robosuite / split+lean"
        + (f" | {old} / split+lean" if old else "")
        + " | split+lean numpy / split+lean"
        + " | episode s: "
        + " / ".join(c for c in columns if c not in ("split", "split+lean numpy"))
        + " | ratios |"
    )
    print("|---|" + "---:|" * (len(columns) + 2 + bool(old)) + "---|---|")
    for key in args.task:
        steps = control_steps(key, args.steps, args.rounds)
        med = {k: float(np.median(v)) for k, v in steps.items()}
        eps = episodes(key, args.episodes) if args.episodes else None
        raw[key] = {"control_step_ms": steps, "episode_s": eps}
        ep, ep_ratio = "-", "-"
        if eps:
            names = [c for c in columns if c in eps]
            ep = " / ".join(f"{float(np.median(eps[c])):.2f}" for c in names) + f" ({eps['steps']} steps)"
            ep_ratio = " / ".join(f"{_ratio(eps, c, 'split+lean'):.3f}" for c in names[:-1])
        cells = " | ".join(f"{med[c]:.2f}" for c in columns)
        ratios = (
            f"{_ratio(steps, 'robosuite', 'split+lean'):.2f}"
            + (f" | {_ratio(steps, old, 'split+lean'):.3f}" if old else "")
            + f" | {_ratio(steps, 'split+lean numpy', 'split+lean'):.3f}"
        )
        print(f"| {key} | {cells} | {ratios} | {ep} | {ep_ratio} |", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(raw, f, indent=1)


if __name__ == "__main__":
    main()
