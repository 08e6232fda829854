"""Settled-scene fingerprints: every case's and trial's object poses and articulated joint positions
at the first policy frame, under a named simulator, kept in `settle_fingerprints.json` beside the
catalog (docs/simulator.md). What a start is and how two are compared (`compare`, `TOLERANCES`) is
`vpro_assets.libero.settled`, which packs also carry (a pack ships the fingerprints of its cases,
`vpro_assets.packs.fork_drift`).

A trial's fingerprint is bound to its inputs (the BDDL's and the initial-state file's sha256, the
row, the seed): a case whose inputs changed has a stale fingerprint, reported as such and never
compared as if it were the same scene.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path

from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.libero.settled import FILE_NAME, SCHEMA_VERSION, TOLERANCES, compare

__all__ = [
    "FILE_NAME",
    "SCHEMA_VERSION",
    "TOLERANCES",
    "build",
    "compare",
    "dumps",
    "fingerprints_path",
    "load",
    "trial_fingerprint",
    "write",
]


def fingerprints_path() -> Path:
    return paths.catalog_path().parent / FILE_NAME


def trial_fingerprint(record: Mapping) -> dict:
    """The part of a `settle_trial` record a fingerprint keeps."""
    return {
        "seed": record["seed"],
        "init_row": record["inputs"]["init_row"],
        "objects": {name: obj["pose"] for name, obj in sorted(record["objects"].items())},
        "joints": dict(sorted(record["joints"].items())),
    }


def build(records: Iterable[Mapping], simulator: Mapping, wait_steps: int, base: Mapping | None = None) -> dict:
    """Fingerprints of settled records, merged over `base` (cases not settled now are kept only when
    taken with the same simulator: one file, one simulator)."""
    cases: dict = {}
    if base is not None and dict(base.get("simulator", {})) == dict(simulator) and base.get("wait_steps") == wait_steps:
        cases = {cid: dict(entry) for cid, entry in base["cases"].items()}
    for rec in records:
        inputs = {"bddl": rec["inputs"]["bddl"], "init_states": rec["inputs"]["init_states"]}
        entry = cases.get(rec["case"])
        if entry is None or entry["inputs"] != inputs:
            entry = cases[rec["case"]] = {"inputs": inputs, "trials": {}}
        entry["trials"] = {**entry["trials"], str(rec["trial"]): trial_fingerprint(rec)}
    return {
        "schema_version": SCHEMA_VERSION,
        "simulator": dict(sorted(simulator.items())),
        "wait_steps": wait_steps,
        "cases": dict(sorted(cases.items())),
    }


def dumps(fingerprints: Mapping) -> str:
    """Canonical text: the header fields one per line, then one line per case (diffs name the case)."""
    lines = [
        f" {json.dumps(k)}: {json.dumps(v, sort_keys=True)}," for k, v in sorted(fingerprints.items()) if k != "cases"
    ]
    cases = [
        f"  {json.dumps(cid)}: {json.dumps(entry, sort_keys=True, separators=(',', ':'))}"
        for cid, entry in sorted(fingerprints["cases"].items())
    ]
    return "{\n" + "\n".join(lines) + '\n "cases": {\n' + ",\n".join(cases) + "\n }\n}\n"


def write(path: Path | str, fingerprints: Mapping) -> None:
    write_text_atomic(path, dumps(fingerprints))


def load(path: Path | str | None = None) -> dict:
    path = Path(path) if path else fingerprints_path()
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise VProError(
            f"{path}: no fingerprints; take them with `vpro settle --select normal --trials 10 --fingerprints`"
        ) from None
    except ValueError as exc:
        raise VProError(f"{path}: not valid JSON ({exc})") from None
    if data.get("schema_version") != SCHEMA_VERSION or not isinstance(data.get("cases"), dict):
        raise VProError(f"{path}: not a fingerprint file of schema {SCHEMA_VERSION}")
    return data
