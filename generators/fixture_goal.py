"""What the distractor rules stand on when the goal has no movable target (libero_goal-00 "open
the middle layer of the drawer", libero_goal-07 "turn on the stove").

The target is then the fixture part the goal acts on. Its stand-in for the choice rules is the
movable object LIBERO's own tasks put into or onto that fixture (STAND_INS: the bowl that goes
into a cabinet drawer in libero_goal-03 and libero_10-03, the moka pot that goes on the stove in
libero_10-02 and libero_10-08), and the rules' anchor (the target's familiar position) is the
fixture's mean position. Per distractor type:
- same_category, same_color, same_shape, same_affordance: the rule applied to the stand-in
  (another bowl model next to the cabinet; an object recoloured to the stand-in's colour; ...),
  at the free spot nearest the fixture, as for a movable target.
- familiar_position: the same-category object stands as close to the fixture as it fits (where a
  target to be put into or onto it would stand); nothing is displaced, since a fixture stays put.
- trajectory_obstacle: on the reaching path, from where the gripper starts to the fixture.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.scene import pool as pool_mod
from vpro_assets.scene.context import GenContext

STAND_INS = {
    "wooden_cabinet": "akita_black_bowl",
    "white_cabinet": "akita_black_bowl",
    "flat_stove": "moka_pot",
    "microwave": "porcelain_mug",
}
# m from the fixture's position, nearest first: the familiar-position competitor stands as close as it fits.
CLOSE_RADII = tuple(round(0.06 + 0.02 * k, 3) for k in range(23))


def fixture_goal(ctx: GenContext) -> bool:
    return ctx.task.target is None


def acted_on(ctx: GenContext) -> str:
    """The articulated fixture a fixture-only goal acts on."""
    if not ctx.task.articulations:
        raise ctx.fail("a goal without a target and without an articulated fixture has no distractor anchor")
    return ctx.task.articulations[0].name


def reference(ctx: GenContext) -> pool_mod.PoolObject:
    """The target's pool entry, or the stand-in of the fixture a fixture-only goal acts on."""
    if not fixture_goal(ctx):
        return ctx.target_pool()
    category = ctx.task.category_of(acted_on(ctx))
    if category not in STAND_INS:
        raise ctx.fail(f"no distractor stand-in for fixture category {category!r} (known: {sorted(STAND_INS)})")
    return ctx.pool_object(STAND_INS[category])


def anchor_xy(ctx: GenContext) -> np.ndarray:
    """The target's familiar position, or the position of the fixture the goal acts on."""
    return ctx.familiar_xy(acted_on(ctx) if fixture_goal(ctx) else ctx.task.target)
