"""The registry of scene generators: plug-ins register by name, the build finds them here.

A generator turns one scene case (task x setting) into a `SceneVariant` (BDDL edits, generated
objects, initial-state placements); `vpro_assets.scene.build` turns that into files. Generators
live outside the toolkit (the top-level `generators/` package, one module per family): they import
the toolkit, and the toolkit loads them by module name on first use, never by a static import, so
imports go one way. The registry refuses a second generator under a name already taken. A
generator's `version` is part of every artifact's input hash: changing what a generator does means
bumping it. A change that concerns only some of a generator's cases is a `revision` instead: a
function of the case record, cheap (no simulation), whose value (empty for the cases the change
leaves alone) enters the input hash of the cases it names and nothing else. Those cases are built
again; the others keep their hash, and the version in every case's BDDL stays, so a rebuilt case the
change leaves as it was keeps its bytes (target geometry's fit to an enclosed receptacle).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass

from vpro_assets.core.errors import GeneratorError

# Plug-in modules loaded on first use, each registering its generators.
FAMILY_MODULES = (
    "generators.distractors",
    "generators.precondition",
    "generators.ambiguity",
    "generators.geometry_scene",
)


@dataclass(frozen=True)
class Generator:
    name: str  # "<category>/<setting name>", e.g. "task_relevant_distractors/same_color"
    version: int
    fn: Callable  # (GenContext) -> SceneVariant
    doc: str
    revision: Callable[[dict], str] | None = None  # case record -> per-case revision ("" for none)

    def revision_of(self, case: dict) -> str:
        """The generator's revision for `case` ("" where it has none)."""
        return self.revision(case) if self.revision is not None else ""


_REGISTRY: dict[str, Generator] = {}


def register(
    name: str, version: int = 1, revision: Callable[[dict], str] | None = None
) -> Callable[[Callable], Callable]:
    """Decorator: register `fn` as the generator of `name` (with a per-case `revision`, see the
    module doc); a duplicate name is refused."""

    def wrap(fn: Callable) -> Callable:
        if name in _REGISTRY:
            raise GeneratorError(
                f"generator {name!r} is already registered by {_REGISTRY[name].fn.__module__}; "
                f"refusing a second one from {fn.__module__}"
            )
        _REGISTRY[name] = Generator(name, version, fn, " ".join((fn.__doc__ or "").split()), revision)
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
        raise GeneratorError(
            f"case {case['id']}: no generator registered for {name!r} (known: {', '.join(sorted(_REGISTRY))})"
        )
    return _REGISTRY[name]
