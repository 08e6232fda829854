"""Placement rules for crowded scenes, checked on the generators' output (no settling): the cases
that failed the first full build because the rules had no answer for them."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import scene_variant, start_trial, variant_env

from vpro_assets.scene.base_scene import base_scene


def test_target_resting_on_a_ramekin_leaves_its_exact_place_to_a_no_wider_competitor():
    ctx, v = scene_variant("libero_spatial-05/task_relevant_distractors/familiar_position-v1")
    competitor = next(p for p in v.placements if p.instance in v.added)
    assert competitor.take_place_of == ctx.task.target
    chosen = ctx.pool_object(v.details["distractor_object"])
    assert max(chosen.footprint) <= 1.1 * max(ctx.target_pool().footprint)
    # in LIBERO's BDDL dialect, on the same support the target stood on
    assert f"(On {v.details['distractor']} glazed_rim_porcelain_ramekin_1)" in v.init


def test_obstacle_for_a_mug_in_front_of_the_microwave_blocks_the_reaching_path_with_room_to_spare():
    ctx, v = scene_variant("libero_10-09/task_relevant_distractors/trajectory_obstacle-v1")
    assert v.details["obstructs"] == "reaching"
    spot = np.asarray(v.placements[-1].anchor)
    start, gripper = ctx.familiar_xy(ctx.task.target), ctx.base.gripper_xy
    path = start - gripper
    t = float(np.dot(spot - gripper, path) / np.dot(path, path))
    lateral = abs(np.cross(path / np.linalg.norm(path), spot - gripper))
    assert 0.199 <= t <= 0.801 and lateral <= 0.0605  # on the reaching path (spots are rounded to 0.1 mm)
    radius = ctx.pool_object(v.details["distractor_object"]).footprint_radius
    assert ctx.clearance(spot, radius) >= 0.001  # clear of everything in every trial layout


def test_a_plate_gets_a_same_affordance_distractor_from_the_bowl_class():
    ctx, v = scene_variant("libero_goal-05/task_relevant_distractors/same_affordance-v1")
    assert ctx.target_pool().grasp == "flat"
    assert ctx.pool_object(v.details["distractor_object"]).grasp == "bowl"


def test_trials_skip_libero_initial_states_that_drop_an_object_off_the_table():
    """Under the pinned MuJoCo every LIBERO row of libero_10-00 is sound (under 3.8.1 its row 2
    dropped the cream cheese on the floor). A row whose cream cheese stands beyond the table's edge
    is replaced by the next sound row after the first 10."""
    from vpro_assets.libero import bridge as libero_bridge
    from vpro_assets.libero.env import libero_init_states
    from vpro_assets.libero.tasks import get_task
    from vpro_assets.scene import sim
    from vpro_assets.scene.base_scene import _sound_rows

    assert base_scene("libero_10-00").trial_rows == list(range(10))
    task = get_task("libero_10-00")
    rows = np.array(libero_init_states(task))
    env = sim.physics_env(str(libero_bridge.bddl_path(task.suite, task.name)))
    try:
        joint = sim.raw(env).objects_dict["cream_cheese_1"].joints[-1]
        rows[2][1 + sim.joint_slots(env)[joint].qpos.start] += 1.0  # 1 m along x: off the table
        trial_rows = _sound_rows(env, rows, 10, task.key)
    finally:
        env.close()
    assert trial_rows[:2] == [0, 1] and trial_rows[3:] == list(range(3, 10))
    assert trial_rows[2] == 10


def test_base_scene_layouts_do_not_depend_on_the_process_random_state():
    """Fixtures are placed at seed 0 before measuring, whatever numpy's global stream holds."""
    cabinets = []
    for seed in (0, 7):
        np.random.seed(seed)  # what another process (or an earlier env) leaves behind
        base_scene.cache_clear()
        cabinets.append(base_scene("libero_spatial-04").layouts[0]["wooden_cabinet_1"]["lo"].copy())
    base_scene.cache_clear()
    np.testing.assert_array_equal(cabinets[0], cabinets[1])


def test_an_inverted_bowl_next_to_a_plate_moves_clear_and_rests_upside_down(tmp_path):
    """libero_goal-03 trial 0: at LIBERO's spot the turned bowl's rim lands on the plate's rim, tips
    and rolls 21 cm onto the stove (the v1 build failed there). It must start clear of the plate,
    nearby, and stay upside down. (Nearby: since revision opened1 it also starts clear of the
    drawer the task opens, the next test, at most SPOT_REACH_M away; it was within 5 cm before.)"""
    from vpro_assets.scene import sim
    from vpro_assets.scene.init_gen import SPOT_REACH_M

    with variant_env("libero_goal-03/task_precondition_variation/object_pose-v1", tmp_path) as (ctx, v, env):
        start_trial(env, ctx, v, 0)
        bowl = ctx.task.target
        qpos, _ = sim.free_object_state(env)[bowl]
        body = sim.raw(env).sim.model.body_name2id(sim.raw(env).objects_dict[bowl].root_body)
        up = sim.raw(env).sim.data.body_xmat[body].reshape(3, 3)[:, 2]  # the bowl's own z axis
        b, plate = (sim.body_layout(env)[n] for n in (bowl, "plate_1"))
    was = ctx.base.layouts[0][bowl]["pos"]
    assert 0.005 < np.linalg.norm(qpos[:2] - was[:2]) < SPOT_REACH_M  # moved, not far
    assert np.any(b["lo"][:2] > plate["hi"][:2]) or np.any(plate["lo"][:2] > b["hi"][:2])  # off the plate
    assert up[2] < -0.95  # still upside down, not tipped onto its side


def test_an_inverted_bowl_starts_out_from_under_the_drawer_the_task_opens(tmp_path):
    """libero_goal-03 ("open the top drawer and put the bowl inside"), object_pose (revision opened1):
    LIBERO's bowl stands in front of the cabinet, under where the top drawer comes out. Upside down,
    its one grasp is a pinch of its foot from above, and with the drawer open (which the goal needs
    first) the drawer front stood 2.4 cm beside the pinch: the wrist hit it (0 of 10 certified).
    The bowl must start with its footprint clear of the ground the drawer covers from closed to
    the far edge of LIBERO's open range, by the hand's room, and still upside down and at rest."""
    from vpro_assets.core.mjgeom import colliding, geom_corners, subtree
    from vpro_assets.scene import sim
    from vpro_assets.scene.init_gen import HAND_ROOM_M

    with variant_env("libero_goal-03/task_precondition_variation/object_pose-v1", tmp_path) as (ctx, v, env):
        raw = sim.raw(env)
        model, data = raw.sim.model._model, raw.sim.data._data
        joint = "wooden_cabinet_1_top_level"
        assert v.placements[0].clear_of_opened == ((joint, -0.16),)  # LIBERO's open range is [-0.16, -0.14]
        drawer = set(subtree(model, int(model.jnt_bodyid[raw.sim.model.joint_name2id(joint)])))
        geoms = colliding(model, [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) in drawer])
        for trial in (0, 3):
            start_trial(env, ctx, v, trial)
            bowl = sim.body_layout(env)[ctx.task.target]
            up = data.xmat[raw.sim.model.body_name2id(raw.objects_dict[ctx.task.target].root_body)][8]
            assert up < -0.95 and not sim.moving_objects(env), trial  # upside down, at rest
            # The drawer's ground, closed and open: a slide's travel covers the box around both.
            corners = []
            for q in (float(raw.sim.data.get_joint_qpos(joint)), -0.16):
                raw.sim.data.set_joint_qpos(joint, q)
                mujoco.mj_kinematics(model, data)
                corners.append(geom_corners(model, data, geoms))
            pts = np.concatenate(corners)
            lo, hi = pts.min(0)[:2], pts.max(0)[:2]
            gap = np.maximum(np.maximum(lo - bowl["hi"][:2], bowl["lo"][:2] - hi), 0.0)
            # The bowl is round: its box's corners are empty, so clear by the hand's room along x
            # or y, or by the hand's room less the corner's empty part diagonally.
            assert np.max(gap) >= HAND_ROOM_M or np.linalg.norm(gap) >= HAND_ROOM_M - 0.015, (trial, gap)


def test_a_mug_in_the_sweep_of_a_door_set_ajar_starts_out_of_it_in_its_region(tmp_path):
    """libero_10-09 trial 7 with the microwave door set 75% open: the door panel cuts through the mug
    where LIBERO places it (11.6 mm deep; the first full build failed the case on every attempt, v2
    then slid the mug out along the contact). Since travel1 the mug starts at a spot of its own
    LIBERO region (+-2.5 cm about the table's origin) that the door's travel leaves clear: no
    door/mug contact, and at rest."""
    from vpro_assets.scene import sim

    cid, trial = "libero_10-09/task_precondition_variation/receptacle_openness-v1-open75", 7
    with variant_env(cid, tmp_path) as (ctx, v, env):
        start_trial(env, ctx, v, trial)
        mug = ctx.task.target
        touching = [p for a, b, p in sim.penetrations(env, 0.0) if "microdoor" in a + b and mug in a + b]
        qpos, _ = sim.free_object_state(env)[mug]
        moving = sim.moving_objects(env)
    assert not touching, touching
    assert np.all(np.abs(qpos[:2]) <= 0.025), qpos[:2]
    assert not moving


def test_a_drawer_set_closed_never_starts_jammed_in_its_cabinet(tmp_path):
    """libero_10-03's bottom drawer set closed (precondition receptacle openness): v1 drew trials
    1, 5, 6 and 7 between 2.5 and 4.5 mm into LIBERO's closed range, where the drawer front cuts
    into the cabinet's base plate and MuJoCo holds it with kilonewtons (a 5 kN pull did not move it).
    Every trial must start closed (LIBERO's own test), free of its cabinet, and move under a gentle
    push; and the push finds a drawer set 4 mm in jammed."""
    from vpro_assets.scene import sim, start_checks

    cid = "libero_10-03/task_precondition_variation/receptacle_openness-v1"
    with variant_env(cid, tmp_path) as (ctx, v, env):
        (joint,) = v.joints
        cabinet = ctx.base.object_classes["white_cabinet_1"]
        for trial in (1, 5):
            start_trial(env, ctx, v, trial)
            state = sim.flattened_state(env)
            q = float(sim.raw(env).sim.data.get_joint_qpos(joint.joint))
            assert cabinet.is_close(q) and q < 0.002, (trial, q)
            assert start_checks.jammed_parts(env, v, state) == []
        sim.raw(env).sim.data.set_joint_qpos(joint.joint, 0.004)
        sim.raw(env).sim.forward()
        assert start_checks.jammed_parts(env, v, sim.flattened_state(env)) == [
            f"{joint.joint} is jammed (moved 0.00 mm under 20 N or N m)"
        ]


@pytest.mark.slow
def test_a_deformed_target_never_starts_locked_under_a_thin_support(tmp_path):
    """libero_spatial-07 taper-s1 trial 0: LIBERO's row holds the bowl 8 cm over the stove, and
    kept at that height (the first attempt) the tapered bowl fell through the stove's 1 mm top
    plate (its top at 0.9305 m) and rested locked under it on the stove's base (a 30 N pull raised
    it 2 mm; no gripper lifted it). The accepted start rests on the plate and comes up under the
    gentle pull (`stuck_objects`); put back under the plate, the pull finds it held. The scene is
    built first (its deformed bowl registered)."""
    from conftest import build_scene_case

    from vpro_assets.scene import build, sim, start_checks

    cid = "libero_spatial-07/target_geometry_variation/taper-s1-v1"
    build_scene_case(cid)
    build.built_case(cid)  # registers its deformed bowl with LIBERO
    with variant_env(cid, tmp_path) as (ctx, v, env):
        start_trial(env, ctx, v, 0)
        bowl = ctx.task.target
        assert sim.body_layout(env)[bowl]["lo"][2] > 0.9295  # on the plate, not through it
        assert start_checks.stuck_objects(env, [bowl], sim.flattened_state(env)) == []
        data = sim.raw(env).sim.data
        joint = sim.raw(env).objects_dict[bowl].joints[-1]
        qpos = np.array(data.get_joint_qpos(joint))
        qpos[2] -= sim.body_layout(env)[bowl]["lo"][2] - 0.925  # its foot on the base, under the plate
        data.set_joint_qpos(joint, qpos)
        sim.raw(env).sim.forward()
        sim.settle(env)
        (held,) = start_checks.stuck_objects(env, [bowl], sim.flattened_state(env))
        assert held.startswith(f"{bowl} is held by what it stands on")


def test_an_inverted_bowl_never_starts_over_the_ramekin_it_stood_on(tmp_path):
    """libero_spatial-05 object_pose (revision enclose1): LIBERO's bowl stands on the ramekin, and
    turned upside down there it came down over it; the ramekin stayed wedged in the bowl's hull
    pieces (a 1 N pull lifted both, 3 N did not part them), so no trial could put the bowl on the
    plate (0 of 10 certified). That start is drawn again (`_enclosing`) with the bowl upside down
    on the table beside the ramekin, their footprints apart. libero_spatial-03's bowl, upside down
    on the cookie box it spans, still rests on top of the box."""
    from vpro_assets.scene import sim

    def bowl_frame_zz(env, bowl):
        raw = sim.raw(env)
        return raw.sim.data.body_xmat[raw.sim.model.body_name2id(raw.objects_dict[bowl].root_body)][8]

    with variant_env("libero_spatial-05/task_precondition_variation/object_pose-v1", tmp_path) as (ctx, v, env):
        bowl = ctx.task.target
        for trial in (0, 1):
            start_trial(env, ctx, v, trial)
            b, r = (sim.body_layout(env)[n] for n in (bowl, "glazed_rim_porcelain_ramekin_1"))
            assert np.any(b["lo"][:2] > r["hi"][:2]) or np.any(r["lo"][:2] > b["hi"][:2]), (trial, b, r)
            assert bowl_frame_zz(env, bowl) < -0.95, trial  # still upside down
    with variant_env("libero_spatial-03/task_precondition_variation/object_pose-v1", tmp_path) as (ctx, v, env):
        bowl = ctx.task.target
        start_trial(env, ctx, v, 0)
        b, box = (sim.body_layout(env)[n] for n in (bowl, "cookies_1"))
        assert b["lo"][2] > box["hi"][2] - 0.005  # on top of the box
        assert bowl_frame_zz(env, bowl) < -0.95
