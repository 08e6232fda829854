"""Episodes per hour through vla-eval against `vpro eval`, on the same cases, side by side.

Each round runs the same episodes twice, alternating the order from round to round so a change of
load on the machine falls on both paths:
- `vpro eval --policy noop` (the policy in-process, queried once per chunk);
- `vla-eval run --no-docker` with `ScriptedModelServer` answering LIBERO's no-op, one websocket round
  trip per step with both views PNG-encoded, as every vla-eval model server is driven.
The no-op never succeeds, so every episode runs the suite's full step limit (220 for libero_spatial).
Reported: wall time of each command (process start, env build, episodes) and the mean per-episode
time each path records (its own `wall_time`: env reset, wait steps and policy steps).

    nice -n 10 .venv/bin/python scripts/bench_vla_eval.py --rounds 2 --out out/bench/vla-eval
"""
from __future__ import annotations

import argparse
import json
import os
import socket
import sqlite3
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import yaml

BENCHMARK = "vpro_assets.integrations.vla_eval.benchmark:LiberoVProBenchmark"
CASES = ["libero_spatial-00/normal", "libero_spatial-00/camera_staleness/wrist-delay2-v1"]
BIN = Path(sys.executable).parent


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(log: Path) -> tuple[subprocess.Popen, str]:
    port = free_port()
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "vpro_assets.integrations.vla_eval.server", "--host",
                                 "127.0.0.1", "--port", str(port)], stdout=out, stderr=subprocess.STDOUT)
    for _ in range(400):
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/health", timeout=2):
                return proc, f"ws://127.0.0.1:{port}"
        except OSError:
            time.sleep(0.3)
    proc.kill()
    raise SystemExit(f"model server did not start; see {log}")


def run_vpro(out: Path, trials: int) -> tuple[float, list[float]]:
    db = out / "vpro.sqlite"
    cmd = [str(BIN / "vpro"), "eval", "--policy", "noop", "--trials", str(trials), "--workers", "1", "--results", str(db)]
    for c in CASES:
        cmd += ["--select", c]
    t0 = time.monotonic()
    subprocess.run(cmd, check=True, capture_output=True)
    wall = time.monotonic() - t0
    con = sqlite3.connect(db)
    times = [r[0] for r in con.execute("SELECT wall_time FROM episodes WHERE status = 'ok'")]
    con.close()
    return wall, times


def run_vla(out: Path, url: str, trials: int) -> tuple[float, list[float]]:
    config = out / "config.yaml"
    config.write_text(yaml.safe_dump({"benchmarks": [{"benchmark": BENCHMARK, "subname": "bench", "mode": "sync",
                                                      "episodes_per_task": trials, "params": {"select": CASES}}]}))
    t0 = time.monotonic()
    subprocess.run([str(BIN / "vla-eval"), "run", "--no-docker", "-c", str(config), "--server-url", url,
                    "--output-dir", str(out / "results")], check=True, capture_output=True)
    wall = time.monotonic() - t0
    db = next((out / "results").glob("recording-*.sqlite"))
    con = sqlite3.connect(db)
    times = [json.loads(m)["wall_time"] for (m,) in con.execute("SELECT metrics FROM episode_results WHERE status != 'error'")]
    con.close()
    return wall, times


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--trials", type=int, default=1, help="trials per case per round")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    server, url = start_server(args.out / "server.log")
    rows = []
    try:
        for rnd in range(args.rounds):
            order = ["vpro", "vla"] if rnd % 2 == 0 else ["vla", "vpro"]
            for path in order:
                d = args.out / f"round{rnd}-{path}"
                d.mkdir(parents=True, exist_ok=False)
                load = os.getloadavg()[0]
                wall, times = run_vpro(d, args.trials) if path == "vpro" else run_vla(d, url, args.trials)
                rows.append({"round": rnd, "path": path, "wall": wall, "episodes": len(times), "episode_times": times,
                             "load_before": load})
                print(json.dumps(rows[-1]), flush=True)  # noqa: T201
    finally:
        server.terminate()
        server.wait(timeout=20)
    summary = {}
    for path in ("vpro", "vla"):
        mine = [r for r in rows if r["path"] == path]
        wall = sum(r["wall"] for r in mine)
        eps = sum(r["episodes"] for r in mine)
        ep_times = [t for r in mine for t in r["episode_times"]]
        summary[path] = {"episodes": eps, "wall_s": round(wall, 1), "episodes_per_hour_wall": round(3600 * eps / wall, 1),
                         "mean_episode_s": round(sum(ep_times) / len(ep_times), 2),
                         "episodes_per_hour_episode_time": round(3600 * len(ep_times) / sum(ep_times), 1)}
    summary["ratio_wall_vla_over_vpro"] = round(summary["vla"]["wall_s"] / summary["vpro"]["wall_s"], 4)
    summary["ratio_episode_vla_over_vpro"] = round(summary["vla"]["mean_episode_s"] / summary["vpro"]["mean_episode_s"], 4)
    (args.out / "summary.json").write_text(json.dumps({"rounds": rows, "summary": summary}, indent=1))
    print(json.dumps(summary, indent=1))  # noqa: T201
    return 0


if __name__ == "__main__":
    sys.exit(main())
