"""Certificate throughput of two checkouts side by side: render-free oracle episodes per hour.

`vpro certify` runs the oracle render-free through the episode runner, one episode after another
in each worker, the env of a case kept between its trials. This script starts one such worker per
checkout (`PYTHONPATH=<tree>`: each imports that tree's `vpro_assets`) and runs every episode of
the selection (cases x trials, in order) in both, one episode at a time, the order alternating
(A then B, B then A, ...): the two runs of an episode lie seconds apart, so a loaded machine slows
both alike, and the paired ratios show the spread. Per episode: wall and CPU seconds (the first
trial of a case includes building its env, as in a certify worker). Every episode's success,
steps, final-state fingerprint, phase timeline and contact summary are compared across the
checkouts, and with the committed certificate where it has the trial: a speed-up must not change
what the oracle does.

    .venv/bin/python scripts/bench_oracle_trees.py --tree /path/to/old --tree . \\
        --select libero_spatial-04/normal --select libero_10-00/normal --trials 3

A scene case must be built in both checkouts (`vpro build`).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

KEEP = ("success", "steps", "final_state", "phase_timeline", "contact")


def serve() -> None:
    """A worker: reads `case_id trial` lines, runs each episode, answers with one JSON line."""
    import vpro_assets  # noqa: F401  (first: pins numpy's kernels)
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.rollout.episode import EpisodeSettings, run_episode
    from vpro_assets.rollout.policies.oracle.policy import OraclePolicy

    catalog = load_catalog(paths.catalog_path())
    policy = OraclePolicy()
    print(json.dumps({"ready": str(paths.REPO_ROOT)}), flush=True)
    for line in sys.stdin:
        case_id, trial = line.split()
        wall, cpu = time.perf_counter(), time.process_time()
        row = run_episode(find_case(catalog, case_id), int(trial), policy, EpisodeSettings(render=False))
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        print(json.dumps({"wall": wall, "cpu": cpu, **{k: row[k] for k in KEEP}}), flush=True)


class Worker:
    def __init__(self, tree: Path):
        env = dict(os.environ, PYTHONPATH=str(tree))
        self.proc = subprocess.Popen(
            [sys.executable, __file__, "--serve"],
            env=env,
            cwd=tree,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        self.root = json.loads(self._read())["ready"]

    def _read(self) -> str:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"worker of {self.proc.args} ended (exit {self.proc.wait()})")
        return line

    def run(self, case_id: str, trial: int) -> dict:
        assert self.proc.stdin is not None
        self.proc.stdin.write(f"{case_id} {trial}\n")
        self.proc.stdin.flush()
        return json.loads(self._read())

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait()


def certificate_trials(tree: Path) -> dict[tuple[str, int], tuple[int, str]]:
    path = tree / "solvability.json"
    if not path.is_file():
        return {}
    out = {}
    for case_id, entry in json.loads(path.read_text())["cases"].items():
        for k, trial in enumerate(entry.get("trial_ids", [])):
            out[(case_id, trial)] = (entry["steps"][k], entry["final_state"][k])
    return out


def _quartiles(xs: list[float]) -> str:
    q = statistics.quantiles(xs, n=4) if len(xs) > 1 else [xs[0]] * 3
    return f"median {q[1]:.2f} (quartiles {q[0]:.2f}-{q[2]:.2f}, range {min(xs):.2f}-{max(xs):.2f})"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tree", action="append", type=Path, default=[], help="a checkout (twice: A, then B)")
    p.add_argument("--select", action="append", default=[], metavar="CASE_ID", help="case id (repeatable)")
    p.add_argument("--trials", type=int, default=3, help="trials 0..N-1 of every case (default 3)")
    p.add_argument("--json", type=Path, help="write every episode's figures here")
    p.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.serve:
        serve()
        return 0
    if len(args.tree) != 2 or not args.select:
        p.error("give two --tree and at least one --select")
    trees = [t.resolve() for t in args.tree]
    workers = [Worker(t) for t in trees]
    recorded = certificate_trials(trees[0])
    pairs, differ, certified = [], [], 0
    try:
        for n, (case_id, trial) in enumerate((c, t) for c in args.select for t in range(args.trials)):
            order = (0, 1) if n % 2 == 0 else (1, 0)
            got: dict[int, dict] = {i: workers[i].run(case_id, trial) for i in order}
            a, b = got[0], got[1]
            if any(a[k] != b[k] for k in KEEP):
                differ.append((case_id, trial, [k for k in KEEP if a[k] != b[k]]))
            if (case_id, trial) in recorded:
                certified += 1
                if recorded[(case_id, trial)] != (a["steps"], a["final_state"]):
                    differ.append((case_id, trial, ["certificate"]))
            pairs.append({"case": case_id, "trial": trial, "A": a, "B": b})
            print(
                f"{case_id} t{trial}: {a['steps']} steps, CPU {a['cpu']:.2f} / {b['cpu']:.2f} s "
                f"({a['cpu'] / b['cpu']:.2f}x), wall {a['wall']:.2f} / {b['wall']:.2f} s",
                flush=True,
            )
    finally:
        for w in workers:
            w.close()
    print(f"A = {trees[0]}, B = {trees[1]}")
    print(
        f"identity: {len(pairs)} episodes compared A/B ({certified} also with the certificate): "
        f"{len(differ)} differ {differ[:10]}"
    )
    for what in ("wall", "cpu"):
        ta, tb = (sum(x[s][what] for x in pairs) for s in "AB")
        ratios = [x["A"][what] / x["B"][what] for x in pairs]
        print(
            f"{what}: A {3600 * len(pairs) / ta:.0f} episodes/h, B {3600 * len(pairs) / tb:.0f} episodes/h "
            f"(totals {ta:.0f} / {tb:.0f} s: {ta / tb:.2f}x); per episode A/B {_quartiles(ratios)}"
        )
    print("per case, CPU s per episode A / B (ratio):")
    for case_id in args.select:
        ta, tb = (sum(x[s]["cpu"] for x in pairs if x["case"] == case_id) for s in "AB")
        print(f"  {case_id}: {ta / args.trials:.2f} / {tb / args.trials:.2f} ({ta / tb:.2f}x)")
    if args.json:
        args.json.write_text(json.dumps({"trees": [str(t) for t in trees], "pairs": pairs}, indent=1))
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
