"""What a scene generator returns: a pure description of one case's scene variant.

A generator reads the task and the measured base scene and returns a `SceneVariant`: the BDDL
edits (objects, fixtures, regions, init predicates), the generated MJCF objects it needs, and how
each trial's initial state differs from LIBERO's initial state of the same trial index (objects
placed by a stated rule, a pose flipped, an articulation set to its other state). Simulation and
file writing happen elsewhere (`init_gen`, `build`), so a generator is a pure function of its
inputs and can be unit-tested without MuJoCo.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from vpro_assets.scene.bddl_doc import Region


@dataclass(frozen=True)
class Placement:
    """Where one movable object goes in every trial: on a ring around `anchor` (world xy), at a
    radius drawn in [r_min, r_max], clear of every other object by `margin`."""

    instance: str
    anchor: tuple[float, float]
    r_min: float = 0.0
    r_max: float = 0.01
    margin: float = 0.015
    invert: bool = False  # turned upside down (180 degrees about the world x axis)
    turn: tuple[float, float, float, float] | None = None  # another turn (w, x, y, z) applied like invert
    keep_xy: bool = False  # keep LIBERO's xy of this trial (only the pose or height changes)
    # With keep_xy: where the object would touch a neighbour at LIBERO's xy (a turned bowl's rim
    # landing on a plate's rim and rolling away), a clear spot on a ring around it instead.
    clear_of_neighbours: bool = False
    # Stand where this other instance stood in LIBERO's state of the trial (same footprint centre,
    # same lowest point: on the same support, in the same drawer); no clearance check, since that
    # instance is placed elsewhere first.
    take_place_of: str | None = None
    # With keep_xy and clear_of_neighbours: parts the task has the policy open, as (joint, value
    # it is opened to); the footprint starts clear of the ground each one's travel from where it
    # starts to that value covers, with room for the hand to come down beside it
    # (`travel.opened_sweep`, `init_gen._kept_spot`), at the nearest clear spot if it is not.
    clear_of_opened: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class JointSetting:
    """An articulation set to a value drawn uniformly from [low, high] in every trial."""

    joint: str
    low: float
    high: float
    # The part is taken to have come from this value (its closed end): objects on that way start
    # out of it (`SceneVariant.keep_clear`, `scene.travel`). None: set where it is, as before.
    travel_from: float | None = None


@dataclass(frozen=True)
class KeepClear:
    """An object a set part's travel must not pass through, and where it may start instead: the
    rectangle LIBERO places its origin in (its BDDL init region on the table), in world xy."""

    instance: str
    box: tuple[float, float, float, float]  # x0, y0, x1, y1


class WrittenObject(Protocol):
    """What a shared producer's `write` may return instead of the XML path: a record of it."""

    timings: dict[str, float]  # seconds per stage of the producer's own work
    peak_rss_mb: float  # of the child process the producer worked in, 0 if none

    @property
    def xml_path(self) -> Path: ...


@dataclass(frozen=True)
class GeneratedObject:
    """An MJCF object the case needs registered under `name` (see vpro_assets.objects.registry).
    `write(directory) -> xml_path` writes its files deterministically (a shared producer may return
    a `WrittenObject` record instead)."""

    name: str
    write: Callable[[Path], Path | WrittenObject] = field(compare=False)
    template: str | None = None  # LIBERO object whose placement attributes it copies
    shared: bool = False  # write(objects_root) manages its own caching and atomic layout


@dataclass
class SceneVariant:
    case_id: str
    generator: str
    summary: str  # one sentence for the BDDL header and the gallery
    objects: list[tuple[str, str]]  # full (instance, category) list of the variant
    fixtures: list[tuple[str, str]]
    regions: list[Region] = field(default_factory=list)  # added regions
    init: list[str] = field(default_factory=list)  # full init predicate list
    placements: list[Placement] = field(default_factory=list)
    joints: list[JointSetting] = field(default_factory=list)
    keep_clear: list[KeepClear] = field(default_factory=list)  # objects kept out of the joints' travel
    generated_objects: list[GeneratedObject] = field(default_factory=list)
    added: list[str] = field(default_factory=list)  # instances the variant adds (distractors, visual-only)
    details: Mapping[str, object] = field(default_factory=dict)  # the rule's choices, recorded in meta.json
