"""Masks drawn from the env's own captured scene (entities and what can cover them) against the
reference: a full-scene segmentation render of the same scene, on real renders of three tasks,
both cameras, scripted episodes that approach, grasp and carry the target."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.libero.env import CAMERAS, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb import PerturbedEnv
from vpro_assets.perturb.base import MaskSource
from vpro_assets.perturb.capture import CaptureRenderer, capture, decode_ids
from vpro_assets.perturb.imageops import meeting_region, scaled_px
from vpro_assets.perturb.rendering import draw, render_context, render_geom_ids, render_rgb
from vpro_assets.rollout.policies.scripted import PickPlaceController

TASKS = ("libero_spatial-00", "libero_goal-03", "libero_object-02")
RES, STEPS, LABELS = 128, 10, ("target", "receptacle", "gripper")
GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)
RADIUS = scaled_px(6, RES)  # interaction-cue masking's contact radius at this size
MIN_PX = 50  # IoU is asserted on frames where the entity has at least this many pixels


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


class FullCapture:
    """Also capture every entry of each scene the env draws: the reference, in the same state."""

    def __init__(self, sim):
        self.ctx, self.sim, self.frames = render_context(sim), sim, {}
        hooked = self.ctx.render
        model = sim.model._model

        def render(width, height, camera_id=None, segmentation=False):
            hooked(width, height, camera_id, segmentation)
            if not segmentation:
                self.frames[camera_id] = capture(
                    self.ctx, model, sim.data._data, camera_id, width, height, np.arange(model.ngeom), 0
                )

        self.ctx.render = render
        self.renderer = CaptureRenderer(model)

    def ids(self, camera: str, only=None) -> np.ndarray:
        """Full-scene segmentation of the frame the env drew (`only`: of these geoms alone)."""
        cap = self.frames[self.sim.model.camera_name2id(camera)]
        if only is not None:
            cap = dataclasses.replace(
                cap, entries=[e for e in cap.entries if e["objtype"] == GEOM and e["objid"] in only]
            )
        return self.renderer.draw_ids(self.ctx, cap)


@pytest.mark.parametrize("key", TASKS)
def test_captured_masks_equal_full_scene_segmentation(key):
    task = get_task(key)
    # a placement-contact case needs target and receptacle, then the gripper is added: all three captured
    env = PerturbedEnv(make_env(task, RES, horizon=10**6), "vpro/interaction_cue_masking/placement_contact-v1", task)
    try:
        env.pipeline.mask_labels = frozenset(LABELS)
        env.reset(trial=0, init_state=libero_init_states(task)[0])
        sim, pipe = env.sim, env.pipeline
        reference = FullCapture(sim)
        controller = PickPlaceController(sim, task)
        compared, occluded, apart = 0, 0, 0
        for step in range(STEPS):
            env.env.step(controller.action())
            masks = MaskSource(
                sim,
                pipe.entities,
                dict.fromkeys(CAMERAS, (RES, RES)),
                pipe.hook.take(),
                pipe.capture_renderer,
                pipe.mask_labels,
            )
            for cam in CAMERAS:
                ref_ids = reference.ids(cam)
                for label in LABELS:
                    entity = pipe.entities.entity(label)
                    ref = np.isin(ref_ids, entity.geoms)
                    new = masks.mask(cam, label)
                    # exact at every pixel, not only above the IoU threshold
                    assert np.array_equal(new, ref), (
                        f"{key} step {step} {cam} {label}: {int((new != ref).sum())} px differ"
                    )
                    if ref.sum() >= MIN_PX:
                        assert iou(new, ref) >= 0.98
                        compared += 1
                        # the entity drawn alone covers more: something in the scene hides part of it
                        alone = np.isin(reference.ids(cam, only=set(entity.geoms)), entity.geoms)
                        occluded += int(alone.sum() > ref.sum())
                # entities whose windows cannot meet have an empty contact region in the reference too
                for a, b in (("gripper", "target"), ("target", "receptacle")):
                    if not masks.may_meet(cam, a, b, RADIUS):
                        apart += 1
                        region = meeting_region(
                            np.isin(ref_ids, pipe.entities.entity(a).geoms),
                            np.isin(ref_ids, pipe.entities.entity(b).geoms),
                            RADIUS,
                        )
                        assert not region.any(), f"{key} step {step} {cam}: {a} and {b} meet"
            assert masks.reference_renders == 0  # every mask came from the captured scenes
        assert compared >= STEPS * 3  # several entities visible in both cameras
        assert occluded > 0  # some frames test occlusion, not only entities in the open
        assert apart > 0  # and some skip a contact region by the windows alone
    finally:
        env.close()


def test_masking_setting_same_schedule_seeds_and_physics_with_either_mask_path():
    """A target-masking case run twice, masks from captures and from full-scene segmentation:
    the same steps are masked, with the same sweep directions, and the physics is the same."""
    key = TASKS[0]
    task = get_task(key)
    setting = tx.setting("vpro/target_object_masking/ratio50-before_grasp-v1")
    case = {"id": f"{key}/x", "task": key, "setting": setting.id, "params": setting.param_dict}
    runs = []
    env0 = make_env(task, RES, horizon=10**6)
    try:
        for capture_masks in (True, False):
            env = PerturbedEnv(env0, case, task)
            env.pipeline.capture_masks = capture_masks
            env.reset(trial=3, init_state=libero_init_states(task)[0])
            controller = PickPlaceController(env.sim, task)
            applied, states = [], []
            for _ in range(STEPS):
                _, _, _, info = env.step(controller.action())
                applied.append(sorted(info["vpro"]["applied"]))
                states.append(env.sim.get_state().flatten())
            runs.append(
                (
                    applied,
                    np.array(states),
                    dict(env.pipeline.perturbations[0].angles),
                    env.pipeline.reference_mask_renders,
                    env.pipeline.mask_renders,
                )
            )
            env.pipeline.detach()
    finally:
        env0.close()
    (a1, s1, ang1, ref1, n1), (a2, s2, ang2, ref2, n2) = runs
    assert a1 == a2 and any(a1)
    assert ang1 == ang2
    np.testing.assert_array_equal(s1, s2)
    assert ref1 == 0 < n1 and ref2 == n2 > 0


def test_masks_show_what_the_colour_frame_shows_under_hidden_sites():
    """robosuite hides its visualisation sites (the grip site's vertical cylinder) by negating
    their alpha: nothing in the colour frame, an opaque strip in MuJoCo's segmentation mode. With
    the target right under the gripper, the strip crosses it in the third-person view; the masks of
    both paths must still cover every target pixel the camera shows."""
    key, cam = TASKS[0], "agentview"
    task = get_task(key)
    setting = tx.setting("vpro/target_object_masking/ratio100-always-v1")
    case = {"id": f"{key}/x", "task": key, "setting": setting.id, "params": setting.param_dict}
    env = PerturbedEnv(make_env(task, RES, horizon=10**6), case, task)
    try:
        env.reset(trial=0, init_state=libero_init_states(task)[0])
        sim, pipe = env.sim, env.pipeline
        model, data = sim.model._model, sim.data._data
        target = pipe.entities.entity("target")
        # the target's free joint: its x-y under the grip site, its height kept
        qadr = model.jnt_qposadr[model.body_jntadr[target.bodies[0]]]
        data.qpos[qadr : qadr + 2] = data.site_xpos[model.site("gripper0_grip_site").id][:2]
        mujoco.mj_forward(model, data)
        ctx = render_context(sim)
        colour = render_rgb(sim, cam, RES, RES)
        shown = np.isin(render_geom_ids(sim, cam, RES, RES), target.geoms)
        sites = ctx.vopt.sitegroup.copy()
        try:
            ctx.vopt.sitegroup[:] = 0
            assert np.array_equal(render_rgb(sim, cam, RES, RES), colour)  # the sites draw nothing in colour
            without_sites = np.isin(render_geom_ids(sim, cam, RES, RES), target.geoms)
        finally:
            ctx.vopt.sitegroup[:] = sites
        draw(ctx, RES, RES, model.camera(cam).id, segmentation=True)  # MuJoCo's segmentation as is
        rgb = np.empty((RES, RES, 3), dtype=np.uint8)
        mujoco.mjr_readPixels(rgb=rgb, depth=None, viewport=mujoco.MjrRect(0, 0, RES, RES), con=ctx.con)
        raw = np.isin(decode_ids(rgb, ctx.scn), target.geoms)
        assert without_sites.sum() - raw.sum() >= 5  # the strip does cross the target
        assert np.array_equal(shown, without_sites)
        sim.render(camera_name=cam, width=RES, height=RES)  # the env's frame, captured by the hook
        masks = MaskSource(sim, pipe.entities, {cam: (RES, RES)}, pipe.hook.take(), pipe.capture_renderer,
                           frozenset({"target"}))  # fmt: skip
        assert np.array_equal(masks.mask(cam, "target"), without_sites)
        assert masks.reference_renders == 0
    finally:
        env.close()
