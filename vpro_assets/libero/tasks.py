"""The 40 base tasks as typed records parsed from LIBERO's own BDDL files.

Everything the applicability rules need is read from the task's structure (objects, fixtures,
goal predicates, articulation of the fixtures involved), never from its name or language.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Iterable

from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.core.errors import UnknownIdError

# LIBERO's problem classes (the `(problem ...)` name selects the scene class).
PLACEMENT_PREDICATES = ("on", "in")


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


def libero_instruction(task_name: str) -> str:
    """LIBERO's `grab_language_from_filename`, restated because importing
    `libero.libero.benchmark` imports torch."""
    if task_name[0].isupper():  # libero_10/90 names carry a SCENE prefix
        cut = task_name.find("SCENE") + (8 if "SCENE10" in task_name else 7)
        return " ".join(task_name[cut:].split("_"))
    return " ".join(task_name.split("_"))


def _flatten(named: dict[str, list[str]]) -> tuple[tuple[str, str], ...]:
    return tuple((inst, cat) for cat, insts in named.items() for inst in insts)


def _resolve(arg: str, instances: Iterable[str]) -> tuple[str, str | None]:
    """Split a goal argument into (entity, region): `wooden_cabinet_1_top_region` ->
    (`wooden_cabinet_1`, `top_region`); LIBERO names regions `<entity>_<region>`."""
    best = max((i for i in instances if arg == i or arg.startswith(i + "_")), key=len, default=None)
    if best is None:
        return arg, None
    return best, (arg[len(best) + 1 :] or None)


@functools.lru_cache(maxsize=None)
def _articulation_kinds() -> dict[str, str]:
    """LIBERO object category -> articulation kind, from LIBERO's object registry."""
    envs = libero_bridge.libero_envs()
    from libero.libero.envs.objects.articulated_objects import ArticulatedObject

    kinds = {}
    for category, cls in envs.OBJECTS_DICT.items():
        if isinstance(cls, type) and issubclass(cls, ArticulatedObject):
            # The base class declares every state check; a subclass defines the ones it has.
            if hasattr(cls, "turn_on"):
                kinds[category] = "switchable"
            elif "is_open" in vars(cls):
                kinds[category] = "openable"
    return kinds


def parse_task(suite: str, index: int, name: str) -> TaskRecord:
    parsed = libero_bridge.bddl_parser().robosuite_parse_problem(str(libero_bridge.bddl_path(suite, name)))
    objects = _flatten(parsed["objects"])
    fixtures = _flatten(parsed["fixtures"])
    movable = {inst for inst, _ in objects}
    instances = [inst for inst, _ in objects + fixtures]
    goal = tuple(tuple([g[0].lower(), *g[1:]]) for g in parsed["goal_state"])

    target = receptacle = region = relation = None
    for pred, *args in goal:
        if pred in PLACEMENT_PREDICATES and args[0] in movable:
            target, relation = args[0], pred
            dest, region = _resolve(args[1], instances)
            table = dict(fixtures).get(dest) in ("table", "kitchen_table", "living_room_table", "study_table", "floor")
            receptacle = None if table else dest
            region = None if table else region
            relation = None if table else relation
            break

    kinds = _articulation_kinds()
    categories = dict(objects + fixtures)
    involved = {_resolve(a, instances)[0] for _, *args in goal for a in args}
    involved |= {_resolve(o, instances)[0] for o in parsed["obj_of_interest"]}
    articulations = tuple(
        Articulation(inst, categories[inst], kinds[categories[inst]])
        for inst in sorted(involved)
        if inst in categories and categories[inst] in kinds
    )
    return TaskRecord(
        suite=suite,
        index=index,
        name=name,
        language=" ".join(parsed["language_instruction"]),
        problem_class=parsed["problem_name"],
        objects=objects,
        fixtures=fixtures,
        objects_of_interest=tuple(parsed["obj_of_interest"]),
        goal=goal,
        target=target,
        receptacle=receptacle,
        receptacle_region=region,
        placement_relation=relation,
        articulations=articulations,
    )


@functools.lru_cache(maxsize=None)
def load_tasks() -> tuple[TaskRecord, ...]:
    """The 40 base tasks, suite by suite, in LIBERO's task order."""
    return tuple(
        parse_task(suite, index, name)
        for suite, names in libero_bridge.suite_task_names().items()
        for index, name in enumerate(names)
    )


def get_task(key: str) -> TaskRecord:
    """A task by key (`libero_goal-03`) or LIBERO task name."""
    tasks = load_tasks()
    for task in tasks:
        if key in (task.key, task.name):
            return task
    raise UnknownIdError("task", key, [t.key for t in tasks] + [t.name for t in tasks])
