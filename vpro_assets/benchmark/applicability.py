"""Which settings apply to which task: meaningfulness rules on the task record (no receptacle
masking without a receptacle, no openness precondition where nothing opens), printed in
docs/taxonomy.md. How many of the meaningful cases the benchmark keeps is
`vpro_assets.benchmark.allocation`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core.errors import VProError
from vpro_assets.libero.tasks import TaskRecord


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
            "involves_openable",
            "the goal involves a fixture that opens and closes (opens or closes it, puts the target in or on it)",
            lambda t: any(a.kind == "openable" for a in t.articulations),
        ),
        Rule(
            "places_with_openable",
            "the goal places a target and involves a fixture that opens and closes (so that fixture's other "
            "state leaves the goal unmet)",
            lambda t: t.target is not None and any(a.kind == "openable" for a in t.articulations),
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
    if cat == "task_precondition_variation":
        return RULES["places_with_openable" if p["attribute"] == "receptacle_openness" else "grasps_target"]
    if cat == "visual_state_ambiguity":
        return RULES["involves_openable" if p["attribute"] == "receptacle_openness" else "grasps_target"]
    if cat == "task_relevant_distractors":
        # Fixture-only goals too: the distractors then stand for the fixture part (generators.fixture_goal).
        return RULES["target_or_articulation"]
    if cat == "target_geometry_variation":
        return RULES["has_target"]
    raise VProError(f"no applicability rule for setting {setting.id}")


def meaningful_tasks(setting: tx.Setting, tasks: Sequence[TaskRecord]) -> list[TaskRecord]:
    rule = rule_for(setting)
    return [t for t in tasks if rule.holds(t)]
