"""Visual State Ambiguity: the physical state is unchanged; the other state is added as
visual-only geometry (never collides, never moves), so both states are seen at once.

- object_pose: an upside-down, visual-only copy of the target (a fixture: no joint, no collision
  geometry) stands at the free spot nearest the target (the distractors' spot rule); the real
  target starts upright as in LIBERO.
- receptacle_openness: no generator yet (see the report of issue 4); building such a case fails
  with a message saying so.
"""
from __future__ import annotations

from vpro_assets.scene.context import GenContext
from vpro_assets.scene.pose import INVERT, class_quat, quat_mul
from vpro_assets.scene.variant import SceneVariant
from vpro_assets.scene.visual_only import ghost_object

from . import register

GHOST_REGION_HALF = 0.001  # m: the copy is a fixture at a fixed spot (LIBERO jitters within this)
SURFACE_GAP = 0.001  # m between the table and the copy's lowest point


@register("visual_state_ambiguity/object_pose")
def object_pose(ctx: GenContext) -> SceneVariant:
    """An upside-down visual-only copy of the target stands next to the real, upright target."""
    target, category = ctx.task.target, ctx.task.target_category
    quat = quat_mul(INVERT, class_quat(ctx.base.object_classes[target]))
    sink = ctx.base.surface_z - ctx.base.fixture_z + SURFACE_GAP
    ghost = ghost_object(category, "inverted", quat, round(sink, 5))
    spot = ctx.free_spot(ctx.familiar_xy(target), ctx.target_pool().footprint_radius)
    instance = ctx.new_instance(ghost.name)
    region = ctx.region_at("vpro_ghost_region", spot, half=GHOST_REGION_HALF)
    return SceneVariant(
        case_id=ctx.case_id, generator="visual_state_ambiguity/object_pose",
        summary=f"a visual-only upside-down copy of {target} stands next to it",
        objects=list(ctx.base.bddl.objects), fixtures=list(ctx.base.bddl.fixtures) + [(instance, ghost.name)],
        regions=[region], init=ctx.init_with(add=[f"(On {instance} {region.full_name})"]),
        generated_objects=[ghost], added=[instance],
        details={"target": target, "visual_only": instance, "pose": "inverted",
                 "nominal_xy": [round(float(v), 4) for v in spot]},
    )
