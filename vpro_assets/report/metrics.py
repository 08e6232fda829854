"""Success rates from episode rows: counts, Wilson confidence intervals, drops from Normal.

Only rows with `status = 'ok'` count towards a success rate; errors and unavailable episodes are
reported next to it, never as failures. The drop of a group is taken against the Normal success
rate of the same policy on the same tasks the group covers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable, Optional

Z95 = 1.959963984540054


@dataclass(frozen=True)
class Rate:
    successes: int
    trials: int
    errors: int = 0
    unavailable: int = 0

    @property
    def sr(self) -> Optional[float]:
        return 100.0 * self.successes / self.trials if self.trials else None

    @property
    def ci(self) -> Optional[tuple[float, float]]:
        """Wilson score interval at 95%, in percent."""
        n = self.trials
        if not n:
            return None
        p = self.successes / n
        denom = 1 + Z95**2 / n
        centre = (p + Z95**2 / (2 * n)) / denom
        half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / denom
        return 100 * max(0.0, centre - half), 100 * min(1.0, centre + half)


def rate(rows: Iterable[dict]) -> Rate:
    ok = succ = err = unav = 0
    for r in rows:
        if r["status"] == "ok":
            ok += 1
            succ += int(bool(r["success"]))
        elif r["status"] == "unavailable":
            unav += 1
        else:
            err += 1
    return Rate(succ, ok, err, unav)


def group(rows: Iterable[dict], key: Callable[[dict], Optional[str]]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:
        k = key(r)
        if k is not None:
            out.setdefault(k, []).append(r)
    return out


def normal_rate(rows: list[dict], tasks: Optional[set[str]] = None) -> Rate:
    return rate(r for r in rows if r["category"] == "normal" and (tasks is None or r["task"] in tasks))


def drop(cell_rows: list[dict], all_rows: list[dict]) -> Optional[float]:
    """Normal SR on the tasks of `cell_rows` minus their SR (positive = worse than Normal)."""
    cell = rate(cell_rows)
    tasks = {r["task"] for r in cell_rows if r["status"] == "ok"}
    base = normal_rate(all_rows, tasks)
    if cell.sr is None or base.sr is None:
        return None
    return base.sr - cell.sr


def composition(rows: Iterable[dict]) -> dict[str, int]:
    from vpro_assets.rollout.contacts import COMPOSITIONS

    counts = {k: 0 for k in COMPOSITIONS}
    for r in rows:
        if r["status"] == "ok" and r.get("contact") in counts:
            counts[r["contact"]] += 1
    return counts
