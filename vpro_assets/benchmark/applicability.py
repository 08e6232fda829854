"""Which settings apply to which task, and the deterministic selection of the 3,296 cases.

Two steps, both rules written here and printed in docs/taxonomy.md:
1. Meaningfulness: a rule on the task record (no receptacle masking without a receptacle, no
   openness precondition where nothing opens). Every observation-level setting keeps every task
   its rule admits.
2. Budget: the benchmark has exactly TOTAL_CASES cases. Scene-variation settings (which each need
   generated assets) share what the observation-level settings leave, by water-filling: every
   scene setting gets as equal a share as its meaningful tasks allow (ties go to settings in
   taxonomy order), each setting's share is spread as evenly as possible across the four suites
   (ties in suite order), and within a suite the tasks are taken in LIBERO's order starting at a
   rotating offset, so that different settings cover different tasks.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core.errors import VProError
from vpro_assets.libero.tasks import TaskRecord

TOTAL_CASES = 3296


@dataclass(frozen=True)
class Rule:
    name: str
    text: str
    holds: Callable[[TaskRecord], bool]


RULES = {
    r.name: r
    for r in (
        Rule("any_task", "every task", lambda t: True),
        Rule("has_target", "the goal places a movable target object", lambda t: t.target is not None),
        Rule(
            "grasps_target",
            "the target is grasped and put on or into a receptacle (not pushed, not a fixture-only goal)",
            lambda t: t.requires_grasp,
        ),
        Rule(
            "has_receptacle",
            "the target goes on or into an object or fixture (not a table region)",
            lambda t: t.receptacle is not None,
        ),
        Rule(
            "openable_receptacle",
            "the target goes into a receptacle that opens and closes (drawer, microwave)",
            lambda t: t.openable_receptacle,
        ),
        Rule(
            "target_or_articulation",
            "the goal places a target or involves an articulated fixture",
            lambda t: t.target is not None or bool(t.articulations),
        ),
    )
}


def rule_for(setting: tx.Setting) -> Rule:
    """The meaningfulness rule of one setting."""
    p, cat = setting.param_dict, setting.category
    if cat == "target_object_masking":
        return RULES["has_target" if p["schedule"] == "always" else "grasps_target"]
    if cat == "target_receptacle_masking":
        return RULES["has_receptacle"]
    if cat == "interaction_cue_masking":
        return RULES[
            {"gripper": "any_task", "gripper_object_contact": "grasps_target", "placement_contact": "has_receptacle"}[
                str(p["region"])
            ]
        ]
    if cat == "temporary_observation_corruption":
        return RULES["any_task" if p["trigger"] == "frequency" or p["phase"] == "approach" else "grasps_target"]
    if cat in ("view_unavailability", "camera_staleness", "prediction_reality_divergence"):
        return RULES["any_task"]
    if cat == "cross_view_contradiction":
        return RULES["target_or_articulation" if p["attribute"] == "state" else "has_target"]
    if cat in ("task_precondition_variation", "visual_state_ambiguity"):
        return RULES["openable_receptacle" if p["attribute"] == "receptacle_openness" else "grasps_target"]
    if cat in ("task_relevant_distractors", "target_geometry_variation"):
        return RULES["has_target"]
    raise VProError(f"no applicability rule for setting {setting.id}")


def meaningful_tasks(setting: tx.Setting, tasks: Sequence[TaskRecord]) -> list[TaskRecord]:
    rule = rule_for(setting)
    return [t for t in tasks if rule.holds(t)]


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


def select(tasks: Sequence[TaskRecord], suites: Sequence[str]) -> dict[str, list[TaskRecord]]:
    """Setting id -> the tasks it has cases for, in task order; exactly TOTAL_CASES in all."""
    chosen: dict[str, list[TaskRecord]] = {}
    scene: list[tuple[tx.Setting, list[TaskRecord]]] = []
    for setting in tx.SETTINGS:
        candidates = meaningful_tasks(setting, tasks)
        if tx.category(setting.category).level == tx.SCENE:
            scene.append((setting, candidates))
        else:
            chosen[setting.id] = candidates
    budget = TOTAL_CASES - sum(len(v) for v in chosen.values())
    if budget < len(scene):
        raise VProError(f"observation settings leave {budget} cases for {len(scene)} scene settings")
    shares = water_fill(budget, [len(c) for _, c in scene])
    for ordinal, ((setting, candidates), share) in enumerate(zip(scene, shares)):
        by_suite = [[t for t in candidates if t.suite == s] for s in suites]
        picked: list[TaskRecord] = []
        for pool, k in zip(by_suite, water_fill(share, [len(p) for p in by_suite])):
            if k:
                start = (ordinal * k) % len(pool)
                picked += [pool[(start + i) % len(pool)] for i in range(k)]
        order = {t.key: i for i, t in enumerate(tasks)}
        chosen[setting.id] = sorted(picked, key=lambda t: order[t.key])
    return chosen
