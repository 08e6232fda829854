"""The results store: one SQLite file, WAL mode, one row per (run, case, trial).

Each episode's row is committed the moment the episode ends (synchronous=FULL), so a run killed
at any moment, even by kill -9, keeps every finished episode. The primary key makes a duplicate
impossible; a row that ended in an error may be replaced by a later attempt, a row with a result
(`status = 'ok'`) never is.

Tables:
  runs(run_id PK, created_at, policy_spec, policy_id, settings JSON, selection JSON, trials,
       versions JSON, catalog_sha256)
  episodes(run_id, case_id, trial  PK;  seed, policy_id, suite, task, dimension, category,
       setting, indicator, level, status ('ok' | 'error' | 'unavailable'), success (0/1, NULL
       unless ok), steps, phase_timeline JSON, contact ('target_only' | 'distractor_only' | 'both'
       | 'neither'), contact_detail JSON, wall_time, artifact_hashes JSON, error, error_kind,
       attempts, worker, finished_at, video, final_state (sha256 of the
       simulator state at the end: a fingerprint of the trajectory, equal across backends),
       simulator JSON (the worker's mujoco, robosuite and hf-libero versions; schema 2),
       code_version (the toolkit's git commit that ran the episode: `core.provenance`; schema 3))
"""

from __future__ import annotations

import json
import sqlite3
import time
from collections.abc import Iterable
from pathlib import Path

from vpro_assets.core.errors import VProError

# 2: episodes.simulator, 3: episodes.code_version (an older file gains the columns when opened; its
# rows keep NULL there: not recorded)
SCHEMA_VERSION = 3
STATUSES = ("ok", "error", "unavailable")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    run_id TEXT PRIMARY KEY,
    created_at TEXT NOT NULL,
    policy_spec TEXT NOT NULL,
    policy_id TEXT NOT NULL,
    settings TEXT NOT NULL,
    selection TEXT NOT NULL,
    trials INTEGER NOT NULL,
    versions TEXT NOT NULL,
    catalog_sha256 TEXT
);
CREATE TABLE IF NOT EXISTS episodes (
    run_id TEXT NOT NULL REFERENCES runs(run_id),
    case_id TEXT NOT NULL,
    trial INTEGER NOT NULL,
    seed INTEGER,
    policy_id TEXT NOT NULL,
    suite TEXT, task TEXT, dimension TEXT, category TEXT, setting TEXT, indicator TEXT, level TEXT,
    status TEXT NOT NULL CHECK (status IN ('ok', 'error', 'unavailable')),
    success INTEGER CHECK (success IN (0, 1) OR success IS NULL),
    steps INTEGER,
    phase_timeline TEXT,
    contact TEXT,
    contact_detail TEXT,
    wall_time REAL,
    artifact_hashes TEXT,
    error TEXT,
    error_kind TEXT,
    attempts INTEGER NOT NULL DEFAULT 1,
    worker TEXT,
    finished_at TEXT,
    video TEXT,
    final_state TEXT,
    simulator TEXT,
    code_version TEXT,
    PRIMARY KEY (run_id, case_id, trial)
);
CREATE INDEX IF NOT EXISTS episodes_by_category ON episodes(run_id, category, setting);
"""

EPISODE_COLUMNS = (
    "run_id",
    "case_id",
    "trial",
    "seed",
    "policy_id",
    "suite",
    "task",
    "dimension",
    "category",
    "setting",
    "indicator",
    "level",
    "status",
    "success",
    "steps",
    "phase_timeline",
    "contact",
    "contact_detail",
    "wall_time",
    "artifact_hashes",
    "error",
    "error_kind",
    "attempts",
    "worker",
    "finished_at",
    "video",
    "final_state",
    "simulator",
    "code_version",
)
_JSON_COLUMNS = ("phase_timeline", "contact_detail", "artifact_hashes", "simulator")


def utc_now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


class ResultsStore:
    def __init__(self, path: Path | str):
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise VProError(f"results database {self.path}: cannot create its folder ({exc.strerror})") from None
        try:
            self.db = sqlite3.connect(str(self.path), timeout=60.0, isolation_level=None)
            self.db.row_factory = sqlite3.Row
            mode = self.db.execute("PRAGMA journal_mode=WAL").fetchone()[0]
            self.db.execute("PRAGMA synchronous=FULL")
            version = self.db.execute("PRAGMA user_version").fetchone()[0]
        except sqlite3.OperationalError as exc:  # unwritable folder, a directory in the way, ...
            raise VProError(f"results database {self.path}: cannot open it ({exc})") from None
        except sqlite3.DatabaseError as exc:
            raise VProError(f"{self.path}: not a results database ({exc})") from None
        if mode.lower() != "wal":
            raise VProError(f"{self.path}: SQLite refused WAL mode (got {mode!r}); use a local file system")
        if version not in (0, 1, 2, SCHEMA_VERSION):
            raise VProError(f"{self.path}: results schema {version}, this toolkit reads schema {SCHEMA_VERSION}")
        self.db.executescript(_SCHEMA)
        columns = {r[1] for r in self.db.execute("PRAGMA table_info(episodes)")}
        for column in ("simulator", "code_version"):
            if column not in columns:
                self.db.execute(f"ALTER TABLE episodes ADD COLUMN {column} TEXT")
        self.db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")

    def close(self) -> None:
        self.db.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- runs -------------------------------------------------------------------------------
    def create_run(
        self,
        run_id: str,
        policy_spec: str,
        policy_id: str,
        settings: dict,
        selection: list,
        trials: int,
        versions: dict,
        catalog_sha256: str | None,
    ) -> None:
        self.db.execute(
            "INSERT INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                run_id,
                utc_now(),
                policy_spec,
                policy_id,
                json.dumps(settings, sort_keys=True),
                json.dumps(list(selection)),
                trials,
                json.dumps(versions, sort_keys=True),
                catalog_sha256,
            ),
        )

    def run(self, run_id: str) -> dict | None:
        row = self.db.execute("SELECT * FROM runs WHERE run_id = ?", (run_id,)).fetchone()
        if row is None:
            return None
        out = dict(row)
        for key in ("settings", "selection", "versions"):
            out[key] = json.loads(out[key])
        return out

    def runs(self) -> list[dict]:
        ids = [r[0] for r in self.db.execute("SELECT run_id FROM runs ORDER BY created_at, rowid")]
        return [run for run_id in ids if (run := self.run(run_id)) is not None]

    def latest_run_id(self) -> str | None:
        row = self.db.execute("SELECT run_id FROM runs ORDER BY created_at DESC, rowid DESC LIMIT 1").fetchone()
        return row[0] if row else None

    # ---- episodes ---------------------------------------------------------------------------
    def done_keys(self, run_id: str, include_errors: bool = True) -> set[tuple[str, int]]:
        """(case, trial) pairs that need no new attempt: results, plus errors unless they are to be retried."""
        where = "" if include_errors else " AND status != 'error'"
        return {
            (r[0], r[1])
            for r in self.db.execute(f"SELECT case_id, trial FROM episodes WHERE run_id = ?{where}", (run_id,))
        }

    def attempts(self, run_id: str, case_id: str, trial: int) -> int:
        row = self.db.execute(
            "SELECT attempts FROM episodes WHERE run_id=? AND case_id=? AND trial=?", (run_id, case_id, trial)
        ).fetchone()
        return int(row[0]) if row else 0

    def record(self, row: dict) -> bool:
        """Commit one episode; returns False if a result for it already exists (never overwritten)."""
        if row.get("status") not in STATUSES:
            raise VProError(f"episode row status must be one of {STATUSES}, got {row.get('status')!r}")
        row = dict(row)
        row.setdefault("attempts", 1)
        row.setdefault("finished_at", utc_now())
        values = []
        for col in EPISODE_COLUMNS:
            value = row.get(col)
            if col in _JSON_COLUMNS and value is not None:
                value = json.dumps(value, sort_keys=True)
            if col == "success" and value is not None:
                value = int(bool(value))
            values.append(value)
        cols = ", ".join(EPISODE_COLUMNS)
        marks = ", ".join("?" for _ in EPISODE_COLUMNS)
        updates = ", ".join(f"{c} = excluded.{c}" for c in EPISODE_COLUMNS[3:])
        cur = self.db.execute(
            f"INSERT INTO episodes ({cols}) VALUES ({marks}) ON CONFLICT(run_id, case_id, trial) "
            f"DO UPDATE SET {updates} WHERE episodes.status != 'ok'",
            values,
        )
        return cur.rowcount > 0

    def forget(self, run_id: str, case_ids: Iterable[str]) -> None:
        """Drop the rows of these cases (to run them again)."""
        self.db.executemany("DELETE FROM episodes WHERE run_id = ? AND case_id = ?", [(run_id, c) for c in case_ids])

    def episodes(self, run_id: str | None = None) -> list[dict]:
        query = "SELECT * FROM episodes"
        args: tuple[str, ...] = ()
        if run_id is not None:
            query, args = query + " WHERE run_id = ?", (run_id,)
        rows = []
        for r in self.db.execute(query + " ORDER BY run_id, case_id, trial", args):
            d = dict(r)
            for col in _JSON_COLUMNS:
                if d[col] is not None:
                    d[col] = json.loads(d[col])
            rows.append(d)
        return rows

    def count(self, run_id: str) -> dict[str, int]:
        return {
            r[0]: r[1]
            for r in self.db.execute(
                "SELECT status, COUNT(*) FROM episodes WHERE run_id = ? GROUP BY status", (run_id,)
            )
        }


def open_readonly_rows(path: Path | str, run_ids: Iterable[str] | None = None) -> list[dict]:
    if not Path(path).is_file():
        raise VProError(f"{path}: no such results database")
    with ResultsStore(path) as store:
        wanted = list(run_ids) if run_ids else [r["run_id"] for r in store.runs()]
        return [row for rid in wanted for row in store.episodes(rid)]
