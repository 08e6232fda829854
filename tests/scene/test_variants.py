"""Variants of a setting differ from its base case as documented (docs/taxonomy.md, Variants), and
fixture-only goals get every distractor type; checked on the generators' output and, for a pose, on
a settled initial state."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import scene_variant, start_trial, variant_env

from generators.fixture_goal import STAND_INS
from generators.precondition import container_part, opening_value
from vpro_assets.scene.pose import LIE


@pytest.mark.parametrize("level", ["open25", "open50", "open75"])
def test_a_partly_open_drawer_is_neither_open_nor_closed_and_between_the_base_states(level):
    base_ctx, base = scene_variant("libero_10-03/task_precondition_variation/receptacle_openness-v1")
    ctx, v = scene_variant(f"libero_10-03/task_precondition_variation/receptacle_openness-v1-{level}")
    fixture, region = container_part(ctx)
    assert (fixture, region) == ("white_cabinet_1", "white_cabinet_1_bottom_region")
    obj = ctx.base.object_classes[fixture]
    fraction = {"open25": 0.25, "open50": 0.5, "open75": 0.75}[level]
    [joint] = v.joints
    assert joint.joint == base.joints[0].joint and joint.low == joint.high == opening_value(ctx, fixture, fraction)
    assert not obj.is_open(joint.low) and not obj.is_close(joint.low)
    # LIBERO starts this drawer open: the variant drops the `(Open ...)` the base case turns into `(Close ...)`.
    assert "(Open white_cabinet_1_bottom_region)" in base_ctx.base.bddl.init
    assert not any("white_cabinet_1_bottom_region" in p and p.startswith(("(Open", "(Close")) for p in v.init)
    assert "(Close white_cabinet_1_bottom_region)" in base.init


def test_opening_levels_grow_toward_the_open_range():
    ctx, _ = scene_variant("libero_goal-00/task_precondition_variation/receptacle_openness-v1-open25")
    assert container_part(ctx) == ("wooden_cabinet_1", "wooden_cabinet_1_middle_region")
    values = [opening_value(ctx, "wooden_cabinet_1", f) for f in (0.0, 0.25, 0.5, 0.75, 1.0)]
    assert values == sorted(values, reverse=True)  # this cabinet opens toward negative joint values
    art = ctx.base.object_classes["wooden_cabinet_1"].object_properties["articulation"]
    assert values[0] == min(art["default_close_ranges"]) and values[-1] == max(art["default_open_ranges"])


def test_the_cabinet_top_task_involves_its_top_drawer():
    ctx, v = scene_variant("libero_goal-02/task_precondition_variation/receptacle_openness-v1")
    assert container_part(ctx) == ("wooden_cabinet_1", "wooden_cabinet_1_top_region")
    assert "(Open wooden_cabinet_1_top_region)" in v.init  # LIBERO starts it closed


def test_the_ambiguity_ghost_shows_the_half_open_level():
    ctx, v = scene_variant("libero_goal-03/visual_state_ambiguity/receptacle_openness-v1-open50")
    assert v.details["joint_value"] == opening_value(ctx, "wooden_cabinet_1", 0.5)
    assert v.details["shown_state"] == "partly_open" and "_open50_" in v.generated_objects[0].name


def test_lying_variants_turn_the_target_on_its_side():
    _, v = scene_variant("libero_spatial-00/task_precondition_variation/object_pose-v1-lying")
    [p] = v.placements
    assert p.turn == tuple(float(x) for x in LIE) and not p.invert and p.keep_xy
    _, ghost = scene_variant("libero_spatial-03/visual_state_ambiguity/object_pose-v1-lying")
    assert ghost.details["pose"] == "lying" and "_lying_" in ghost.generated_objects[0].name


@pytest.mark.parametrize("task", ["libero_goal-00", "libero_goal-07"])
@pytest.mark.parametrize(
    "kind",
    ["same_category", "same_color", "same_shape", "same_affordance", "familiar_position", "trajectory_obstacle"],
)
def test_fixture_only_goals_get_every_distractor_type_near_their_fixture(task, kind):
    ctx, v = scene_variant(f"{task}/task_relevant_distractors/{kind}-v1")
    fixture = ctx.task.articulations[0].name
    assert ctx.task.target is None and ctx.task.category_of(fixture) in STAND_INS
    [added] = v.added
    spot = np.asarray(v.details["nominal_xy"])
    assert np.linalg.norm(spot - ctx.familiar_xy(fixture)) < 0.55
    assert ctx.base.on_surface(spot) and ctx.base.in_view(spot)
    assert [p for p in v.placements if p.instance == added]


def test_a_lying_target_rests_on_its_side_after_settling(tmp_path):
    """The settled first trial of a lying case: the target's own up axis lies near the table plane."""
    from vpro_assets.scene import sim

    with variant_env("libero_object-00/task_precondition_variation/object_pose-v1-lying", tmp_path) as (ctx, v, env):
        base, raw = ctx.base, sim.raw(env)
        body = raw.sim.model.body_name2id(raw.objects_dict[ctx.task.target].root_body)
        sim.load_state(env, sim.map_state(base.rows[base.trial_rows[0]], base.slots, env))
        # The object's own axis that points up in LIBERO's state (its mesh's up need not be its z).
        own_up = raw.sim.data.body_xmat[body].reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])
        start_trial(env, ctx, v, 0)
        up = raw.sim.data.body_xmat[body].reshape(3, 3) @ own_up
    assert abs(up[2]) < 0.5, up  # upright would be 1, upside down -1
