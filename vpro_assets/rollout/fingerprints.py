"""Settled-scene fingerprints: every case's and trial's object poses and articulated joint positions
at the first policy frame, under a named simulator, kept in `settle_fingerprints.json` beside the
catalog, and the drift check that compares a fresh settle with them (docs/simulator.md).

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
from vpro_assets.rollout.settle import pose_difference

SCHEMA_VERSION = 1
FILE_NAME = "settle_fingerprints.json"
# Beyond any of these a case has drifted (docs/simulator.md). Reruns under one simulator agree
# exactly; between MuJoCo 3.8.1 and 3.2.3 the 36 unaffected Normal baselines differ by at most
# 0.56 cm (libero_spatial-08: the same resting place, a few mm over) and 0.3 deg, the affected ones
# by 3.5 cm / 12.5 deg (libero_spatial-05) and 54 cm (libero_10-00, -01, -07).
TOLERANCES = {"displacement_cm": 0.75, "tilt_deg": 5.0, "joint_change": 0.01}


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


def compare(fingerprints: Mapping, records: Iterable[Mapping], tolerances: Mapping | None = None) -> list[dict]:
    """One row per case: largest displacement, tilt and joint change over its trials against the
    fingerprints, `status` drifted / ok / stale / missing, the worst trial."""
    tol = dict(TOLERANCES, **(tolerances or {}))
    rows: dict[str, dict] = {}
    for rec in records:
        cid = rec["case"]
        row = rows.setdefault(
            cid,
            {
                "case": cid,
                "trials": 0,
                "displacement_cm": 0.0,
                "object": None,
                "tilt_deg": 0.0,
                "tilt_object": None,
                "joint_change": 0.0,
                "joint": None,
                "worst_trial": None,
                "status": "ok",
                "note": "",
            },
        )
        entry = fingerprints["cases"].get(cid)
        recorded = entry["trials"].get(str(rec["trial"])) if entry else None
        if recorded is None:
            row["status"], row["note"] = "missing", f"no fingerprint for trial {rec['trial']}"
            continue
        inputs = {"bddl": rec["inputs"]["bddl"], "init_states": rec["inputs"]["init_states"]}
        if (
            entry["inputs"] != inputs
            or recorded["init_row"] != rec["inputs"]["init_row"]
            or recorded["seed"] != rec["seed"]
        ):
            row["status"], row["note"] = (
                "stale",
                "the case's BDDL, initial states or seed changed since the fingerprint",
            )
            continue
        diff = pose_difference(
            rec, {"objects": {n: {"pose": p} for n, p in recorded["objects"].items()}, "joints": recorded["joints"]}
        )
        row["trials"] += 1
        if diff["displacement_cm"] > row["displacement_cm"]:
            row.update(displacement_cm=diff["displacement_cm"], object=diff["object"], worst_trial=rec["trial"])
        if diff["tilt_deg"] > row["tilt_deg"]:
            row.update(tilt_deg=diff["tilt_deg"], tilt_object=diff["tilt_object"])
            row["worst_trial"] = rec["trial"] if row["worst_trial"] is None else row["worst_trial"]
        if diff["joint_change"] > row["joint_change"]:
            row.update(joint_change=diff["joint_change"], joint=diff["joint"])
        if diff["missing"]:
            row["status"], row["note"] = "drifted", f"objects not in both: {', '.join(diff['missing'])}"
    for row in rows.values():
        if row["status"] == "ok" and any(row[k] > tol[k] for k in ("displacement_cm", "tilt_deg", "joint_change")):
            row["status"] = "drifted"
    return list(rows.values())
