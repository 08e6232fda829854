"""Variants of a setting: more than one case per (task, setting) where the paper's counts ask for
more cases than the setting has meaningful tasks.

Every setting has its own definition, the base variant (name ""), whose cases keep the plain case
id `<task>/<category>/<name>-v<version>`. A setting listed in VARIANTS also has further variants,
each a case of its own with the id suffix `-<variant name>`, its own parameters (added to the
setting's, with `variant` naming it) and its own meaningfulness rule. The allocation
(`vpro_assets.benchmark.allocation`) fills a setting's share with its variants in the order listed
here, base first, so a variant is only used where the base variant runs out of tasks.
"""

from __future__ import annotations

from dataclasses import dataclass

from vpro_assets.benchmark.taxonomy import JSONScalar, Setting

BASE = ""

# Opening levels of the "ajar" variants: the fraction of the way from the edge of LIBERO's
# closed range to the edge of its open range (neither LIBERO's `is_open` nor its `is_close` holds).
OPENING_LEVELS = {"open25": 0.25, "open50": 0.5, "open75": 0.75}


@dataclass(frozen=True)
class Variant:
    name: str  # BASE for the setting as defined, else the case-id suffix
    rule: str | None  # applicability rule name; None: the setting's own rule
    params: tuple[tuple[str, JSONScalar], ...] = ()  # added to the setting's parameters
    text: str = ""  # one sentence for docs/taxonomy.md

    @property
    def suffix(self) -> str:
        return f"-{self.name}" if self.name else ""


# What the base variant of a setting with variants is (docs/taxonomy.md).
BASE_TEXT = {
    "task_precondition_variation/receptacle_openness": "The drawer or door the task involves (the receptacle the "
    "target goes into, else the drawer the goal opens or closes, else the top drawer of the cabinet the target "
    "goes on) starts in its other end state, drawn from LIBERO's own open or closed range where the part does not cut "
    "into its fixture (and moves under a gentle push).",
    "task_precondition_variation/object_pose": "The target starts upside down at its LIBERO place.",
    "visual_state_ambiguity/receptacle_openness": "A visual-only copy of the drawer or door the task involves shows "
    "it in its other end state over the real one.",
    "visual_state_ambiguity/object_pose": "A visual-only upside-down copy of the target stands next to it.",
}


def _ajar(cat_label: str) -> tuple[Variant, ...]:
    # A drawer the goal itself opens is not started three quarters open (libero_goal-00: it would
    # also push the bowl standing in front of the cabinet).
    return tuple(
        Variant(
            name,
            "places_with_openable" if level > 0.5 else "involves_openable",
            (("opening", level), ("state", "partly_open"), ("variant", name)),
            f"{cat_label} at {int(level * 100)}% of the way from LIBERO's closed range to its open range "
            "(a second opening level: neither open nor closed by LIBERO's own test).",
        )
        for name, level in OPENING_LEVELS.items()
    )


# "<category>/<setting name>" -> its variants after the base one, in fill order.
VARIANTS: dict[str, tuple[Variant, ...]] = {
    "task_precondition_variation/receptacle_openness": _ajar("The drawer or door the task involves starts"),
    "task_precondition_variation/object_pose": (
        Variant(
            "lying",
            "grasps_target",
            (("state", "lying"), ("variant", "lying")),
            "The target starts lying on its side (turned 90 degrees about the world x axis) at its LIBERO "
            "place, a second stable pose besides upside down.",
        ),
    ),
    "visual_state_ambiguity/receptacle_openness": (
        Variant(
            "open50",
            "involves_openable",
            (("opening", 0.5), ("state", "partly_open"), ("variant", "open50")),
            "The visual-only copy shows the drawer or door half way between LIBERO's closed and open ranges.",
        ),
    ),
    "visual_state_ambiguity/object_pose": (
        Variant(
            "lying",
            "grasps_target",
            (("state", "lying"), ("variant", "lying")),
            "The visual-only copy of the target lies on its side instead of standing upside down.",
        ),
    ),
}


# Task-Relevant Distractors on goals without a movable target (generators.fixture_goal does it).
FIXTURE_GOAL_DISTRACTORS = (
    "On a fixture-only goal (libero_goal-00 opens the middle drawer, libero_goal-07 turns on the stove) the "
    "target is the fixture part the goal acts on. A stand-in takes its place in the choice rules: the "
    "movable object LIBERO's tasks put into or onto that fixture (a bowl for a cabinet drawer, the moka pot "
    "for the stove, a mug for the microwave), and the fixture's position is the anchor. same_category, "
    "same_color, same_shape, same_affordance: the rule applied to the stand-in, at the free spot nearest the "
    "fixture; familiar_position: the stand-in's same-category object as close to the fixture as it fits "
    "(nothing is displaced, a fixture stays put); trajectory_obstacle: on the reaching path from the "
    "gripper's start to the fixture."
)


def setting_key(setting: Setting) -> str:
    return f"{setting.category}/{setting.name}"


def variants_of(setting: Setting) -> tuple[Variant, ...]:
    """The setting's variants in fill order, base first."""
    key = setting_key(setting)
    return (Variant(BASE, None, text=BASE_TEXT.get(key, "")), *VARIANTS.get(key, ()))


def variant_params(setting: Setting, variant: Variant) -> dict[str, JSONScalar]:
    """A case's parameters: the setting's, overridden and extended by the variant's."""
    return {**setting.param_dict, **dict(variant.params)}
