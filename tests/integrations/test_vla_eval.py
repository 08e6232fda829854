"""LIBERO-VPro inside vla-eval (issue 17): `vla-eval run --no-docker` against a model server on
vla-eval's own base class (`ScriptedModelServer`, started by the test on a free loopback port).

Default run: the shipped smoke config (a Normal case and an observation case) completes, records a
result per episode, the server's observations equal the in-process path's byte for byte after
vla-eval's LIBERO preprocessing, the same actions give the same outcome and final state, and
`vpro report` writes the tables from the results directory; bad configs fail in one line.
`-m slow`: a scene case, the oracle's full episode replayed, two shards, a server that drops the
connection mid-episode.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sqlite3
import subprocess
import sys
import time
import urllib.request
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("vla_eval", reason="the vla-eval extra: pip install 'libero-vpro[vla-eval]' (make setup does)")

from vla_eval.benchmarks.libero.utils import preprocess_libero_image  # noqa: E402
from vla_eval.rotation import quat_to_axisangle  # noqa: E402

from vpro_assets.benchmark.catalog import find_case, load_catalog  # noqa: E402
from vpro_assets.benchmark.selection import select_cases  # noqa: E402
from vpro_assets.core import paths  # noqa: E402
from vpro_assets.integrations.vla_eval import config_names, config_path  # noqa: E402
from vpro_assets.libero.env import NOOP_ACTION  # noqa: E402
from vpro_assets.report.vla_eval_results import read_vla_eval, to_row  # noqa: E402
from vpro_assets.report.write import write_report  # noqa: E402
from vpro_assets.rollout.episode import EpisodeSettings, run_episode  # noqa: E402
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy  # noqa: E402

VLA_EVAL = str(Path(sys.executable).with_name("vla-eval"))
BENCHMARK = "vpro_assets.integrations.vla_eval.benchmark:LiberoVProBenchmark"
NORMAL = "libero_spatial-00/normal"
OBSERVATION = "libero_spatial-00/camera_staleness/wrist-delay2-v1"
SCENE = "libero_spatial-00/task_relevant_distractors/same_color-v1"
CAMS = {"agentview": "agentview", "wrist": "robot0_eye_in_hand"}  # vla-eval key -> LIBERO camera


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def model_server(log: Path, **args):
    """ScriptedModelServer in its own process on a free loopback port; yields its ws:// URL."""
    port = _free_port()
    cmd = [sys.executable, "-m", "vpro_assets.integrations.vla_eval.server", "--host", "127.0.0.1", "--port", str(port)]
    cmd += [f"--args.{k}={v}" for k, v in args.items()]
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/health", timeout=2) as r:
                    if r.status == 200:
                        break
            except OSError:
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"model server did not start: {log.read_text()[-2000:]}")
            time.sleep(0.3)
        yield f"ws://127.0.0.1:{port}"
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def vla_eval_run(config: Path, url: str, out: Path, *extra: str, env: dict | None = None, background: bool = False):
    cmd = [VLA_EVAL, "run", "--no-docker", "-c", str(config), "--server-url", url, "--output-dir", str(out), *extra]
    if background:
        return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=1800, env=env)


def write_config(path: Path, select: list[str], episodes: int = 1, max_steps: int | None = None, **more) -> Path:
    params: dict = {"select": select, **more}
    if max_steps is not None:
        params["max_steps"] = max_steps
    path.write_text(
        yaml.safe_dump(
            {
                "server": {"url": "ws://127.0.0.1:1", "timeout": 120},
                "benchmarks": [
                    {
                        "benchmark": BENCHMARK,
                        "subname": "test",
                        "mode": "sync",
                        "episodes_per_task": episodes,
                        "params": params,
                    }
                ],
            }
        )
    )
    return path


def scripted_actions(n: int, seed: int = 0) -> np.ndarray:
    """A deterministic, non-trivial action sequence (gripper -1/+1, as vla-eval's LIBERO sends it)."""
    rng = np.random.default_rng(seed)
    actions = np.concatenate([rng.uniform(-0.6, 0.6, (n, 6)), np.where(rng.random((n, 1)) < 0.5, -1.0, 1.0)], axis=1)
    return actions.astype(np.float32)


class Replay:
    """In-process policy (`vpro eval`'s protocol): the given actions, one per step; keeps what it saw."""

    policy_id, replan_steps, predicts_frames = "replay", 1, False

    def __init__(self, actions: np.ndarray, inner=None):
        self.actions, self.inner, self.seen, self.done = actions, inner, [], []

    def bind_env(self, cenv):
        if self.inner is not None:
            self.inner.bind_env(cenv)

    def reset(self, episode):
        self.seen, self.done = [], []
        if self.inner is not None:
            self.inner.reset(episode)

    def act(self, obs):
        self.seen.append(obs)
        if self.inner is not None:
            action = np.asarray(self.inner.act(obs).actions[0], dtype=np.float64)
        else:
            i = len(self.seen) - 1
            action = np.asarray(self.actions[i] if i < len(self.actions) else NOOP_ACTION, dtype=np.float64)
        self.done.append(action)
        return action[None]

    def close(self):
        pass


def case(cid: str) -> dict:
    return find_case(load_catalog(paths.catalog_path()), cid)


def assert_same_episode(received: Path, policy: Replay, vla_metrics: dict, in_process: dict) -> None:
    """The server's observations equal the in-process ones after vla-eval's LIBERO preprocessing,
    byte for byte, at every step; and the episode ended the same way."""
    got = np.load(received)
    n = len(policy.seen)
    assert n == in_process["steps"] == vla_metrics["steps"] and got["image_agentview"].shape[0] == n
    for key, cam in CAMS.items():
        expected = np.stack(
            [
                preprocess_libero_image(
                    np.asarray(o.images[cam]) if o.images[cam] is not None else np.zeros_like(got[f"image_{key}"][0])
                )
                for o in policy.seen
            ]
        )
        assert got[f"image_{key}"].dtype == expected.dtype == np.uint8
        diff = np.flatnonzero((got[f"image_{key}"] != expected).reshape(n, -1).any(axis=1))
        assert diff.size == 0, f"{key} view differs first at step {diff[:1]}"
    states = np.stack([np.concatenate([o.eef_pos, quat_to_axisangle(o.eef_quat), o.gripper_qpos]) for o in policy.seen])
    assert np.array_equal(got["states"], states)
    assert str(got["task_description"]) == policy.seen[0].instruction
    for key in ("success", "steps", "final_state", "seed", "artifact_hashes", "phase_timeline"):
        assert vla_metrics[key] == json.loads(json.dumps(in_process[key])), key
    assert vla_metrics["contact"] == in_process["contact"]["composition"]


def _metrics(results: Path) -> dict[tuple[str, int], dict]:
    db = next(results.glob("recording-*.sqlite"))
    con = sqlite3.connect(db)
    try:
        out = {}
        for metrics, context in con.execute("SELECT metrics, context FROM episode_results"):
            m, c = json.loads(metrics), json.loads(context)
            out[(c["case_id"], c["episode_idx"])] = m
        return out
    finally:
        con.close()


# -- default run --------------------------------------------------------------------------------


def test_shipped_configs_cover_every_category_and_select_cases():
    catalog = load_catalog(paths.catalog_path())
    cats = {c["category"] for c in catalog["cases"]}
    assert set(config_names()) == cats | {"all", "normal", "smoke"}
    for name in config_names():
        cfg = yaml.safe_load(config_path(name).read_text())
        (entry,) = cfg["benchmarks"]
        assert entry["benchmark"] == BENCHMARK
        assert entry["episodes_per_task"] == (1 if name == "smoke" else 10)
        chosen = {c["id"] for c in select_cases(catalog, entry["params"]["select"])}
        if name == "all":
            assert chosen == {c["id"] for c in catalog["cases"] + catalog["normal"]}
        elif name == "normal":
            assert chosen == {c["id"] for c in catalog["normal"]}
        elif name in cats:
            assert chosen == {c["id"] for c in catalog["cases"] if c["category"] == name}
    smoke = yaml.safe_load(config_path("smoke").read_text())["benchmarks"][0]["params"]["select"]
    assert smoke == [NORMAL, OBSERVATION]


def test_smoke_run_records_every_episode_same_as_in_process_and_reports(tmp_path):
    actions = scripted_actions(20)
    np.save(tmp_path / "actions.npy", actions)
    obs_dir, results = tmp_path / "received", tmp_path / "results"
    with model_server(tmp_path / "server.log", actions=tmp_path / "actions.npy", record_dir=obs_dir) as url:
        proc = vla_eval_run(config_path("smoke"), url, results)
    assert proc.returncode == 0, proc.stderr[-3000:]
    metrics = _metrics(results)
    assert set(metrics) == {(NORMAL, 0), (OBSERVATION, 0)}
    assert list(results.glob("*_aggregate.json"))
    for cid in (NORMAL, OBSERVATION):
        m = metrics[(cid, 0)]
        c = case(cid)
        assert (m["case_id"], m["trial"], m["suite"]) == (cid, 0, "libero_spatial")
        assert m.get("setting") == c.get("setting") and m.get("indicator") == c.get("indicator")
        assert m["category"] == c.get("category", "normal") and m.get("dimension") == c.get("dimension")
        policy = Replay(actions)
        ref = run_episode(c, 0, policy, EpisodeSettings(max_steps_override=20))
        assert_same_episode(obs_dir / f"{cid.replace('/', '__')}__t0.npz", policy, m, ref)
    # the exported aggregate JSON gives the same rows as the recording database
    key = ("case_id", "trial", "status", "success", "steps", "final_state", "category", "setting", "indicator")
    _, from_db = read_vla_eval(results)
    _, from_json = read_vla_eval(next(results.glob("*_aggregate.json")))
    assert [tuple(r[k] for k in key) for r in from_db] == [tuple(r[k] for k in key) for r in from_json]
    assert len(from_db) == 2
    written = write_report(results, tmp_path / "report", plots=False)
    md = written["markdown"].read_text()
    assert "ScriptedModelServer" in md and "Camera Staleness" in md and "n=1" in md
    assert written["latex"].is_file()


@pytest.fixture(scope="module")
def noop_server(tmp_path_factory):
    with model_server(tmp_path_factory.mktemp("noop") / "server.log") as url:
        yield url


def _failed_run(tmp_path: Path, server: str, select: list[str], env: dict | None = None, **params) -> tuple[str, str]:
    """vla-eval on a config of `select` (2 steps): it must fail; (the last line of its stderr, all of it)."""
    config = write_config(tmp_path / "c.yaml", select, max_steps=2, **params)
    proc = vla_eval_run(config, server, tmp_path / "results", env=env)
    assert proc.returncode != 0
    return [line for line in proc.stderr.strip().splitlines() if line.strip()][-1], proc.stderr


def test_unknown_case_id_is_one_line_error_naming_closest_ids(tmp_path, noop_server):
    line, stderr = _failed_run(tmp_path, noop_server, ["libero_spatial-00/camera_staleness/wrist-delay2-v2"])
    assert line.startswith("LIBERO-VPro: unknown case, setting")
    assert "'libero_spatial-00/camera_staleness/wrist-delay2-v2'" in line and OBSERVATION in line
    assert "Traceback" not in stderr


def test_unbuilt_scene_case_names_the_build_command(tmp_path, noop_server):
    line, _ = _failed_run(tmp_path, noop_server, [SCENE], env=dict(os.environ, VPRO_OUT=str(tmp_path / "empty-out")))
    assert line.startswith(f"LIBERO-VPro: case {SCENE}: scene not built")
    assert f"run vpro build --select {SCENE}" in line


def test_bad_benchmark_parameter_is_one_line_error(tmp_path, noop_server):
    line, _ = _failed_run(tmp_path, noop_server, [NORMAL], image_format="jpeg")
    assert line == "LIBERO-VPro: params.image_format must be one of png, raw (lossless), got 'jpeg'"


def test_recorded_failures_become_error_and_unavailable_rows():
    base = {
        "task_name": NORMAL,
        "episode_id": 3,
        "sid": "s",
        "context": {
            "name": NORMAL,
            "case_id": NORMAL,
            "suite": "libero_spatial",
            "task": "libero_spatial-00",
            "category": "normal",
            "level": "normal",
            "episode_idx": 3,
        },
    }
    ok = to_row(
        {
            **base,
            "status": "success",
            "metrics": {"success": True, "case_id": NORMAL, "trial": 3, "category": "normal", "steps": 7},
        },
        "r",
        "p",
    )
    assert (ok["status"], ok["success"], ok["trial"], ok["steps"]) == ("ok", True, 3, 7)

    def failed(reason: str, detail: str) -> dict:
        record = {**base, "status": "error", "metrics": {"success": False}}
        return to_row(record | {"failure_reason": reason, "failure_detail": detail}, "r", "p")

    gone = failed("connection_closed", "code=None reason=None")
    assert (gone["status"], gone["success"], gone["case_id"], gone["trial"]) == ("error", None, NORMAL, 3)
    assert gone["error"] == "connection_closed: code=None reason=None"
    unavailable = failed("env_start", "Traceback...\nvpro_assets.rollout.case_env.CaseUnavailableError: x")
    assert unavailable["status"] == "unavailable"


# -- slow ---------------------------------------------------------------------------------------


@pytest.mark.slow
def test_scene_case_same_episode_as_in_process(tmp_path, scene_out, monkeypatch):
    actions = scripted_actions(20, seed=1)
    np.save(tmp_path / "actions.npy", actions)
    config = write_config(tmp_path / "c.yaml", [SCENE], max_steps=20, image_format="png")  # vla-eval's PNG
    env = dict(os.environ, VPRO_OUT=str(scene_out))
    with model_server(tmp_path / "server.log", actions=tmp_path / "actions.npy", record_dir=tmp_path / "rx") as url:
        proc = vla_eval_run(config, url, tmp_path / "results", env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    monkeypatch.setenv("VPRO_OUT", str(scene_out))
    policy = Replay(actions)
    ref = run_episode(case(SCENE), 0, policy, EpisodeSettings(max_steps_override=20))
    m = _metrics(tmp_path / "results")[(SCENE, 0)]
    assert m["level"] == "scene" and m["artifact_hashes"] == ref["artifact_hashes"]
    assert_same_episode(tmp_path / "rx" / f"{SCENE.replace('/', '__')}__t0.npz", policy, m, ref)


@pytest.mark.slow
def test_oracle_full_episode_replayed_through_vla_eval_has_the_same_outcome(tmp_path):
    oracle = Replay(None, inner=OraclePolicy())
    assert run_episode(case(NORMAL), 0, oracle, EpisodeSettings())["success"], "the oracle solves trial 0"
    # vla-eval's model servers send float32 actions (PredictModelServer): the deterministic policy
    # compared on both paths is the oracle's episode in float32, replayed.
    actions = np.asarray(oracle.done, dtype=np.float32)
    assert set(np.unique(actions[:, -1])) <= {-1.0, 1.0}
    np.save(tmp_path / "actions.npy", actions)
    ref = run_episode(case(NORMAL), 0, Replay(actions), EpisodeSettings())
    assert ref["success"]
    config = write_config(tmp_path / "c.yaml", [NORMAL])
    with model_server(tmp_path / "server.log", actions=tmp_path / "actions.npy") as url:
        proc = vla_eval_run(config, url, tmp_path / "results")
    assert proc.returncode == 0, proc.stderr[-3000:]
    m = _metrics(tmp_path / "results")[(NORMAL, 0)]
    assert (m["success"], m["steps"], m["final_state"]) == (True, ref["steps"], ref["final_state"])


@pytest.mark.slow
def test_two_shards_cover_every_episode_once(tmp_path):
    config = write_config(tmp_path / "c.yaml", [NORMAL, OBSERVATION], episodes=2, max_steps=3)
    results = tmp_path / "results"
    with model_server(tmp_path / "server.log") as url:
        shards = [
            vla_eval_run(
                config,
                url,
                results,
                "--shard-id",
                str(i),
                "--num-shards",
                "2",
                "--eval-id",
                "two-shards",
                background=True,
            )
            for i in range(2)
        ]
        outs = [p.communicate(timeout=1800) for p in shards]
    for p, (_, err) in zip(shards, outs, strict=True):
        assert p.returncode == 0, err[-3000:]
    con = sqlite3.connect(results / "recording-two-shards.sqlite")
    try:
        done = Counter(
            (json.loads(c)["case_id"], json.loads(c)["episode_idx"])
            for (c,) in con.execute("SELECT context FROM episode_results")
        )
        by_shard = Counter(sid for (sid,) in con.execute("SELECT sid FROM episode_results"))
    finally:
        con.close()
    assert done == Counter({(c, t): 1 for c in (NORMAL, OBSERVATION) for t in (0, 1)})
    assert sum(by_shard.values()) == 4 and len(by_shard) <= 2
    _, rows = read_vla_eval(results)
    assert sorted((r["case_id"], r["trial"], r["status"]) for r in rows) == sorted(
        (c, t, "ok") for c in (NORMAL, OBSERVATION) for t in (0, 1)
    )


@pytest.mark.slow
def test_server_that_disconnects_mid_episode_is_a_recorded_error_and_the_run_goes_on(tmp_path):
    config = write_config(tmp_path / "c.yaml", [NORMAL, OBSERVATION], max_steps=5)
    results = tmp_path / "results"
    with model_server(tmp_path / "server.log", disconnect_episode=0, disconnect_step=2) as url:
        proc = vla_eval_run(config, url, results)
    assert proc.returncode == 0, proc.stderr[-3000:]
    _, rows = read_vla_eval(results)
    by_case = {r["case_id"]: r for r in rows}
    assert set(by_case) == {NORMAL, OBSERVATION}
    assert by_case[NORMAL]["status"] == "error" and by_case[NORMAL]["error"].startswith("connection_closed")
    assert by_case[OBSERVATION]["status"] == "ok" and by_case[OBSERVATION]["steps"] == 5
    md = write_report(results, tmp_path / "report", plots=False)["markdown"].read_text()
    assert "Camera Staleness" in md
