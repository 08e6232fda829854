"""Task-Relevant Distractors: six generators, each adding one object chosen by a stated rule.

Choice rules (over the pool of LIBERO's movable objects, `vpro_assets.scene.pool`; ranked in
`generators.distractor_choice`, ties broken by name, so every choice is deterministic; for the
four "same ..." rules the best-ranked candidate that has a free spot near the target is used):
- same_category: an object of the target's category (another model), else of its family, else
  of its grasp class; the closest in size within a tier.
- same_color: the object of another family closest in size, recoloured with the target's
  dominant colour (a generated MJCF object registered under its own name).
- same_shape: the object of another category whose bounding-box aspect ratios are closest.
- same_affordance: an object of the target's grasp class (bowl, box, bottle, handle, can, flat)
  and another category (else another model of the same class), closest in size; a class with
  no other member takes the class grasped the same way (GRASP_ALIKE: a plate, the only flat
  object, is pinched at its rim like a bowl).
- familiar_position: the same-category object stands at the target's familiar position (mean of
  its position over LIBERO's 50 initial states); the target is displaced to the nearest free spot.
  The best-ranked candidate that fits there (1.5 cm from every other object in every trial) is
  used; where none fits (a crowded table) or the target starts on or in something (a ramekin, a
  drawer, a cabinet top), the best-ranked candidate at most 10% wider than the target takes the
  target's exact place in each trial instead (same support, same footprint centre).
- trajectory_obstacle: an object of another family, 6 cm across and at least 8 cm tall if the pool
  has one (closest to that), on the straight path from the target to where it goes (at 50, 40,
  60, 30 or 70% of it, the first clear of everything by 3 cm), or, where the path is too short,
  at the free spot nearest its midpoint; clear of target and receptacle, so a detour exists.
  Where neither fits (a crowded path, e.g. to a cabinet in libero_goal), the thinnest tall object
  of another family goes to the point within 6 cm of the path (20-80% of its length) with the most
  room, if that leaves at least 1 mm beyond its padded footprint to everything in every trial;
  where the carrying path has no such room either (a mug right in front of the microwave it goes
  into), the same search runs on the reaching path, from where the gripper starts to the target.
Fixture-only goals (open a drawer, turn on the stove): each rule as documented in
`generators.fixture_goal`, with a stand-in object for the target and the fixture as the anchor.
Placement: added objects sit at a nominal spot (the free-spot rule of `scene.context`, or the
rule's anchor) written as a 2 cm region in the BDDL, jittered per trial by up to 1.5 cm with the
trial's seed, clear of every other object; an object never overlaps the target or receptacle, so
the task stays physically possible.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from generators.distractor_choice import choose
from generators.fixture_goal import CLOSE_RADII, acted_on, anchor_xy, fixture_goal, reference
from vpro_assets.core.errors import GeneratorError
from vpro_assets.scene.bddl_doc import Region
from vpro_assets.scene.context import GenContext
from vpro_assets.scene.plugins import register
from vpro_assets.scene.recolor import recolored_object
from vpro_assets.scene.revisions import stuck_revision
from vpro_assets.scene.variant import GeneratedObject, Placement, SceneVariant

JITTER = 0.015
ON_TABLE_TOL = 0.01  # m: a target whose lowest point is further from the table surface rests on something
FAMILIAR_ROOM = 0.015  # m: room a competitor needs around the familiar position (the trial placement margin)
TAKE_PLACE_WIDTH = 1.1  # a competitor taking the target's exact place is at most this much wider than the target
CROWDED_CLEARANCE = 0.001  # m: least room (beyond the 10% padded footprint radius) around an obstacle on a crowded path


def _variant(
    ctx: GenContext,
    rule: str,
    category: str,
    spot: np.ndarray,
    summary: str,
    extra_placements: Sequence[Placement] = (),
    generated: Sequence[GeneratedObject] = (),
    init_replace: dict | None = None,
    extra_regions: Sequence[Region] = (),
    details: dict | None = None,
    distractor_region_name: str | None = None,
    distractor_predicate: str = "On",
    placement: dict | None = None,
) -> SceneVariant:
    """`placement`: Placement fields of the added object other than instance and anchor (default:
    jittered by up to JITTER around the spot)."""
    instance = ctx.new_instance(category)
    regions = list(extra_regions)
    if distractor_region_name is None:
        region = ctx.region_at("vpro_distractor_region", spot)
        regions.append(region)
        distractor_region_name = region.full_name
    init = ctx.init_with(replace=init_replace, add=[f"({distractor_predicate} {instance} {distractor_region_name})"])
    return SceneVariant(
        case_id=ctx.case_id,
        generator=f"task_relevant_distractors/{rule}",
        summary=summary,
        objects=list(ctx.base.bddl.objects) + [(instance, category)],
        fixtures=list(ctx.base.bddl.fixtures),
        regions=regions,
        init=init,
        placements=list(extra_placements) + [Placement(instance, tuple(spot), **(placement or {"r_max": JITTER}))],
        generated_objects=list(generated),
        added=[instance],
        details={
            "rule": rule,
            "distractor": instance,
            "distractor_object": category,
            "nominal_xy": [round(float(v), 4) for v in spot],
            **(details or {}),
        },
    )


def _near_target(ctx: GenContext, rule: str):
    """The best candidate that has a free spot near the target, and that spot."""
    errors = []
    for chosen in choose(ctx, rule):
        try:
            return chosen, ctx.free_spot(anchor_xy(ctx), chosen.footprint_radius)
        except GeneratorError as exc:
            errors.append(f"{chosen.name}: {exc}")
    raise ctx.fail(f"no {rule} candidate fits near the target ({'; '.join(errors[:3])})")


@register("task_relevant_distractors/same_category")
def same_category(ctx: GenContext) -> SceneVariant:
    """Adds an object of the target's category (another model) next to the target."""
    chosen, spot = _near_target(ctx, "same_category")
    return _variant(ctx, "same_category", chosen.name, spot, f"adds {chosen.name}, same category as the target")


@register("task_relevant_distractors/same_shape")
def same_shape(ctx: GenContext) -> SceneVariant:
    """Adds the object whose bounding-box aspect ratios are closest to the target's."""
    chosen, spot = _near_target(ctx, "same_shape")
    return _variant(ctx, "same_shape", chosen.name, spot, f"adds {chosen.name}, shaped like the target")


@register("task_relevant_distractors/same_affordance")
def same_affordance(ctx: GenContext) -> SceneVariant:
    """Adds an object grasped the same way as the target (same grasp class)."""
    chosen, spot = _near_target(ctx, "same_affordance")
    return _variant(
        ctx, "same_affordance", chosen.name, spot, f"adds {chosen.name}, grasped like the target ({chosen.grasp})"
    )


@register("task_relevant_distractors/same_color")
def same_color(ctx: GenContext) -> SceneVariant:
    """Adds an object of another family recoloured with the target's dominant colour."""
    chosen, spot = _near_target(ctx, "same_color")
    color = reference(ctx).color
    generated = recolored_object(chosen.name, color)
    return _variant(
        ctx,
        "same_color",
        generated.name,
        spot,
        f"adds {chosen.name} recoloured to the target's colour #{bytes(color).hex()}",
        generated=[generated],
        details={"source_object": chosen.name, "color": list(color)},
    )


def _on_table(ctx: GenContext, instance: str) -> bool:
    low = float(np.median([layout[instance]["lo"][2] for layout in ctx.base.layouts]))
    return abs(low - ctx.base.surface_z) < ON_TABLE_TOL


@register("task_relevant_distractors/familiar_position", version=2, revision=stuck_revision)
def familiar_position(ctx: GenContext) -> SceneVariant:
    """A same-category object takes the target's familiar position; the target moves nearby."""
    if fixture_goal(ctx):
        return _familiar_fixture(ctx)
    target = ctx.task.target
    ranked = choose(ctx, "familiar_position")
    familiar = ctx.familiar_xy(target)
    on_table = _on_table(ctx, target)
    fits = [
        p for p in ranked if on_table and ctx.clearance(familiar, p.footprint_radius, ignore=(target,)) >= FAMILIAR_ROOM
    ]
    take_place = not fits
    if fits:
        chosen = fits[0]
    else:  # it takes the target's exact place (on the table, on a ramekin, in a drawer): it must fit there
        width = max(ctx.target_pool().footprint)
        narrow = [p for p in ranked if max(p.footprint) <= TAKE_PLACE_WIDTH * width]
        if not narrow:
            raise ctx.fail(
                f"no familiar_position candidate fits at the familiar position or is as narrow as "
                f"{target} ({width:.3f} m) to take its place"
            )
        chosen = narrow[0]
    t_radius = ctx.target_pool().footprint_radius
    reach = t_radius + chosen.footprint_radius + 0.03
    radii = tuple(round(reach + 0.03 * k, 3) for k in range(11))  # nearest first, up to 30 cm further
    displaced = ctx.free_spot(familiar, t_radius, ignore=(target,), radii=radii)
    old = ctx.init_of(target)
    predicate, _, old_region = old.strip("()").split()
    new_region = ctx.region_at("vpro_displaced_region", displaced)
    where = f"the target's place ({predicate.lower()} {old_region})" if take_place else "the target's familiar position"
    return _variant(
        ctx,
        "familiar_position",
        chosen.name,
        familiar,
        f"adds {chosen.name} at {where}; the target starts {np.linalg.norm(displaced - familiar):.2f} m away",
        extra_placements=[Placement(target, tuple(displaced), 0.0, JITTER)],
        init_replace={old: f"(On {target} {new_region.full_name})"},
        extra_regions=[new_region],
        distractor_region_name=old_region,
        distractor_predicate=predicate,
        placement={"take_place_of": target} if take_place else None,
        details={
            "familiar_xy": [round(float(v), 4) for v in familiar],
            "takes_target_place": take_place,
            "target_displaced_xy": [round(float(v), 4) for v in displaced],
        },
    )


@register("task_relevant_distractors/trajectory_obstacle")
def trajectory_obstacle(ctx: GenContext) -> SceneVariant:
    """Adds an object on the straight path from the target to where the goal puts it."""
    chosen = choose(ctx, "trajectory_obstacle")[0]
    # A fixture-only goal has no carrying path: the reaching path, from the gripper to the fixture.
    start, end = (ctx.base.gripper_xy, anchor_xy(ctx)) if fixture_goal(ctx) else (anchor_xy(ctx), ctx.destination_xy())
    radius = chosen.footprint_radius
    mid = start + 0.5 * (end - start)
    best = None
    for frac in (0.5, 0.4, 0.6, 0.3, 0.7):
        xy = start + frac * (end - start)
        if ctx.clearance(xy, radius) >= 0.03:
            best = np.round(xy, 4)
            break
    placement, path_name = None, "carrying"
    if best is None:  # the path is too short for an object between: the free spot nearest its midpoint
        try:
            best = ctx.free_spot(mid, radius, radii=(0.04, 0.07, 0.10, 0.13, 0.16, 0.20))
        except GeneratorError:
            chosen, best, path_name = _crowded_path_spot(ctx, start, end)
            placement = {"r_max": 0.0, "margin": CROWDED_CLEARANCE / 2}  # no jitter: its room holds in every trial
    return _variant(
        ctx,
        "trajectory_obstacle",
        chosen.name,
        best,
        f"adds {chosen.name} on the path from the target to its destination"
        if path_name == "carrying"
        else f"adds {chosen.name} on the path the gripper takes to reach the target",
        placement=placement,
        details={
            "path": [[round(float(v), 4) for v in start], [round(float(v), 4) for v in end]],
            **({} if path_name == "carrying" else {"obstructs": path_name}),
        },
    )


def _familiar_fixture(ctx: GenContext) -> SceneVariant:
    """Fixture-only goal: the stand-in's same-category object as close to the fixture as it fits."""
    fixture, errors = acted_on(ctx), []
    for chosen in choose(ctx, "familiar_position"):
        try:
            spot = ctx.free_spot(anchor_xy(ctx), chosen.footprint_radius, radii=CLOSE_RADII)
        except GeneratorError as exc:
            errors.append(f"{chosen.name}: {exc}")
            continue
        return _variant(
            ctx,
            "familiar_position",
            chosen.name,
            spot,
            f"adds {chosen.name} right next to {fixture}, where an object to go into or onto it would stand",
            details={"familiar_xy": [round(float(v), 4) for v in anchor_xy(ctx)], "stands_for": fixture},
        )
    raise ctx.fail(f"no familiar_position candidate fits next to {fixture} ({'; '.join(errors[:3])})")


def _crowded_path_spot(ctx: GenContext, start: np.ndarray, end: np.ndarray):
    """The thinnest tall obstacle, the point near the carrying path (else the reaching path) with
    the most room for it, and which path that is."""
    chosen = min(choose(ctx, "trajectory_obstacle"), key=lambda p: (p.footprint_radius, p.name))
    tried = []
    for name, (a, b) in (("carrying", (start, end)), ("reaching", (ctx.base.gripper_xy, start))):
        xy, room = _roomiest_near(ctx, a, b, chosen.footprint_radius)
        if xy is not None and room >= CROWDED_CLEARANCE:
            return chosen, xy, name
        tried.append(f"{name} path: at most {room * 1000:.1f} mm")
    raise ctx.fail(
        f"no room for a trajectory obstacle ({chosen.name}) near the path to the destination "
        f"({end[0]:.3f}, {end[1]:.3f}): {'; '.join(tried)}"
    )


def _roomiest_near(ctx: GenContext, a: np.ndarray, b: np.ndarray, radius: float):
    """(point, room) within 6 cm of segment a-b (20-80% of its length) with the most room."""
    path = b - a
    if np.linalg.norm(path) < 1e-6:
        return None, -math.inf
    normal = np.array([-path[1], path[0]]) / np.linalg.norm(path)
    lo, hi = ctx.bounds()
    best, room = None, -math.inf
    for frac in np.linspace(0.2, 0.8, 13):
        for offset in np.linspace(-0.06, 0.06, 13):
            xy = np.round(a + frac * path + offset * normal, 4)
            if np.any(xy < lo) or np.any(xy > hi) or not ctx.base.in_view(xy):
                continue
            gap = ctx.clearance(xy, radius)
            if gap > room + 1e-9:
                best, room = xy, gap
    return best, room
