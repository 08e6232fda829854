"""The oracle's reachable ceiling beside a model's success: from the solvability certificate
(`solvability.json`), per category of a report's episode rows, over the cases the model ran.

A scene case counts its own certificate entry; an observation case its task's Normal baseline (its
physics is Normal's, so the oracle solves it exactly when it solves `<task>/normal`:
docs/solvability.md). Within a category each certificate entry counts once, with its own trials
(forty observation cases of one task are one Normal baseline, not forty: the interval stays honest).
Cases the certificate does not hold are left out and counted, so a ceiling over part of the cases
says so.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from vpro_assets.report.metrics import Rate

LABEL = "oracle ceiling"


@dataclass(frozen=True)
class Ceiling:
    normal: Rate  # the Normal baselines of the rows' tasks
    categories: dict[str, Rate]
    missing: tuple[str, ...]  # case ids of the rows whose certificate entry is absent


def entry_id(row: dict) -> str:
    """The certificate entry an episode row's case is certified by."""
    if row.get("level") == "observation":
        return f"{row['task']}/normal"
    return str(row["case_id"])


def _pooled(entries: Iterable[dict]) -> Rate:
    entries = list(entries)
    return Rate(sum(int(e["solved"]) for e in entries), sum(int(e["trials"]) for e in entries))


def ceiling(rows: Iterable[dict], certificate: dict) -> Ceiling:
    held = certificate["cases"]
    by_category: dict[str, set[str]] = {}
    tasks: set[str] = set()
    missing: set[str] = set()
    for row in rows:
        base = entry_id(row)
        if base not in held:
            missing.add(str(row["case_id"]))
            continue
        by_category.setdefault(row["category"], set()).add(base)
        tasks.add(row["task"])
    normal = [held[f"{t}/normal"] for t in sorted(tasks) if f"{t}/normal" in held]
    return Ceiling(
        _pooled(normal),
        {cat: _pooled(held[b] for b in sorted(bases)) for cat, bases in by_category.items()},
        tuple(sorted(missing)),
    )
