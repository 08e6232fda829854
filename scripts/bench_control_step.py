"""Split substeps against robosuite's own substep loop, side by side in one process.

Three ways through LIBERO's control step (observables, reward and success included, render-free):
- `robosuite`: robosuite 1.4's loop per substep: mj_forward, the controllers (whose update runs
  mj_forward again), mj_step (a third forward inside);
- `split`: mj_step1, robosuite's controllers with their forward skipped, mj_step2;
- `split+lean`: the same, with the arm control between policy steps from `libero.arm_control`
  (the toolkit's step).
Each round times `--steps` control steps of every variant in turn on one env (a seeded sequence of
arm motions and gripper commands); then `--episodes` render-free oracle episodes (trial 1 of the
task's Normal baseline) with robosuite's loop and with the toolkit's step, alternating. Ratios are
medians over rounds of the same minute, so a loaded machine slows both sides alike.

    .venv/bin/python scripts/bench_control_step.py --task libero_goal-03 --task libero_spatial-00
"""

from __future__ import annotations  # noqa: I001 (vpro_assets before numpy: its import pins the kernels)

import argparse
import contextlib
import json
import time

import vpro_assets  # noqa: F401
import numpy as np

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.libero import arm_control, physics
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.env import libero_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy
from vpro_assets.scene import sim

SPLIT = physics._substeps
ARMS = arm_control.Arms.of


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
    try:
        yield
    finally:
        physics._substeps, arm_control.Arms.of = SPLIT, ARMS


def control_steps(task_key: str, steps: int, rounds: int) -> dict:
    task = get_task(task_key)
    env = sim.physics_env(str(libero_bridge.bddl_path(task.suite, task.name)))
    sim.place_fixtures(env, 0)
    env.set_init_state(libero_init_states(task)[0])
    rng = np.random.default_rng(0)
    actions = [np.concatenate([rng.uniform(-0.3, 0.3, 6), [1.0 if (i // 30) % 2 else -1.0]]) for i in range(steps)]
    times: dict[str, list[float]] = {"robosuite": [], "split": [], "split+lean": []}
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
    times: dict[str, list[float]] = {"robosuite": [], "split+lean": []}
    for _ in range(rounds):
        for name, out in times.items():
            with variant(name):
                started = time.perf_counter()
                row = run_episode(case, 1, OraclePolicy(), EpisodeSettings(render=False))
                out.append(time.perf_counter() - started)
    return {**times, "steps": row["steps"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", action="append", required=True, help="task key, e.g. libero_goal-03 (repeatable)")
    parser.add_argument("--steps", type=int, default=60, help="control steps per variant and round")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--episodes", type=int, default=3, help="rounds of oracle episodes (0: none)")
    parser.add_argument("--json", help="write the raw times here")
    args = parser.parse_args()
    raw = {}
    print(
        "| task | robosuite ms/step | split | split+lean | ratio split+lean | episode s robosuite / toolkit | ratio |"
    )
    print("|---|---:|---:|---:|---:|---|---:|")
    for key in args.task:
        steps = control_steps(key, args.steps, args.rounds)
        med = {k: float(np.median(v)) for k, v in steps.items()}
        eps = episodes(key, args.episodes) if args.episodes else None
        raw[key] = {"control_step_ms": steps, "episode_s": eps}
        ep = "-"
        ep_ratio = "-"
        if eps:
            a, b = float(np.median(eps["robosuite"])), float(np.median(eps["split+lean"]))
            ep, ep_ratio = f"{a:.2f} / {b:.2f} ({eps['steps']} steps)", f"{a / b:.2f}"
        print(
            f"| {key} | {med['robosuite']:.1f} | {med['split']:.1f} | {med['split+lean']:.1f} | "
            f"{med['robosuite'] / med['split+lean']:.2f} | {ep} | {ep_ratio} |",
            flush=True,
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(raw, f, indent=1)


if __name__ == "__main__":
    main()
