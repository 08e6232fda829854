"""Register a LIBERO-VPro pack inside any LIBERO installation: one call, then the fork's own code
runs the pack's scenes unchanged.

    import vpro_libero_fork                      # shipped at the root of every pack
    vpro_libero_fork.register("/path/to/pack")   # or vpro_assets.packs.fork_runtime.register(...)

    from libero.libero import benchmark
    suite = benchmark.get_benchmark_dict()["vpro_task_relevant_distractors"]()
    bddl = suite.get_task_bddl_file_path(0)       # or get_libero_path("bddl_files")/task.problem_folder/task.bddl_file
    init_states = suite.get_task_init_states(0)   # LIBERO's torch.load of the pack's .pruned_init

What `register` does, all or nothing (every clash is found before anything is registered):
- each generated object of the pack (deformed targets, recoloured distractors, visual-only
  copies) becomes a `MujocoXMLObject` subclass in LIBERO's `OBJECTS_DICT` under its own name;
- each suite of the pack (one per category) becomes a `Benchmark` subclass in LIBERO's
  `BENCHMARK_MAPPING`, its tasks in pack order, each task's language the base task's instruction.
A name already registered for something else (one of LIBERO's objects or suites, or another
pack's) is refused with `PackRegistrationError` and the registries are left as they were;
registering the same pack again is a no-op.

Observation-level cases (masking, corruption, view loss, staleness, contradiction, prediction
feedback) are applied around the fork's own env:

    env = vpro_libero_fork.wrap(env, case)        # case dict, the pack's case JSON path, or a case id
    for trial in range(10):
        obs = vpro_libero_fork.reset(env, case, trial, init_states)   # seed, reset, initial state
        ...                                                           # the fork's loop, unchanged

`reset` seeds LIBERO's global numpy stream with the trial's seed (`env.seed`, as the toolkit's
rollouts do) before the reset, so fixtures land where the frozen scenes were settled.

Before trusting a number, a fork learns which cases its simulator starts differently (objects
moved, tilted, joints changed beyond the tolerances of `vpro drift`) from the fingerprints the
pack carries:

    report = vpro_libero_fork.verify("/path/to/pack", simulate=True)   # report["drifted"]: case ids
    python -m vpro_libero_fork verify /path/to/pack --simulate          # table; exit 1 on drift

This module is the pack runtime's face; its parts are `fork_registry` (register, unregister),
`fork_env` (wrap, reset) and `fork_drift` (verify). In a pack this file is `vpro_libero_fork.py`,
next to the private package holding those parts and the toolkit's own perturbation code, copied
by `vpro_assets.packs.vendor` with its imports renamed (this file's included), so a fork needs neither the toolkit nor its pins: numpy, mujoco, cv2 and scipy (robosuite's
dependencies), LIBERO and robosuite. Nothing here writes a file, reads the toolkit's config or
LIBERO's, except that `register` extracts an archive beside it. The task's problem_folder is the
absolute path of the pack's suite folder, which `os.path.join` and `pathlib` both let replace the
fork's `bddl_files` root.
"""

from __future__ import annotations

import argparse
import sys

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.settled import simulator_label, summary_lines, table_lines
from vpro_assets.packs.fork_drift import NOT_FINGERPRINTED, verify
from vpro_assets.packs.fork_env import ForkEnv, load_case, pack_root, reset, wrap
from vpro_assets.packs.fork_registry import (
    MANIFEST,
    SUPPORTED_SCHEMA,
    PackRegistrationError,
    check_files,
    read_manifest,
    register,
    unregister,
)

__all__ = [
    "MANIFEST",
    "SUPPORTED_SCHEMA",
    "ForkEnv",
    "PackRegistrationError",
    "check_files",
    "load_case",
    "pack_root",
    "read_manifest",
    "register",
    "reset",
    "unregister",
    "verify",
    "wrap",
]


def main(argv: list[str] | None = None) -> int:
    """`python -m vpro_libero_fork verify PACK [--simulate]`: 0 when the pack matches its manifest
    (and, with --simulate, no case drifted or went unchecked), 1 otherwise, 2 on unusable input."""
    parser = argparse.ArgumentParser(
        prog="python -m vpro_libero_fork", description="The pack runtime of a LIBERO-VPro pack."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("verify", help="check the pack's files; --simulate: re-settle its cases here")
    p.add_argument("pack", help="the pack folder or archive")
    p.add_argument(
        "--simulate",
        action="store_true",
        help="settle each fingerprinted case here and compare with the pack's fingerprints",
    )
    p.add_argument("--case", action="append", default=None, metavar="ID", help="only this case (repeatable)")
    p.add_argument("--trials", type=int, default=None, help="trials per case, from the first (default: all)")
    p.add_argument("--fingerprints", default=None, metavar="FILE", help="another fingerprint file than the pack's")
    args = parser.parse_args(argv)
    try:
        report = verify(
            args.pack,
            simulate=args.simulate,
            fingerprints=args.fingerprints,
            cases=args.case,
            trials=args.trials,
            progress=lambda case: print(f"settling {case}", file=sys.stderr),
        )
    except (PackRegistrationError, InvalidParameterError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{report['pack']}: {report['files']} files match the manifest")
    if args.simulate:
        print(
            f"fingerprints: {simulator_label(report['fingerprint_simulator'])}; "
            f"this environment: {simulator_label(report['simulator'])}"
        )
        print("\n".join(table_lines(report["rows"])))
        print("\n".join(summary_lines(report["rows"])))
        skipped = [r["case"] for r in report["rows"] if r["status"] == NOT_FINGERPRINTED]
        if skipped:
            print(f"{len(skipped)} case(s) carry no fingerprint in this pack, not checked: {' '.join(skipped)}")
    return 0 if report["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
