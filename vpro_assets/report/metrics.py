"""Success rates from episode rows: counts, Wilson confidence intervals, drops from Normal.

Only rows with `status = 'ok'` count towards a success rate; errors and unavailable episodes are
reported next to it, never as failures. The drop of a group is taken against the Normal success
rate of the same policy on the same tasks the group covers.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

from vpro_assets.rollout.contacts import COMPOSITIONS


@dataclass(frozen=True)
class Rate:
    successes: int
    trials: int
    errors: int = 0
    unavailable: int = 0

    @property
    def sr(self) -> float | None:
        return 100.0 * self.successes / self.trials if self.trials else None

    @property
    def ci(self) -> tuple[float, float] | None:
        """Wilson score interval at 95%, in percent."""
        if not self.trials:
            return None
        # Imported here: scipy.stats takes about a second to import, which every `vpro` command
        # would pay (the CLI imports all command modules) for what only reports use.
        from scipy.stats import binomtest

        ci = binomtest(self.successes, self.trials).proportion_ci(confidence_level=0.95, method="wilson")
        return 100 * ci.low, 100 * ci.high


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


def group(rows: Iterable[dict], key: Callable[[dict], str | None]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:
        k = key(r)
        if k is not None:
            out.setdefault(k, []).append(r)
    return out


def normal_rate(rows: list[dict], tasks: set[str] | None = None) -> Rate:
    return rate(r for r in rows if r["category"] == "normal" and (tasks is None or r["task"] in tasks))


def drop(cell_rows: list[dict], all_rows: list[dict]) -> float | None:
    """Normal SR on the tasks of `cell_rows` minus their SR (positive = worse than Normal)."""
    cell = rate(cell_rows)
    tasks = {r["task"] for r in cell_rows if r["status"] == "ok"}
    base = normal_rate(all_rows, tasks)
    if cell.sr is None or base.sr is None:
        return None
    return base.sr - cell.sr


def composition(rows: Iterable[dict]) -> dict[str, int]:

    counts = dict.fromkeys(COMPOSITIONS, 0)
    for r in rows:
        if r["status"] == "ok" and r.get("contact") in counts:
            counts[r["contact"]] += 1
    return counts
