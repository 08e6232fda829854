"""Scene generators, one module per generator family, registered by name.

A generator turns one scene case (task x setting) into a `SceneVariant` (BDDL edits, generated
objects, initial-state placements); `vpro_assets.scene.build` turns that into files. The registry
refuses a second generator under a name already taken. A generator's `version` is part of every
artifact's input hash: changing what a generator does means bumping it.

Families (modules): `distractors` (6 settings), `precondition` (2), `geometry_scene` (12, using
the geometry pipeline's deformed objects from `target_geometry`). Visual State Ambiguity (2) has
no generator yet: its cases fail to build with a message saying so.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Callable

from vpro_assets.errors import VProError

FAMILY_MODULES = ("generators.distractors", "generators.precondition", "generators.ambiguity",
                  "generators.geometry_scene")


class GeneratorError(VProError):
    """A generator cannot produce a case (named with the case and the reason)."""


@dataclass(frozen=True)
class Generator:
    name: str  # "<category>/<setting name>", e.g. "task_relevant_distractors/same_color"
    version: int
    fn: Callable  # (GenContext) -> SceneVariant
    doc: str


_REGISTRY: dict[str, Generator] = {}


def register(name: str, version: int = 1):
    """Decorator: register `fn` as the generator of `name`; a duplicate name is refused."""

    def wrap(fn: Callable) -> Callable:
        if name in _REGISTRY:
            raise GeneratorError(f"generator {name!r} is already registered by {_REGISTRY[name].fn.__module__}; "
                                 f"refusing a second one from {fn.__module__}")
        _REGISTRY[name] = Generator(name, version, fn, " ".join((fn.__doc__ or "").split()))
        return fn

    return wrap


def _load_families() -> None:
    for module in FAMILY_MODULES:
        importlib.import_module(module)


def registry() -> dict[str, Generator]:
    _load_families()
    return dict(_REGISTRY)


def generator_for(case: dict) -> Generator:
    """The generator of a scene case, by its setting (category and name without version)."""
    _load_families()
    setting = case["setting"].removeprefix("vpro/")
    name = setting.rsplit("-v", 1)[0]
    if name not in _REGISTRY:
        raise GeneratorError(f"case {case['id']}: no generator registered for {name!r} "
                             f"(known: {', '.join(sorted(_REGISTRY))})")
    return _REGISTRY[name]


def built_case(case_id: str) -> dict:
    """Paths of a built scene case ({'bddl', 'init_states', 'init_states_npz', 'dir'}), with its
    generated objects registered in LIBERO so `make_env(..., bddl_file=...)` can build it."""
    from vpro_assets.scene.build import built_case as _built

    return _built(case_id)
