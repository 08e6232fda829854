"""The distractor choice rules (see `generators.distractors`): every candidate of the pool of
LIBERO's movable objects for a rule, best first, ties broken by name."""

from __future__ import annotations

import math

import numpy as np

from generators.fixture_goal import reference
from vpro_assets.scene import pool as pool_mod
from vpro_assets.scene.context import GenContext

GRASP_ALIKE = {"flat": "bowl"}  # grasp class -> the class grasped the same way, when it has no other member
OBSTACLE_WIDTH, OBSTACLE_MIN_HEIGHT = 0.06, 0.08


def _size_gap(a: pool_mod.PoolObject, b: pool_mod.PoolObject) -> float:
    return abs(math.log(a.size / b.size))


def _pick(ctx: GenContext, candidates: list, key, rule: str) -> list[pool_mod.PoolObject]:
    if not candidates:
        raise ctx.fail(f"the {rule} rule finds no object in the pool for target {reference(ctx).name!r}")
    return sorted(candidates, key=lambda p: (key(p), p.name))


def choose(ctx: GenContext, rule: str) -> list[pool_mod.PoolObject]:
    """The rule's candidates, best first (the first that fits the scene is used)."""
    target = reference(ctx)  # the target, or the stand-in of a fixture-only goal's fixture
    others = [p for p in pool_mod.pool().values() if p.name != target.name]
    size = lambda p: _size_gap(p, target)  # noqa: E731
    if rule in ("same_category", "familiar_position"):
        # Tiers: the target's category, then its family, then its grasp class; closest size first.
        tiers = [
            [p for p in others if p.category == target.category],
            [p for p in others if p.family == target.family and p.category != target.category],
            [p for p in others if p.grasp == target.grasp and p.family != target.family],
        ]
        ranked = [q for tier in tiers for q in sorted(tier, key=lambda p: (size(p), p.name))]
        return _pick(ctx, ranked, lambda p: ranked.index(p), rule)
    if rule == "same_color":
        return _pick(ctx, [p for p in others if p.family != target.family], size, rule)
    if rule == "same_shape":
        return _pick(
            ctx,
            [p for p in others if p.category != target.category],
            lambda p: (round(float(np.linalg.norm(p.aspect - target.aspect)), 6), size(p)),
            rule,
        )
    if rule == "same_affordance":
        grasp = [p for p in others if p.grasp == target.grasp]
        grasp = grasp or [p for p in others if p.grasp == GRASP_ALIKE.get(target.grasp)]
        return _pick(ctx, [p for p in grasp if p.category != target.category] or grasp, size, rule)
    if rule == "trajectory_obstacle":
        fam = [p for p in others if p.family != target.family]
        tall = [p for p in fam if p.height >= OBSTACLE_MIN_HEIGHT] or fam
        return _pick(ctx, tall, lambda p: abs(max(p.footprint) - OBSTACLE_WIDTH), rule)
    raise ctx.fail(f"unknown distractor rule {rule!r}")
