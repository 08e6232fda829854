"""Task-Precondition Variation: the instruction is unchanged, the start state is not.

- receptacle_openness: the receptacle the target goes into (drawer, microwave) starts in the
  other state: its `(Open ...)` init predicate becomes `(Close ...)` (and vice versa; where the
  base task states none, the state is read from LIBERO's first initial state with the fixture's
  own `is_open` test and the other one is added), and every
  trial sets its joint to a value drawn from LIBERO's own closed (or open) range for it.
- object_pose: the target starts upside down (turned 180 degrees about the world x axis) at its
  LIBERO position of the trial, lowered onto the table and settled, so it rests in another
  stable pose. Where the turned target would touch a neighbour there (an inverted bowl's rim on
  a plate's rim tips it over and rolls it away), it starts at a spot nearby clear by 5 mm, if
  there is one (v2). The BDDL is the base task's (LIBERO's regions hold no orientation): the
  frozen initial states carry the pose.
"""

from __future__ import annotations

from vpro_assets.scene.context import GenContext
from vpro_assets.scene.plugins import register
from vpro_assets.scene.variant import JointSetting, Placement, SceneVariant


def openness_flip(ctx: GenContext) -> tuple[dict, list[JointSetting], str]:
    """(init predicate replacements, joint settings, new state) for the receptacle's other state."""
    task = ctx.task
    region = f"{task.receptacle}_{task.receptacle_region}" if task.receptacle_region else task.receptacle
    replace, new_state = {}, None
    for p in ctx.base.bddl.init:
        parts = p.strip("()").split()
        if len(parts) == 2 and parts[0].lower() in ("open", "close") and parts[1] in (region, task.receptacle):
            new_state = "close" if parts[0].lower() == "open" else "open"
            replace[p] = f"({new_state.capitalize()} {parts[1]})"
            region = parts[1]
    fixture = ctx.base.object_classes[task.receptacle]
    if new_state is None:
        # No predicate: read the state from LIBERO's first initial state with the fixture's own test.
        joints = ctx.base.site_joints.get(region) or ctx.base.site_joints.get(task.receptacle) or []
        if not joints:
            raise ctx.fail(f"no joint found for {region} in the base scene; cannot tell its open/closed state")
        slot = ctx.base.slots[joints[0]]
        q = float(ctx.base.rows[0][1 + slot.qpos.start])
        new_state = "close" if fixture.is_open(q) else "open"
        add = f"({new_state.capitalize()} {region})"
        replace["__add__"] = add
    ranges = fixture.object_properties["articulation"][f"default_{new_state}_ranges"]
    joints = ctx.base.site_joints.get(region) or ctx.base.site_joints.get(task.receptacle) or []
    if not joints:
        raise ctx.fail(f"no joint found for {region} in the base scene")
    return replace, [JointSetting(j, float(min(ranges)), float(max(ranges))) for j in joints], new_state


@register("task_precondition_variation/receptacle_openness")
def receptacle_openness(ctx: GenContext) -> SceneVariant:
    """The receptacle starts in the other open/closed state, so it must be opened (or closed) first."""
    replace, joints, new_state = openness_flip(ctx)
    add = [replace.pop("__add__")] if "__add__" in replace else []
    return SceneVariant(
        case_id=ctx.case_id,
        generator="task_precondition_variation/receptacle_openness",
        summary=f"{ctx.task.receptacle} starts {'closed' if new_state == 'close' else 'open'}",
        objects=list(ctx.base.bddl.objects),
        fixtures=list(ctx.base.bddl.fixtures),
        init=ctx.init_with(replace=replace, add=add),
        joints=joints,
        details={"receptacle": ctx.task.receptacle, "state": new_state, "joints": [j.joint for j in joints]},
    )


@register("task_precondition_variation/object_pose", version=2)
def object_pose(ctx: GenContext) -> SceneVariant:
    """The target starts upside down at its usual place (or next to it, clear of its neighbours)."""
    target = ctx.task.target
    return SceneVariant(
        case_id=ctx.case_id,
        generator="task_precondition_variation/object_pose",
        summary=f"{target} starts upside down",
        objects=list(ctx.base.bddl.objects),
        fixtures=list(ctx.base.bddl.fixtures),
        init=ctx.init_with(),
        placements=[Placement(target, (0.0, 0.0), margin=0.005, keep_xy=True, invert=True, clear_of_neighbours=True)],
        details={"target": target, "pose": "inverted"},
    )
