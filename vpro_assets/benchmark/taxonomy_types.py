"""The taxonomy's records and fixed tables: the Dimension, Category and Setting types, the 4
dimensions and 12 categories, and their lookups. The 96 settings are built from the parameter
choices in `vpro_assets.benchmark.settings_table`; `vpro_assets.benchmark.taxonomy` gathers both.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass

from vpro_assets.core.errors import UnknownIdError

JSONScalar = str | int | float | bool | None
TAXONOMY_VERSION = "vpro-taxonomy-v1"
CONTROL_HZ = 20  # LIBERO's OSC controller rate: step counts below are control steps

ROBUSTNESS = "robustness"  # higher SR means more resilient
DIAGNOSTIC = "diagnostic"  # high SR may come from priors or other views, read with controls

OBSERVATION = "observation"  # the scene stays nominal, what the policy sees changes
SCENE = "scene"  # the scene itself changes (new BDDL/MJCF, assets, initial states)

# Manipulation phases from the phase tracker, in order.
PHASES = ("approach", "grasp", "transport", "pre_placement")
VIEWS = {"third_person": "agentview", "wrist": "robot0_eye_in_hand"}


@dataclass(frozen=True)
class Dimension:
    id: str
    title: str
    summary: str


@dataclass(frozen=True)
class Category:
    id: str
    dimension: str
    title: str
    indicator: str
    level: str
    summary: str


@dataclass(frozen=True)
class Setting:
    category: str
    name: str
    params: tuple[tuple[str, JSONScalar], ...]
    version: int = 1

    @property
    def id(self) -> str:
        return f"vpro/{self.category}/{self.name}-v{self.version}"

    @property
    def param_dict(self) -> dict[str, JSONScalar]:
        return dict(self.params)

    def to_json(self) -> dict:
        cat = category(self.category)
        return {
            "id": self.id,
            "category": self.category,
            "dimension": cat.dimension,
            "name": self.name,
            "version": self.version,
            "level": cat.level,
            "params": self.param_dict,
        }


DIMENSIONS = (
    Dimension(
        "visual_evidence_degradation",
        "Visual Evidence Degradation",
        "Task-relevant evidence is occluded, corrupted or missing, from single entities to whole views.",
    ),
    Dimension(
        "camera_staleness", "Camera Staleness", "One camera delivers outdated frames while the other stays current."
    ),
    Dimension(
        "visual_source_consistency",
        "Visual Source Consistency",
        "Visual sources disagree: the two cameras, or predicted and realised futures.",
    ),
    Dimension(
        "task_relevant_scene_variation",
        "Task-Relevant Scene Variation",
        "The scene itself changes; observations stay complete, current and consistent.",
    ),
)

CATEGORIES = (
    Category(
        "target_object_masking",
        "visual_evidence_degradation",
        "Target-Object Masking",
        DIAGNOSTIC,
        OBSERVATION,
        "A share of the target object's visible pixels is covered by a flat occluder on a temporal schedule.",
    ),
    Category(
        "target_receptacle_masking",
        "visual_evidence_degradation",
        "Target-Receptacle Masking",
        DIAGNOSTIC,
        OBSERVATION,
        "As target-object masking, applied to the receptacle the target goes on or into.",
    ),
    Category(
        "interaction_cue_masking",
        "visual_evidence_degradation",
        "Interaction-Cue Masking",
        DIAGNOSTIC,
        OBSERVATION,
        "Local interaction cues are removed: the gripper, the gripper-object contact region, the placement contact region.",
    ),
    Category(
        "temporary_observation_corruption",
        "visual_evidence_degradation",
        "Temporary Observation Corruption",
        ROBUSTNESS,
        OBSERVATION,
        "Transient full-frame blackout or noise, triggered at a frequency or during one manipulation phase.",
    ),
    Category(
        "view_unavailability",
        "visual_evidence_degradation",
        "View Unavailability",
        ROBUSTNESS,
        OBSERVATION,
        "One camera is removed: single-view input, a constant image, or a duplicate of the other view.",
    ),
    Category(
        "camera_staleness",
        "camera_staleness",
        "Camera Staleness",
        ROBUSTNESS,
        OBSERVATION,
        "One view is delayed by a fixed number of steps, frozen, or replays its own history.",
    ),
    Category(
        "cross_view_contradiction",
        "visual_source_consistency",
        "Cross-View Contradiction",
        DIAGNOSTIC,
        OBSERVATION,
        "One view is edited to contradict the other about quantity, existence, position or state; both time-aligned.",
    ),
    Category(
        "prediction_reality_divergence",
        "visual_source_consistency",
        "Prediction-Reality Divergence",
        ROBUSTNESS,
        OBSERVATION,
        "Ground truth only at the first step, then the model's own predicted frames are its observations (frame-predicting models only).",
    ),
    Category(
        "task_relevant_distractors",
        "task_relevant_scene_variation",
        "Task-Relevant Distractors",
        ROBUSTNESS,
        SCENE,
        "An added object shares the target's category, colour, shape or affordance, takes its familiar position, or blocks its path.",
    ),
    Category(
        "task_precondition_variation",
        "task_relevant_scene_variation",
        "Task-Precondition Variation",
        ROBUSTNESS,
        SCENE,
        "The receptacle's openness or the target's pose starts in the other state; the instruction is unchanged.",
    ),
    Category(
        "visual_state_ambiguity",
        "task_relevant_scene_variation",
        "Visual State Ambiguity",
        DIAGNOSTIC,
        SCENE,
        "Physical state unchanged; the other state is added as visual-only geometry, so both are seen at once.",
    ),
    Category(
        "target_geometry_variation",
        "task_relevant_scene_variation",
        "Target Geometry Variation",
        ROBUSTNESS,
        SCENE,
        "The target's mesh is tapered, multi-peaked, twisted or made asymmetric at three severities; category preserved.",
    ),
)


@functools.cache
def _index() -> dict[str, Mapping]:
    return {"dimension": {d.id: d for d in DIMENSIONS}, "category": {c.id: c for c in CATEGORIES}}


def dimension(dim_id: str) -> Dimension:
    return lookup("dimension", _index()["dimension"], dim_id)


def category(cat_id: str) -> Category:
    return lookup("category", _index()["category"], cat_id)


def lookup(kind: str, table: Mapping, key: str):
    """`table[key]`, or an UnknownIdError naming the kind and the closest keys."""
    if key not in table:
        raise UnknownIdError(kind, key, table)
    return table[key]
