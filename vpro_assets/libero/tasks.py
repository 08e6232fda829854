"""The 40 base tasks as typed records parsed from LIBERO's own BDDL files.

Everything the applicability rules need is read from the task's structure (objects, fixtures,
goal predicates, articulation of the fixtures involved), never from its name or language.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable

from vpro_assets.core.errors import UnknownIdError
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.task_record import (  # noqa: F401 (re-exported)
    PLACEMENT_PREDICATES,
    TABLE_CATEGORIES,
    Articulation,
    TaskRecord,
    libero_instruction,
)


def _flatten(named: dict[str, list[str]]) -> tuple[tuple[str, str], ...]:
    return tuple((inst, cat) for cat, insts in named.items() for inst in insts)


def _resolve(arg: str, instances: Iterable[str]) -> tuple[str, str | None]:
    """Split a goal argument into (entity, region): `wooden_cabinet_1_top_region` ->
    (`wooden_cabinet_1`, `top_region`); LIBERO names regions `<entity>_<region>`."""
    best = max((i for i in instances if arg == i or arg.startswith(i + "_")), key=len, default=None)
    if best is None:
        return arg, None
    return best, (arg[len(best) + 1 :] or None)


@functools.cache
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
    goal = tuple((g[0].lower(), *g[1:]) for g in parsed["goal_state"])

    target = receptacle = region = relation = None
    for pred, *args in goal:
        if pred in PLACEMENT_PREDICATES and args[0] in movable:
            target, relation = args[0], pred
            dest, region = _resolve(args[1], instances)
            table = dict(fixtures).get(dest) in TABLE_CATEGORIES
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


@functools.cache
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
