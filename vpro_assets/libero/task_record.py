"""A base task as a typed record (`TaskRecord`), and LIBERO's instruction from a task's file name.

Standard library only: the observation perturbations need the record but not LIBERO, so this
module is part of the run-time layer copied into packs (`vpro_assets.packs.vendor`). Records are
parsed from LIBERO's BDDL files by `vpro_assets.libero.tasks`; `TaskRecord.from_json` reads the
form `to_json` writes (the catalog's `tasks` table, a pack's case files).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

# LIBERO's problem classes (the `(problem ...)` name selects the scene class).
PLACEMENT_PREDICATES = ("on", "in")
# Fixture classes whose regions are places on the table, not receptacles.
TABLE_CATEGORIES = ("table", "kitchen_table", "living_room_table", "study_table", "floor")


@dataclass(frozen=True)
class Articulation:
    name: str  # fixture instance, e.g. "wooden_cabinet_1"
    category: str  # LIBERO object class name, e.g. "wooden_cabinet"
    kind: str  # "openable" (doors, drawers) or "switchable" (stove knob)


@dataclass(frozen=True)
class TaskRecord:
    suite: str
    index: int  # position in LIBERO's task order for the suite
    name: str  # LIBERO's task name (the BDDL file stem)
    language: str
    problem_class: str
    objects: tuple[tuple[str, str], ...]  # (instance, category) of movable objects
    fixtures: tuple[tuple[str, str], ...]  # (instance, category) of fixtures
    objects_of_interest: tuple[str, ...]
    goal: tuple[tuple[str, ...], ...]  # goal predicates, lower-case name first
    target: str | None  # the first object the goal places, None for fixture-only goals
    receptacle: str | None  # the object or fixture the target goes on or into, None for the table
    receptacle_region: str | None  # region of the receptacle named by the goal, if any
    placement_relation: str | None  # "on" or "in"
    articulations: tuple[Articulation, ...] = field(default=())  # articulated entities the goal involves

    @property
    def key(self) -> str:
        """Short, stable task id: `libero_goal-03`."""
        return f"{self.suite}-{self.index:02d}"

    @property
    def bddl_relpath(self) -> str:
        return f"{self.suite}/{self.name}.bddl"

    @property
    def init_relpath(self) -> str:
        return f"{self.suite}/{self.name}.pruned_init"

    @property
    def instruction(self) -> str:
        """The prompt models are evaluated with: LIBERO's benchmark derives it from the task's file
        name (openpi, OpenVLA-OFT and LeRobot use it), and it can differ from the BDDL's
        `(:language ...)`, e.g. "open the top drawer and put the bowl inside" for a BDDL that says
        "Open the top layer of the drawer and put the bowl inside"."""
        return libero_instruction(self.name)

    def category_of(self, instance: str) -> str:
        return dict(self.objects + self.fixtures)[instance]

    @property
    def target_category(self) -> str | None:
        return self.category_of(self.target) if self.target else None

    @property
    def requires_grasp(self) -> bool:
        """The target must be lifted onto or into something (not pushed along the table)."""
        return self.target is not None and self.receptacle is not None

    @property
    def openable_receptacle(self) -> bool:
        """The target goes into something that opens and closes (a drawer, a microwave)."""
        return self.placement_relation == "in" and any(
            a.name == self.receptacle and a.kind == "openable" for a in self.articulations
        )

    def to_json(self) -> dict:
        return {
            "key": self.key,
            "suite": self.suite,
            "index": self.index,
            "name": self.name,
            "language": self.language,
            "instruction": self.instruction,
            "problem_class": self.problem_class,
            "objects": [list(o) for o in self.objects],
            "fixtures": [list(f) for f in self.fixtures],
            "objects_of_interest": list(self.objects_of_interest),
            "goal": [list(g) for g in self.goal],
            "target": self.target,
            "target_category": self.target_category,
            "receptacle": self.receptacle,
            "receptacle_region": self.receptacle_region,
            "placement_relation": self.placement_relation,
            "requires_grasp": self.requires_grasp,
            "articulations": [vars(a) for a in self.articulations],
            "bddl": self.bddl_relpath,
            "init_states": self.init_relpath,
        }

    @classmethod
    def from_json(cls, data: Mapping) -> TaskRecord:
        """The record `to_json` wrote (derived keys such as `key` and `instruction` are recomputed)."""
        return cls(
            suite=data["suite"],
            index=int(data["index"]),
            name=data["name"],
            language=data["language"],
            problem_class=data["problem_class"],
            objects=tuple((str(i), str(c)) for i, c in data["objects"]),
            fixtures=tuple((str(i), str(c)) for i, c in data["fixtures"]),
            objects_of_interest=tuple(data["objects_of_interest"]),
            goal=tuple(tuple(g) for g in data["goal"]),
            target=data["target"],
            receptacle=data["receptacle"],
            receptacle_region=data["receptacle_region"],
            placement_relation=data["placement_relation"],
            articulations=tuple(Articulation(**a) for a in data.get("articulations", ())),
        )


def libero_instruction(task_name: str) -> str:
    """LIBERO's `grab_language_from_filename`, restated because importing
    `libero.libero.benchmark` imports torch."""
    if task_name[0].isupper():  # libero_10/90 names carry a SCENE prefix
        cut = task_name.find("SCENE") + (8 if "SCENE10" in task_name else 7)
        return " ".join(task_name[cut:].split("_"))
    return " ".join(task_name.split("_"))
