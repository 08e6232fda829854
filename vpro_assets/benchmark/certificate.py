"""The solvability certificate, `solvability.json` (committed beside the catalog): per certified case
the oracle's trials solved, steps and final-state fingerprints, and the catalog and lock it was
computed on.

A certificate belongs to one catalog: it records the sha256 of `catalog.json` and of
`scene_artifacts.lock.json` and, per case, the sha256 of the case's catalog record (its parameters,
trial seeds, initial-state reference and artifact hashes). `check` compares it with the current
files: a certificate computed on another catalog or lock is refused, naming the mismatch and the
cases whose records changed (stale), disappeared or are not certified. Observation cases are not
listed: their physics is their base task's Normal baseline, whose entry they inherit.

    {"schema_version": 1, "catalog_sha256": ..., "lock_sha256": ..., "policy": "oracle",
     "settings": {...}, "versions": {...},
     "cases": {"libero_goal-05/normal": {"case_sha256": ..., "trials": 10, "solved": 10, "errors": 0,
               "steps": [...], "final_state": [...], "solved_trials": [...],
               "code_versions": {"<git commit>" | "unrecorded": [trials]}}, ...}}
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from vpro_assets.benchmark.lock import lock_path
from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.core.hashing import canonical_json, sha256_bytes, sha256_file

SCHEMA_VERSION = 1
CERTIFICATE_NAME = "solvability.json"
CERTIFIED_LEVELS = ("normal", "scene")  # observation cases inherit their base task's Normal entry


class CertificateError(VProError):
    """A certificate that cannot be read, or that belongs to another catalog."""


def certificate_path() -> Path:
    return paths.REPO_ROOT / CERTIFICATE_NAME


def case_sha256(case: dict) -> str:
    """sha256 of a case's catalog record (canonical JSON): what the certificate entry was computed on."""
    return sha256_bytes(canonical_json(case).encode("utf-8"))


def file_sha256(path: Path) -> str | None:
    return sha256_file(path) if Path(path).is_file() else None


def certifiable(case: dict) -> bool:
    """Normal baselines and scene cases; an observation case inherits its base task's baseline."""
    return not case.get("setting") or case.get("level") == "scene"


def base_of(case: dict) -> str:
    """The certificate entry a case's solvability comes from (its own, or its task's Normal baseline)."""
    return case["id"] if certifiable(case) else f"{case['task']}/normal"


def load(path: Path | None = None) -> dict[str, Any]:
    path = Path(path or certificate_path())
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CertificateError(f"{path}: no certificate; compute one with `vpro certify`") from None
    except json.JSONDecodeError as exc:
        raise CertificateError(f"{path}: invalid JSON at line {exc.lineno}: {exc.msg}") from None
    if not isinstance(data, dict) or data.get("schema_version") != SCHEMA_VERSION:
        found = data.get("schema_version") if isinstance(data, dict) else None
        raise CertificateError(f"{path}: schema_version {found!r}, this toolkit reads {SCHEMA_VERSION}")
    if not isinstance(data.get("cases"), dict):
        raise CertificateError(f"{path}: 'cases' must be an object keyed by case id")
    return data


def write(certificate: dict, path: Path | None = None) -> None:
    write_text_atomic(Path(path or certificate_path()), canonical_json(certificate))


def _short(digest: str | None) -> str:
    return digest[:12] if digest else "none"


def check(certificate: dict, catalog: dict, catalog_file: Path, lock_file: Path | None = None) -> list[str]:
    """Why the certificate does not belong to this catalog (empty: it does). Names the catalog or
    lock mismatch, then the stale, removed and uncertified cases."""
    problems = []
    catalog_sha, lock_sha = file_sha256(catalog_file), file_sha256(lock_file or lock_path())
    if certificate.get("catalog_sha256") != catalog_sha:
        problems.append(
            f"computed on catalog sha256 {_short(certificate.get('catalog_sha256'))}, "
            f"{catalog_file} is {_short(catalog_sha)}"
        )
    if certificate.get("lock_sha256") != lock_sha:
        problems.append(
            f"computed on scene lock sha256 {_short(certificate.get('lock_sha256'))}, "
            f"{lock_file or lock_path()} is {_short(lock_sha)}"
        )
    records = {c["id"]: c for c in catalog.get("normal", []) + catalog["cases"] if certifiable(c)}
    entries = certificate["cases"]
    for cid, entry in sorted(entries.items()):
        if cid not in records:
            problems.append(f"case {cid}: certified but not in the catalog")
        elif entry.get("case_sha256") != case_sha256(records[cid]):
            problems.append(f"case {cid}: stale (its catalog record changed since it was certified)")
    if problems:
        missing = [cid for cid in records if cid not in entries]
        if missing:
            problems.append(f"{len(missing)} case(s) not certified, e.g. {', '.join(missing[:3])}")
    return problems


def coverage(certificate: dict, catalog: dict) -> tuple[int, int]:
    """(certified, certifiable) case counts."""
    ids = [c["id"] for c in catalog.get("normal", []) + catalog["cases"] if certifiable(c)]
    return sum(1 for i in ids if i in certificate["cases"]), len(ids)
