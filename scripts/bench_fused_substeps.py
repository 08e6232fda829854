"""The fused substeps (`libero.fused_substeps`) against the split step's Python loop, side by side in
one process, with `osc_kernel`'s kernel on both sides (compiled before the first round).

Per task and round, in alternating order:
- `--steps` physics-only control steps (`physics.physics_step`, the build's settling and `vpro
  validate`'s drift check) of the zero action from the task's first initial state, old then new
  (new then old in odd rounds), each block from the same state;
- one render-free oracle episode of the task's Normal case (`--trial`), unobserved steps as
  `vpro eval --no-render` and the certificate run them (the episode's start not timed).
The fused path is switched off by making `Arms.fused_substeps` decline. Reports control steps per
second, old and new, and the median of per-round ratios (a loaded machine slows both alike); every
oracle episode's final state is checked equal between the two (bit for bit).

    .venv/bin/python scripts/bench_fused_substeps.py --task libero_spatial-00 --task libero_goal-03
"""

from __future__ import annotations  # noqa: I001 (vpro_assets before numpy: its import pins the kernels)

import argparse
import json
import statistics
import time

import vpro_assets  # noqa: F401
import numpy as np

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.libero import arm_control, fused_substeps, osc_kernel, physics
from vpro_assets.libero.env import libero_init_states, make_env
from vpro_assets.libero.settled import seeded_reset
from vpro_assets.libero.tasks import get_task
from vpro_assets.rollout.episode import EpisodeSession, EpisodeSettings
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy

FUSED = arm_control.Arms.fused_substeps


def use_fused(on: bool) -> None:
    arm_control.Arms.fused_substeps = FUSED if on else (lambda self, action, count: False)  # type: ignore[method-assign]


def zero_action_block(env, init_state, steps: int) -> float:
    """Seconds of `steps` physics-only control steps of the zero action from `init_state`."""
    env.set_init_state(init_state)
    action = np.zeros(7)
    started = time.perf_counter()
    for _ in range(steps):
        physics.physics_step(env, action)
    return time.perf_counter() - started


def oracle_episode(case: dict, trial: int) -> tuple[int, float, bytes]:
    """Steps, seconds and final state (qpos, qvel, act, ctrl, qacc_warmstart bytes) of one episode."""
    session = EpisodeSession(case, trial, EpisodeSettings(render=False), observe=False)
    policy = OraclePolicy()
    policy.reset(None)
    session.start(on_reset=policy.bind_env)
    started = time.perf_counter()
    while not session.finished:
        session.step(policy.next_action())
    seconds = time.perf_counter() - started
    data = session.env.sim.data._data
    state = b"".join(a.tobytes() for a in (data.qpos, data.qvel, data.act, data.ctrl, data.qacc_warmstart))
    steps = session.steps
    session.close()
    return steps, seconds, state


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", action="append", required=True, help="task key, e.g. libero_goal-03")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=100, help="zero-action control steps per block")
    parser.add_argument("--trial", type=int, default=1, help="trial of the Normal case for the oracle episodes")
    args = parser.parse_args()
    osc_kernel.KERNEL_AFTER_STEPS = 0
    assert fused_substeps.kernel() is not None, "the kernel is not at hand here"
    catalog = load_catalog(paths.catalog_path())
    rows = []
    for key in args.task:
        task = get_task(key)
        env = make_env(task, render=False)
        seeded_reset(env, 5)
        init_state = libero_init_states(task)[0]
        for on in (False, True):  # compile both paths' kernels and warm up
            use_fused(on)
            zero_action_block(env, init_state, 5)
        zero: dict[bool, list[float]] = {False: [], True: []}
        ratios_zero = []
        for r in range(args.rounds):
            seconds = {}
            for on in (False, True) if r % 2 == 0 else (True, False):
                use_fused(on)
                seconds[on] = zero_action_block(env, init_state, args.steps)
                zero[on].append(args.steps / seconds[on])
            ratios_zero.append(seconds[False] / seconds[True])
        env.close()
        case = find_case(catalog, f"{key}/normal")
        episode: dict[bool, list[float]] = {False: [], True: []}
        ratios_episode, same, steps = [], True, 0
        for r in range(args.rounds):
            seconds, states = {}, {}
            for on in (False, True) if r % 2 == 0 else (True, False):
                use_fused(on)
                steps, seconds[on], states[on] = oracle_episode(case, args.trial)
                episode[on].append(steps / seconds[on])
            ratios_episode.append(seconds[False] / seconds[True])
            same = same and states[False] == states[True]
        use_fused(True)
        row = {
            "task": key,
            "zero_action_steps_per_s": {"old": statistics.median(zero[False]), "new": statistics.median(zero[True])},
            "zero_action_ratio": statistics.median(ratios_zero),
            "zero_action_ratio_range": [min(ratios_zero), max(ratios_zero)],
            "oracle_steps": steps,
            "oracle_steps_per_s": {"old": statistics.median(episode[False]), "new": statistics.median(episode[True])},
            "oracle_ratio": statistics.median(ratios_episode),
            "oracle_ratio_range": [min(ratios_episode), max(ratios_episode)],
            "oracle_final_states_equal": same,
        }
        rows.append(row)
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
