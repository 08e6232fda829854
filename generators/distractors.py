"""Task-Relevant Distractors: six generators, each adding one object chosen by a stated rule.

Choice rules (over the pool of LIBERO's movable objects, `vpro_assets.scene.pool`; ties broken by
name, so every choice is deterministic; for the four "same ..." rules the best-ranked candidate
that has a free spot near the target is used):
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
- trajectory_obstacle: an object of another family, 6 cm across and at least 8 cm tall if the pool
  has one (closest to that), on the straight path from the target to where it goes (at 50, 40,
  60, 30 or 70% of it, the first clear of everything by 3 cm), or, where the path is too short,
  at the free spot nearest its midpoint; clear of target and receptacle, so a detour exists.
Placement: added objects sit at a nominal spot (the free-spot rule of `scene.context`, or the
rule's anchor) written as a 2 cm region in the BDDL, jittered per trial by up to 1.5 cm with the
trial's seed, clear of every other object; an object never overlaps the target or receptacle, so
the task stays physically possible.
"""
from __future__ import annotations

import math

import numpy as np

from vpro_assets.scene import pool as pool_mod
from vpro_assets.scene.context import GenContext
from vpro_assets.scene.variant import GeneratedObject, Placement, SceneVariant

from . import register

JITTER = 0.015
GRASP_ALIKE = {"flat": "bowl"}  # grasp class -> the class grasped the same way, when it has no other member
OBSTACLE_WIDTH, OBSTACLE_MIN_HEIGHT = 0.06, 0.08


def _size_gap(a: pool_mod.PoolObject, b: pool_mod.PoolObject) -> float:
    return abs(math.log(a.size / b.size))


def _pick(ctx: GenContext, candidates: list, key, rule: str) -> list[pool_mod.PoolObject]:
    if not candidates:
        raise ctx.fail(f"the {rule} rule finds no object in the pool for target {ctx.task.target_category!r}")
    return sorted(candidates, key=lambda p: (key(p), p.name))


def choose(ctx: GenContext, rule: str) -> list[pool_mod.PoolObject]:
    """The rule's candidates, best first (the first that fits the scene is used)."""
    target = ctx.target_pool()
    others = [p for p in pool_mod.pool().values() if p.name != target.name]
    size = lambda p: _size_gap(p, target)  # noqa: E731
    if rule in ("same_category", "familiar_position"):
        # Tiers: the target's category, then its family, then its grasp class; closest size first.
        tiers = [[p for p in others if p.category == target.category],
                 [p for p in others if p.family == target.family and p.category != target.category],
                 [p for p in others if p.grasp == target.grasp and p.family != target.family]]
        ranked = [q for tier in tiers for q in sorted(tier, key=lambda p: (size(p), p.name))]
        return _pick(ctx, ranked, lambda p: ranked.index(p), rule)
    if rule == "same_color":
        return _pick(ctx, [p for p in others if p.family != target.family], size, rule)
    if rule == "same_shape":
        return _pick(ctx, [p for p in others if p.category != target.category],
                     lambda p: (round(float(np.linalg.norm(p.aspect - target.aspect)), 6), size(p)), rule)
    if rule == "same_affordance":
        grasp = [p for p in others if p.grasp == target.grasp]
        grasp = grasp or [p for p in others if p.grasp == GRASP_ALIKE.get(target.grasp)]
        return _pick(ctx, [p for p in grasp if p.category != target.category] or grasp, size, rule)
    if rule == "trajectory_obstacle":
        fam = [p for p in others if p.family != target.family]
        tall = [p for p in fam if p.height >= OBSTACLE_MIN_HEIGHT] or fam
        return _pick(ctx, tall, lambda p: abs(max(p.footprint) - OBSTACLE_WIDTH), rule)
    raise ctx.fail(f"unknown distractor rule {rule!r}")


def _variant(ctx: GenContext, rule: str, category: str, spot: np.ndarray, summary: str,
             extra_placements: list[Placement] = (), generated: list[GeneratedObject] = (),
             init_replace: dict | None = None, extra_regions: list = (), details: dict | None = None,
             distractor_region_name: str | None = None) -> SceneVariant:
    instance = ctx.new_instance(category)
    regions = list(extra_regions)
    if distractor_region_name is None:
        region = ctx.region_at("vpro_distractor_region", spot)
        regions.append(region)
        distractor_region_name = region.full_name
    init = ctx.init_with(replace=init_replace, add=[f"(On {instance} {distractor_region_name})"])
    return SceneVariant(
        case_id=ctx.case_id, generator=f"task_relevant_distractors/{rule}", summary=summary,
        objects=list(ctx.base.bddl.objects) + [(instance, category)], fixtures=list(ctx.base.bddl.fixtures),
        regions=regions, init=init,
        placements=list(extra_placements) + [Placement(instance, tuple(spot), 0.0, JITTER)],
        generated_objects=list(generated), added=[instance],
        details={"rule": rule, "distractor": instance, "distractor_object": category,
                 "nominal_xy": [round(float(v), 4) for v in spot], **(details or {})},
    )


def _near_target(ctx: GenContext, rule: str):
    """The best candidate that has a free spot near the target, and that spot."""
    from generators import GeneratorError

    errors = []
    for chosen in choose(ctx, rule):
        try:
            return chosen, ctx.free_spot(ctx.familiar_xy(ctx.task.target), chosen.footprint_radius)
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
    return _variant(ctx, "same_affordance", chosen.name, spot,
                    f"adds {chosen.name}, grasped like the target ({chosen.grasp})")


@register("task_relevant_distractors/same_color")
def same_color(ctx: GenContext) -> SceneVariant:
    """Adds an object of another family recoloured with the target's dominant colour."""
    from vpro_assets.scene.recolor import recolored_object

    chosen, spot = _near_target(ctx, "same_color")
    color = ctx.target_pool().color
    generated = recolored_object(chosen.name, color)
    return _variant(ctx, "same_color", generated.name, spot,
                    f"adds {chosen.name} recoloured to the target's colour #{bytes(color).hex()}",
                    generated=[generated], details={"source_object": chosen.name, "color": list(color)})


@register("task_relevant_distractors/familiar_position")
def familiar_position(ctx: GenContext) -> SceneVariant:
    """A same-category object takes the target's familiar position; the target moves nearby."""
    chosen = choose(ctx, "familiar_position")[0]
    target = ctx.task.target
    familiar = ctx.familiar_xy(target)
    t_radius = ctx.target_pool().footprint_radius
    reach = t_radius + chosen.footprint_radius + 0.03
    radii = tuple(round(reach + d, 3) for d in (0.0, 0.03, 0.06, 0.09, 0.12, 0.15, 0.18))
    displaced = ctx.free_spot(familiar, t_radius, ignore=(target,), radii=radii)
    old = ctx.init_of(target)
    old_region = old.strip("()").split()[2]
    new_region = ctx.region_at("vpro_displaced_region", displaced)
    return _variant(
        ctx, "familiar_position", chosen.name, familiar,
        f"adds {chosen.name} at the target's familiar position; the target starts {np.linalg.norm(displaced - familiar):.2f} m away",
        extra_placements=[Placement(target, tuple(displaced), 0.0, JITTER)],
        init_replace={old: f"(On {target} {new_region.full_name})"}, extra_regions=[new_region],
        distractor_region_name=old_region,
        details={"familiar_xy": [round(float(v), 4) for v in familiar],
                 "target_displaced_xy": [round(float(v), 4) for v in displaced]},
    )


@register("task_relevant_distractors/trajectory_obstacle")
def trajectory_obstacle(ctx: GenContext) -> SceneVariant:
    """Adds an object on the straight path from the target to where the goal puts it."""
    chosen = choose(ctx, "trajectory_obstacle")[0]
    start, end = ctx.familiar_xy(ctx.task.target), ctx.destination_xy()
    radius = chosen.footprint_radius
    mid = start + 0.5 * (end - start)
    best = None
    for frac in (0.5, 0.4, 0.6, 0.3, 0.7):
        xy = start + frac * (end - start)
        if ctx.clearance(xy, radius) >= 0.03:
            best = np.round(xy, 4)
            break
    if best is None:  # the path is too short for an object between: the free spot nearest its midpoint
        best = ctx.free_spot(mid, radius, radii=(0.04, 0.07, 0.10, 0.13, 0.16, 0.20))
    return _variant(ctx, "trajectory_obstacle", chosen.name, best,
                    f"adds {chosen.name} on the path from the target to its destination",
                    details={"path": [[round(float(v), 4) for v in start], [round(float(v), 4) for v in end]]})
