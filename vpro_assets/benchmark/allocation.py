"""How many cases each setting gets, and which: the paper's pinned counts, then a stated rule.

The benchmark has exactly TOTAL_CASES cases. The paper never lists them, but its tables pin how
many stand behind six categories (PINNED, each with the table it is read from: a cell of N
episodes is N / 10 cases). The allocation, in order:
1. Pinned categories: the category's count is split over its settings as the paper pins it, else
   as evenly as the settings' capacities allow (water-filling, ties to settings in taxonomy order).
2. The other categories (both maskings, interaction cue, temporary corruption, view
   unavailability, cross-view contradiction) share the remaining cases the same way: every such
   setting gets as equal a share as its meaningful tasks allow.
3. A setting's share goes to its variants in order (`vpro_assets.benchmark.variants`): the base
   variant takes as many of its meaningful tasks as the share needs, then the next variant, and so on.
4. Where a variant gets fewer cases than it has meaningful tasks, its share is spread as evenly as
   possible across the four suites (ties in suite order), and within a suite the tasks are taken
   in LIBERO's order from a rotating offset (the setting's position in the taxonomy), so that
   different settings cover different tasks; a category marked `same tasks` uses offset 0 for all
   its settings, so its columns compare the same tasks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from vpro_assets.benchmark import applicability
from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.variants import Variant, variants_of
from vpro_assets.core.errors import VProError
from vpro_assets.libero.tasks import TaskRecord

TOTAL_CASES = 3296


@dataclass(frozen=True)
class Pinned:
    category: str
    cases: int
    source: str  # where the paper pins it
    per_setting: tuple[tuple[str, int], ...] = ()  # setting name -> cases, where the paper splits it
    same_tasks: bool = False  # every setting of the category covers the same tasks


PINNED = (
    Pinned(
        "task_relevant_distractors",
        240,
        "Table V: every cell is a multiple of 0.25%, 400 episodes (40 cases) per distractor type; "
        "Table II is the mean of the six",
    ),
    Pinned(
        "task_precondition_variation",
        80,
        "Table VI: 210 episodes (openness) and 590 (object pose); Table II: 800",
        (("receptacle_openness", 21), ("object_pose", 59)),
    ),
    Pinned(
        "visual_state_ambiguity",
        45,
        "Table VI: 70 episodes (openness) and 380 (object pose); Table II: 450",
        (("receptacle_openness", 7), ("object_pose", 38)),
    ),
    Pinned(
        "target_geometry_variation",
        432,
        "Table VII: 1,080 episodes per deformation (3 severities x 36 tasks); Table II: 4,320",
        same_tasks=True,
    ),
    Pinned("camera_staleness", 400, "Table III: 2,000 episodes (200 cases) per camera"),
    Pinned("prediction_reality_divergence", 40, "Table VIII: 100 episodes (10 cases) per suite"),
)


@dataclass(frozen=True)
class Case:
    """One chosen case: a task under a variant of a setting."""

    setting: tx.Setting
    variant: Variant
    task: TaskRecord


def pinned(category_id: str) -> Pinned | None:
    return next((p for p in PINNED if p.category == category_id), None)


def water_fill(budget: int, capacities: Sequence[int]) -> list[int]:
    """Split `budget` into shares no larger than each capacity and as equal as possible;
    leftover units go to the earliest entries."""
    if budget > sum(capacities):
        raise VProError(f"cannot place {budget} cases in capacities {list(capacities)}")
    shares = [0] * len(capacities)
    open_ = [i for i, c in enumerate(capacities) if c > 0]
    remaining = budget
    while remaining and open_:
        level = remaining // len(open_)
        if level == 0:
            for i in open_[:remaining]:
                shares[i] += 1
            break
        for i in list(open_):
            take = min(level, capacities[i] - shares[i])
            shares[i] += take
            remaining -= take
        open_ = [i for i in open_ if shares[i] < capacities[i]]
    return shares


def candidates(setting: tx.Setting, tasks: Sequence[TaskRecord]) -> list[tuple[Variant, list[TaskRecord]]]:
    """Each variant of the setting with its meaningful tasks, in fill order."""
    out = []
    for variant in variants_of(setting):
        rule = applicability.rule_for(setting) if variant.rule is None else applicability.RULES[variant.rule]
        out.append((variant, [t for t in tasks if rule.holds(t)]))
    return out


def setting_shares(tasks: Sequence[TaskRecord]) -> dict[str, int]:
    """Setting id -> its number of cases (steps 1 and 2)."""
    capacity = {s.id: sum(len(ts) for _, ts in candidates(s, tasks)) for s in tx.SETTINGS}
    shares: dict[str, int] = {}
    for pin in PINNED:
        settings = tx.settings_of(pin.category)
        if pin.per_setting:
            split = dict(pin.per_setting)
            if set(split) != {s.name for s in settings} or sum(split.values()) != pin.cases:
                raise VProError(f"pinned split of {pin.category} {split} does not add up to its {pin.cases} cases")
            counts = [split[s.name] for s in settings]
        else:
            counts = water_fill(pin.cases, [capacity[s.id] for s in settings])
        for s, n in zip(settings, counts):
            if n > capacity[s.id]:
                raise VProError(f"{s.id}: pinned {n} cases but only {capacity[s.id]} (task, variant) pairs apply")
            shares[s.id] = n
    rest = [s for s in tx.SETTINGS if s.id not in shares]
    budget = TOTAL_CASES - sum(shares.values())
    if budget < len(rest):
        raise VProError(f"the pinned categories leave {budget} cases for {len(rest)} other settings")
    shares.update(zip((s.id for s in rest), water_fill(budget, [capacity[s.id] for s in rest])))
    return shares


def _spread(pool: list[TaskRecord], share: int, suites: Sequence[str], offset: int) -> list[TaskRecord]:
    """`share` of the pool's tasks, balanced over suites, from a rotating offset (step 4)."""
    if share == len(pool):
        return list(pool)
    by_suite = [[t for t in pool if t.suite == s] for s in suites]
    picked: list[TaskRecord] = []
    for suite_pool, k in zip(by_suite, water_fill(share, [len(p) for p in by_suite])):
        if k:
            start = (offset * k) % len(suite_pool)
            picked += [suite_pool[(start + i) % len(suite_pool)] for i in range(k)]
    order = {t.key: i for i, t in enumerate(pool)}
    return sorted(picked, key=lambda t: order[t.key])


def select(tasks: Sequence[TaskRecord], suites: Sequence[str]) -> dict[str, list[Case]]:
    """Setting id -> its cases, variant by variant, each in task order; exactly TOTAL_CASES in all."""
    shares = setting_shares(tasks)
    chosen: dict[str, list[Case]] = {}
    for ordinal, setting in enumerate(tx.SETTINGS):
        pin = pinned(setting.category)
        offset = 0 if pin and pin.same_tasks else ordinal
        left, cases = shares[setting.id], []
        for variant, pool in candidates(setting, tasks):
            take = min(left, len(pool))
            cases += [Case(setting, variant, t) for t in _spread(pool, take, suites, offset)]
            left -= take
        chosen[setting.id] = cases
    total = sum(len(v) for v in chosen.values())
    if total != TOTAL_CASES:
        raise VProError(f"the allocation chose {total} cases, not {TOTAL_CASES}")
    return chosen
