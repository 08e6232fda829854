"""Visual State Ambiguity: the physical state is unchanged; the other state is added as
visual-only geometry (never collides, never moves), so both states are seen at once.

- object_pose: an upside-down, visual-only copy of the target (a fixture: no joint, no collision
  geometry) stands at the free spot nearest the target (the distractors' spot rule); the real
  target starts upright as in LIBERO. Variant `lying`: the copy lies on its side (turned 90
  degrees about the world x axis) instead.
- receptacle_openness: a visual-only copy of the moving part (drawer, door) of the container the
  task involves (`generators.precondition.container_part`) in the other state (the middle of
  LIBERO's open or closed range for that joint) is overlaid on the real fixture: both are fixtures
  placed at one region, the centre of the fixture's own region with its yaw fixed to the middle of
  LIBERO's range (LIBERO jitters each within 0.5 mm). The real drawer or door keeps its state and
  is the only one that collides or moves. Variant `open50`: the copy shows the part half way
  between LIBERO's closed and open ranges.
"""

from __future__ import annotations

from generators.precondition import container_part, opening_value, openness_flip
from vpro_assets.core.mjgeom import quat_mul
from vpro_assets.scene.bddl_doc import Region
from vpro_assets.scene.context import GenContext
from vpro_assets.scene.plugins import register
from vpro_assets.scene.pose import INVERT, LIE, class_quat
from vpro_assets.scene.variant import SceneVariant
from vpro_assets.scene.visual_only import articulation_ghost, ghost_object

GHOST_REGION_HALF = 0.001  # m: the copy is a fixture at a fixed spot (LIBERO jitters within this)
SURFACE_GAP = 0.001  # m between the table and the copy's lowest point


@register("visual_state_ambiguity/object_pose")
def object_pose(ctx: GenContext) -> SceneVariant:
    """An upside-down (or lying) visual-only copy of the target stands next to the real, upright target."""
    target, category = ctx.task.target, ctx.task.target_category
    pose = "lying" if ctx.case["params"].get("state") == "lying" else "inverted"
    quat = quat_mul(LIE if pose == "lying" else INVERT, class_quat(ctx.base.object_classes[target]))
    sink = ctx.base.surface_z - ctx.base.fixture_z + SURFACE_GAP
    ghost = ghost_object(category, pose, quat, round(sink, 5))
    spot = ctx.free_spot(ctx.familiar_xy(target), ctx.target_pool().footprint_radius)
    instance = ctx.new_instance(ghost.name)
    region = ctx.region_at("vpro_ghost_region", spot, half=GHOST_REGION_HALF)
    return SceneVariant(
        case_id=ctx.case_id,
        generator="visual_state_ambiguity/object_pose",
        summary=f"a visual-only {'lying' if pose == 'lying' else 'upside-down'} copy of {target} stands next to it",
        objects=list(ctx.base.bddl.objects),
        fixtures=list(ctx.base.bddl.fixtures) + [(instance, ghost.name)],
        regions=[region],
        init=ctx.init_with(add=[f"(On {instance} {region.full_name})"]),
        generated_objects=[ghost],
        added=[instance],
        details={
            "target": target,
            "visual_only": instance,
            "pose": pose,
            "nominal_xy": [round(float(v), 4) for v in spot],
        },
    )


FIXTURE_REGION_HALF = 0.0005  # m


@register("visual_state_ambiguity/receptacle_openness")
def receptacle_openness(ctx: GenContext) -> SceneVariant:
    """The involved drawer or door is also drawn, visual-only, in the other open/closed state (or half open)."""
    replace, joints, new_state = openness_flip(ctx)
    fixture, _ = container_part(ctx)
    category = ctx.task.category_of(fixture)
    joint = joints[0]
    value = (joint.low + joint.high) / 2
    label, shown = ("open" if new_state == "open" else "closed"), f"{new_state}d"  # base wording kept as built
    if "opening" in ctx.case["params"]:
        fraction = float(ctx.case["params"]["opening"])
        value, new_state, label = opening_value(ctx, fixture, fraction), "partly_open", f"open{int(fraction * 100)}"
        shown = f"{int(fraction * 100)}% open"
    ghost = articulation_ghost(category, joint.joint.removeprefix(f"{fixture}_"), value, label)
    old = ctx.init_of(fixture)
    old_region = ctx.base.bddl.parsed["regions"][old.strip("()").split()[2]]
    x0, y0, x1, y1 = old_region["ranges"][0]
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    yaw = sum(old_region["yaw_rotation"]) / 2
    h = FIXTURE_REGION_HALF
    region = Region(
        "vpro_fixture_region",
        old_region["target"],
        (round(cx - h, 5), round(cy - h, 5), round(cx + h, 5), round(cy + h, 5)),
        (yaw, yaw),
    )
    instance = ctx.new_instance(ghost.name)
    return SceneVariant(
        case_id=ctx.case_id,
        generator="visual_state_ambiguity/receptacle_openness",
        summary=f"{fixture} also shows its {joint.joint.removeprefix(fixture + '_')} {shown}, visual-only",
        objects=list(ctx.base.bddl.objects),
        fixtures=list(ctx.base.bddl.fixtures) + [(instance, ghost.name)],
        regions=[region],
        init=ctx.init_with(
            replace={old: f"(On {fixture} {region.full_name})"}, add=[f"(On {instance} {region.full_name})"]
        ),
        generated_objects=[ghost],
        added=[instance],
        details={
            "receptacle": fixture,
            "visual_only": instance,
            "shown_state": new_state,
            "joint": joint.joint,
            "joint_value": round(value, 5),
        },
    )
