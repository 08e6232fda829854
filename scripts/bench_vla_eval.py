"""Episodes per hour through vla-eval against `vpro eval`, on the same cases, side by side.

Both paths run the same episodes at the same time (one process tree each, competing for the same
cores), and each path's cost is the CPU time of its processes, sampled with psutil until they exit
(on a machine shared with other work, wall time measures the scheduler, CPU time the work):
- `vpro eval --policy noop` (the policy in-process, queried once per chunk), its CLI and worker;
- `vla-eval run --no-docker` and `ScriptedModelServer` answering LIBERO's no-op: one websocket
  round trip per step with both views PNG-encoded (vla-eval's default), as every vla-eval model
  server is driven; the server's CPU counts for vla-eval;
- the same with `params.image_format: raw` (images sent unencoded).
The no-op never succeeds, so every episode runs the suite's full step limit (220 for libero_spatial).
Episodes per hour are per core: 3600 / (CPU seconds per episode).

    nice -n 10 .venv/bin/python scripts/bench_vla_eval.py --rounds 1 --out out/bench/vla-eval
"""

from __future__ import annotations

import argparse
import contextlib
import json
import socket
import sqlite3
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import psutil
import yaml

BENCHMARK = "vpro_assets.integrations.vla_eval.benchmark:LiberoVProBenchmark"
CASES = ["libero_spatial-00/normal", "libero_spatial-00/camera_staleness/wrist-delay2-v1"]
BIN = Path(sys.executable).parent
PATHS = ("vpro", "vla", "vla-raw")  # vla: vla-eval's default PNG images; vla-raw: params.image_format raw


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(log: Path) -> tuple[subprocess.Popen, str]:
    port = free_port()
    with open(log, "w") as out:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "vpro_assets.integrations.vla_eval.server",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
            ],
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    for _ in range(400):
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/health", timeout=2):
                return proc, f"ws://127.0.0.1:{port}"
        except OSError:
            time.sleep(0.3)
    proc.kill()
    raise SystemExit(f"model server did not start; see {log}")


def cpu_seconds(proc: psutil.Process) -> float:
    t = proc.cpu_times()
    return t.user + t.system


class Tree:
    """CPU seconds of a process and all its descendants, sampled until the root exits."""

    def __init__(self, popen: subprocess.Popen):
        self.popen, self.root = popen, psutil.Process(popen.pid)
        self.seen: dict[int, float] = {}
        self.started, self.ended = time.monotonic(), None

    def sample(self) -> None:
        try:
            procs = [self.root, *self.root.children(recursive=True)]
        except psutil.NoSuchProcess:
            return
        for p in procs:
            with contextlib.suppress(psutil.NoSuchProcess):
                self.seen[p.pid] = max(self.seen.get(p.pid, 0.0), cpu_seconds(p))

    @property
    def cpu(self) -> float:
        return sum(self.seen.values())


def vpro_cmd(out: Path, trials: int) -> list[str]:
    cmd = [
        str(BIN / "vpro"),
        "eval",
        "--policy",
        "noop",
        "--trials",
        str(trials),
        "--workers",
        "1",
        "--results",
        str(out / "vpro.sqlite"),
    ]
    for c in CASES:
        cmd += ["--select", c]
    return cmd


def vla_cmd(out: Path, url: str, trials: int, image_format: str) -> list[str]:
    config = out / "config.yaml"
    params = {"select": CASES, "image_format": image_format}
    config.write_text(
        yaml.safe_dump(
            {
                "benchmarks": [
                    {
                        "benchmark": BENCHMARK,
                        "subname": "bench",
                        "mode": "sync",
                        "episodes_per_task": trials,
                        "params": params,
                    }
                ]
            }
        )
    )
    return [
        str(BIN / "vla-eval"),
        "run",
        "--no-docker",
        "-c",
        str(config),
        "--server-url",
        url,
        "--output-dir",
        str(out / "results"),
    ]


def episodes(path: str, out: Path) -> list[dict]:
    if path == "vpro":
        con = sqlite3.connect(out / "vpro.sqlite")
        rows = [
            {"case": c, "steps": n, "status": s}
            for c, n, s in con.execute("SELECT case_id, steps, status FROM episodes")
        ]
    else:
        con = sqlite3.connect(next((out / "results").glob("recording-*.sqlite")))
        rows = [
            {"case": json.loads(m).get("case_id"), "steps": n, "status": s}
            for m, n, s in con.execute("SELECT metrics, steps, status FROM episode_results")
        ]
    con.close()
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--trials", type=int, default=1, help="trials per case per round")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    server, url = start_server(args.out / "server.log")
    sproc = psutil.Process(server.pid)
    rows = []
    try:
        for rnd in range(args.rounds):
            dirs = {p: args.out / f"round{rnd}-{p}" for p in PATHS}
            for d in dirs.values():
                d.mkdir(parents=True, exist_ok=False)
            server_cpu0 = cpu_seconds(sproc)
            logs = {p: open(dirs[p] / "log.txt", "w") for p in dirs}  # noqa: SIM115 - closed below
            cmds = {
                "vpro": vpro_cmd(dirs["vpro"], args.trials),
                "vla": vla_cmd(dirs["vla"], url, args.trials, "png"),
                "vla-raw": vla_cmd(dirs["vla-raw"], url, args.trials, "raw"),
            }
            trees = {p: Tree(subprocess.Popen(cmds[p], stdout=logs[p], stderr=subprocess.STDOUT)) for p in PATHS}
            while any(t.ended is None for t in trees.values()):
                for t in trees.values():
                    if t.ended is None:
                        t.sample()
                        if t.popen.poll() is not None:
                            t.ended = time.monotonic()
                time.sleep(0.5)
            for f in logs.values():
                f.close()
            server_cpu = cpu_seconds(sproc) - server_cpu0
            for path, t in trees.items():
                if t.popen.returncode != 0:
                    raise SystemExit(f"{path} failed; see {dirs[path] / 'log.txt'}")
                eps = episodes(path, dirs[path])
                # the server's CPU, shared by the two vla-eval runs, is counted in full against each
                cpu = t.cpu + (server_cpu if path != "vpro" else 0.0)
                rows.append(
                    {
                        "round": rnd,
                        "path": path,
                        "wall_s": round(t.ended - t.started, 1),
                        "cpu_s": round(cpu, 1),
                        "server_cpu_s": round(server_cpu, 1) if path != "vpro" else None,
                        "episodes": eps,
                    }
                )
                print(json.dumps(rows[-1]), flush=True)  # noqa: T201
    finally:
        server.terminate()
        server.wait(timeout=20)
    summary: dict = {}
    for path in PATHS:
        mine = [r for r in rows if r["path"] == path]
        n = sum(len(r["episodes"]) for r in mine)
        steps = sum(e["steps"] or 0 for r in mine for e in r["episodes"])
        cpu = sum(r["cpu_s"] for r in mine)
        summary[path] = {
            "episodes": n,
            "policy_steps": steps,
            "cpu_s": round(cpu, 1),
            "cpu_s_per_episode": round(cpu / n, 2),
            "episodes_per_cpu_hour": round(3600 * n / cpu, 1),
            "wall_s": round(sum(r["wall_s"] for r in mine), 1),
        }
    for path in PATHS[1:]:
        summary[f"cpu_ratio_{path}_over_vpro"] = round(summary[path]["cpu_s"] / summary["vpro"]["cpu_s"], 4)
    (args.out / "summary.json").write_text(json.dumps({"rounds": rows, "summary": summary}, indent=1))
    print(json.dumps(summary, indent=1))  # noqa: T201
    return 0


if __name__ == "__main__":
    sys.exit(main())
