"""Episode rows from a vla-eval results directory, for `vpro report`.

vla-eval (`vpro_assets.integrations.vla_eval`) records every episode in `recording-<eval-id>.sqlite`
(table `episode_results`: status, metrics JSON, context JSON = the task's fields, failure reason)
and exports `<benchmark>_aggregate.json` (the same episodes under `tasks[].episodes[]`). Both are
read here without importing vla-eval, and each episode becomes a row of `vpro eval`'s results
schema, so the tables, plots and Wilson intervals are computed by the same code:

- `run_id`: vla-eval's eval id of the benchmark entry; `policy_id`: the model server's class name
  (from its HELLO reply) unless `policy` names it;
- `status`: `ok` for a finished episode (vla-eval's `success` / `fail`), `unavailable` when the case
  could not run here (CaseUnavailableError), else `error` (server gone, timeout, simulator error),
  which is never counted as a failure, as in `vpro eval`;
- case labels and `vpro eval`'s row fields come from the episode's metrics (finished episodes) or
  its recorded task context (errors).

An episode recorded twice (a shard rerun with the same eval id) counts once: a finished record wins
over an error, and the later of two of the same kind.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from vpro_assets.core.errors import VProError
from vpro_assets.rollout.episode import EpisodeSettings

LABELS = ("case_id", "suite", "task", "dimension", "category", "setting", "indicator", "level")
ROW_FIELDS = (
    "seed",
    "steps",
    "phase_timeline",
    "contact",
    "contact_detail",
    "wall_time",
    "artifact_hashes",
    "video",
    "final_state",
)


def _recordings(path: Path) -> list[Path]:
    if path.is_dir():
        return sorted(path.glob("recording-*.sqlite"))
    return [path] if path.suffix == ".sqlite" and _has_table(path, "episode_results") else []


def _aggregates(path: Path) -> list[Path]:
    if path.is_dir():
        return sorted(path.glob("*_aggregate.json"))
    return [path] if path.suffix == ".json" else []


def _has_table(path: Path, table: str) -> bool:
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            return (
                con.execute("SELECT 1 FROM sqlite_master WHERE type='table' AND name=?", (table,)).fetchone()
                is not None
            )
        finally:
            con.close()
    except sqlite3.Error:
        return False


def is_vla_eval_results(path: Path | str) -> bool:
    """A vla-eval results directory, recording database or aggregate JSON (not a `vpro eval` database)."""
    path = Path(path)
    return bool(_recordings(path) or _aggregates(path))


def _status(record: dict) -> str:
    if not record.get("failure_reason") and record.get("status", "fail") in ("success", "fail"):
        return "ok"
    return "unavailable" if "CaseUnavailableError" in str(record.get("failure_detail") or "") else "error"


def _error_text(record: dict) -> str | None:
    if not record.get("failure_reason"):
        return None
    detail = [line for line in str(record.get("failure_detail") or "").strip().splitlines() if line.strip()]
    return f"{record['failure_reason']}: {detail[-1].strip()}" if detail else str(record["failure_reason"])


def to_row(record: dict, run_id: str, policy_id: str) -> dict:
    """One vla-eval episode record (status, metrics, context, failure) as a `vpro eval` row."""
    metrics, context = record.get("metrics") or {}, record.get("context") or {}
    status = _status(record)
    source = metrics if status == "ok" else {**metrics, **context}
    case_id = source.get("case_id") or context.get("name")
    if not case_id:
        raise VProError(
            f"run {run_id}: an episode of task {record.get('task_name')!r} carries no case id; not a LIBERO-VPro result"
        )
    trial = source.get("trial", context.get("episode_idx", record.get("episode_id")))
    if trial is None:
        raise VProError(f"run {run_id}: the episode of case {case_id} records no trial index")
    row: dict[str, Any] = {
        "run_id": run_id,
        "case_id": case_id,
        "trial": int(trial),
        "policy_id": policy_id,
        "status": status,
        "success": bool(metrics.get("success")) if status == "ok" else None,
        "error": _error_text(record),
        "error_kind": record.get("failure_reason"),
        "attempts": 1,
        "worker": record.get("sid"),
        "finished_at": None,
    }
    for key in LABELS:
        row[key] = source.get(key)
    for key in ROW_FIELDS:
        row[key] = metrics.get(key) if status == "ok" else None
    if row["steps"] is None and record.get("steps") is not None and status == "ok":
        row["steps"] = record["steps"]
    return row


def _run(eval_id: str, metadata: dict, policy: str | None) -> dict:
    config = metadata.get("config") or {}
    params = config.get("params") or {}
    server = (metadata.get("server_info") or {}).get("model_server") or "vla-eval model server"
    settings = EpisodeSettings(
        resolution=int(params.get("resolution", 256)),
        wait_steps=int(params.get("num_steps_wait", 10)),
        max_steps_override=params.get("max_steps") or config.get("max_steps"),
    ).to_json()
    return {
        "run_id": eval_id,
        "policy_id": policy or server,
        "policy_spec": f"vla-eval {metadata.get('harness_version', '')} {config.get('benchmark', '')}".strip(),
        "trials": config.get("episodes_per_task"),
        "settings": settings,
        "selection": params.get("select"),
    }


def _from_recording(path: Path, policy: str | None) -> Iterable[tuple[dict, list[tuple[int, dict]]]]:
    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=60.0)
    con.row_factory = sqlite3.Row
    try:
        for meta in con.execute("SELECT eval_id, metadata FROM eval_metadata ORDER BY eval_id"):
            run = _run(meta["eval_id"], json.loads(meta["metadata"]), policy)
            records = []
            for r in con.execute(
                "SELECT rowid, * FROM episode_results WHERE eval_id = ? ORDER BY rowid", (meta["eval_id"],)
            ):
                rec = dict(r)
                rec["metrics"] = json.loads(rec["metrics"]) if rec["metrics"] else {}
                rec["context"] = json.loads(rec["context"]) if rec["context"] else {}
                records.append((rec["rowid"], rec))
            yield run, records
    except sqlite3.Error as exc:
        raise VProError(f"{path}: not a readable vla-eval recording ({exc})") from None
    finally:
        con.close()


_EPISODE_KEYS = {"sid", "eid", "episode_id", "metrics", "steps", "elapsed_sec", "failure_reason", "failure_detail"}


def _from_aggregate(path: Path, policy: str | None) -> Iterable[tuple[dict, list[tuple[int, dict]]]]:
    try:
        body = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise VProError(f"{path}: not a readable vla-eval aggregate JSON ({exc})") from None
    if not isinstance(body, dict) or "tasks" not in body:
        raise VProError(f"{path}: not a vla-eval aggregate JSON (no 'tasks')")
    run = _run(body.get("eval_id") or path.stem, body, policy)
    records: list[tuple[int, dict]] = []
    for task in body["tasks"]:
        for ep in task.get("episodes", []):
            rec = {k: ep.get(k) for k in _EPISODE_KEYS}
            rec["context"] = {k: v for k, v in ep.items() if k not in _EPISODE_KEYS}
            rec["task_name"] = task.get("task")
            rec["status"] = "error" if ep.get("failure_reason") else "fail"
            records.append((len(records), rec))
    yield run, records


def read_vla_eval(path: Path | str, policy: str | None = None) -> tuple[list[dict], list[dict]]:
    """(runs, rows) of a vla-eval results directory: its recording databases when present (the
    complete record), else its exported aggregate JSON files."""
    path = Path(path)
    if not path.exists():
        raise VProError(f"{path}: no such vla-eval results directory or file")
    sources = [(_from_recording, p) for p in _recordings(path)] or [(_from_aggregate, p) for p in _aggregates(path)]
    if not sources:
        raise VProError(f"{path}: no vla-eval results (recording-*.sqlite or *_aggregate.json)")
    runs, rows = [], []
    for reader, source in sources:
        for run, records in reader(source, policy):
            kept: dict[tuple, tuple[bool, int, dict]] = {}
            for order, rec in records:
                row = to_row(rec, run["run_id"], run["policy_id"])
                key = (row["case_id"], row["trial"])
                rank = (row["status"] == "ok", order)
                if key not in kept or rank >= kept[key][:2]:
                    kept[key] = (*rank, row)
            # the simulator and library versions the episodes ran with (recorded by the benchmark)
            run["versions"] = next(
                (
                    rec["metrics"]["versions"]
                    for _, rec in records
                    if isinstance((rec.get("metrics") or {}).get("versions"), dict)
                ),
                {},
            )
            runs.append(run)
            rows += [v[2] for _, v in sorted(kept.items())]
    return runs, rows
