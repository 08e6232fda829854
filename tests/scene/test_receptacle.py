"""The fit of a deformed target to an enclosed receptacle (generators.geometry_scene, issue 13):
the room of a drawer measured on LIBERO's compiled scene (`vpro_assets.scene.receptacle`), the
fit scale, and the per-case revision that rebuilds only the cases the fit concerns. No built scene
case is needed: LIBERO's own libero_10-03 scene and the deformation of the bowl's solid (no convex
decomposition) are enough."""

from __future__ import annotations

import numpy as np
import pytest

from generators import geometry_scene as gs
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.objects import deformed as tg
from vpro_assets.scene import case_key, plugins
from vpro_assets.scene.receptacle import Clearance, clearance, object_size

# Measured on libero_10-03 (LIBERO's first initial state: the bottom drawer open 14.6 cm).
DRAWER = Clearance("white_cabinet_1_bottom_region", floor=0.9258, ceiling=0.9832, radius=0.0568)
BOWL_REACH, BOWL_HEIGHT = 0.0539, 0.0505
MULTIPEAK_S3_REACH_RATIO = 1.17394  # the record of vpro_akita_black_bowl_multipeak_s3_v1


def _fits(room, reach, height, scale, reach_ratio, height_ratio):
    return (
        reach * reach_ratio * scale <= max(reach, room.radius - gs.FIT_MARGIN_M) + 1e-12
        and height * height_ratio * scale <= max(height, room.height - gs.FIT_MARGIN_M) + 1e-12
    )


def test_multipeak_s3_bowl_is_scaled_into_libero_10_03s_bottom_drawer():
    scale = gs.fit_scale(DRAWER, BOWL_REACH, BOWL_HEIGHT, MULTIPEAK_S3_REACH_RATIO, 1.0)
    assert scale == pytest.approx(0.85)
    assert _fits(DRAWER, BOWL_REACH, BOWL_HEIGHT, scale, MULTIPEAK_S3_REACH_RATIO, 1.0)
    # Unfitted, it reaches 6.3 cm about the drawer's centre: 6 mm into the middle drawer's front.
    assert DRAWER.radius < BOWL_REACH * MULTIPEAK_S3_REACH_RATIO
    # Normal's own bowl satisfies the margin on both measures.
    assert DRAWER.radius - BOWL_REACH >= gs.FIT_MARGIN_M and DRAWER.height - BOWL_HEIGHT >= gs.FIT_MARGIN_M


def test_a_receptacle_with_room_keeps_the_deformed_target_as_it_is():
    roomy = Clearance("wooden_cabinet_1_top_region", floor=1.0642, ceiling=1.1252, radius=0.0759)  # libero_goal-03
    assert gs.fit_scale(roomy, BOWL_REACH, BOWL_HEIGHT, MULTIPEAK_S3_REACH_RATIO, 1.0) == 1.0
    assert gs.fit_scale(DRAWER, BOWL_REACH, BOWL_HEIGHT, 0.81, 1.0) == 1.0  # taper-s3 narrows the bowl


def test_fit_scale_is_the_largest_hundredth_that_fits():
    rng = np.random.default_rng(13)
    for _ in range(500):
        room = Clearance("r", 0.0, float(rng.uniform(0.03, 0.2)), float(rng.uniform(0.03, 0.15)))
        reach, height = float(rng.uniform(0.02, 0.1)), float(rng.uniform(0.02, 0.15))
        ratios = float(rng.uniform(0.7, 1.4)), float(rng.uniform(0.9, 1.2))
        scale = gs.fit_scale(room, reach, height, *ratios)
        assert 0 < scale <= 1.0 and abs(scale / tg.FIT_STEP - round(scale / tg.FIT_STEP)) < 1e-9
        assert _fits(room, reach, height, scale, *ratios)
        if scale < 1.0:
            assert not _fits(room, reach, height, scale + tg.FIT_STEP, *ratios)


def test_fitted_objects_are_named_apart_and_unfitted_keys_are_unchanged():
    assert tg.object_name("akita_black_bowl", "multipeak", 3) == "vpro_akita_black_bowl_multipeak_s3_v1"
    assert tg.object_name("akita_black_bowl", "multipeak", 3, 0.85) == "vpro_akita_black_bowl_multipeak_s3_v1_fit85"
    for bad in (0.0, 1.2, 0.855):
        with pytest.raises(InvalidParameterError):
            tg.object_name("akita_black_bowl", "multipeak", 3, bad)


def test_revision_names_only_the_cases_whose_goal_puts_the_target_into_an_openable_fixture():
    def case(task, setting="multipeak-s3-v1"):
        return {"id": f"{task}/target_geometry_variation/{setting}", "task": task}

    assert gs.fit_revision(case("libero_10-03")) == gs.FIT_REVISION  # the white cabinet's bottom drawer
    assert gs.fit_revision(case("libero_goal-03")) == gs.FIT_REVISION  # the wooden cabinet's top drawer
    for task in (
        "libero_object-00",
        "libero_10-05",
        "libero_spatial-00",
        "libero_goal-09",
    ):  # basket, caddy, plate, rack
        assert gs.fit_revision(case(task)) == ""


def test_a_case_without_a_revision_keeps_its_input_hash(monkeypatch):
    monkeypatch.setattr(
        case_key.pool_mod, "pool", dict
    )  # the distractor pool's table: slow, and the same on both sides
    case = {
        "id": "libero_spatial-00/target_geometry_variation/multipeak-s3-v1",
        "setting": "vpro/target_geometry_variation/multipeak-s3-v1",
        "params": {"deformation": "multipeak", "severity": 3, "peak_amplitude": 0.18},
        "trial_seeds": [1, 2],
        "task": "libero_spatial-00",
    }
    plain = plugins.Generator("target_geometry_variation/multipeak-s3", 1, lambda ctx: None, "")
    revised = plugins.Generator(plain.name, 1, plain.fn, "", gs.fit_revision)
    assert case_key.input_hash(case, revised) == case_key.input_hash(case, plain)
    drawer_case = {**case, "id": case["id"].replace("libero_spatial-00", "libero_10-03"), "task": "libero_10-03"}
    assert case_key.input_hash(drawer_case, revised) != case_key.input_hash(drawer_case, plain)


def test_libero_10_03_drawer_measured_and_the_fitted_multipeak_s3_bowl_fits_it():
    """On LIBERO's compiled libero_10-03 scene: the bottom drawer's room and the bowl; then the
    multipeak-s3 bowl's solid, deformed and fitted as the pipeline does, stays within it."""
    from vpro_assets.libero import bridge as libero_bridge
    from vpro_assets.libero.env import libero_init_states
    from vpro_assets.libero.tasks import get_task
    from vpro_assets.objects import deformed_build as db
    from vpro_assets.objects.deformed_files import _max_radius, _upright_extents
    from vpro_assets.scene import sim

    task = get_task("libero_10-03")
    env = sim.physics_env(str(libero_bridge.bddl_path(task.suite, task.name)))
    try:
        raw = sim.raw(env)
        raw.sim.set_state_from_flattened(libero_init_states(task)[0])
        raw.sim.forward()
        model, data = raw.sim.model._model, raw.sim.data._data
        room = clearance(model, data, "white_cabinet_1_bottom_region")
        reach, height = object_size(model, data, "akita_black_bowl_1_main")
    finally:
        sim.close(env)
    assert room is not None
    assert room.height == pytest.approx(DRAWER.height, abs=0.002)  # floor 0.926 to the shelf at 0.983
    assert room.radius == pytest.approx(DRAWER.radius, abs=0.002)  # to the middle drawer's front
    assert (reach, height) == pytest.approx((BOWL_REACH, BOWL_HEIGHT), abs=0.001)

    category = "akita_black_bowl"
    original = db.repair_solid(category, tg.libero_object_xml(category), tg.up_axis(category))
    setting = tg.geometry_setting("multipeak", 3)
    amount = db.deform_mod.amount_of("multipeak", setting.param_dict)
    plain = db.deform(original, "multipeak", amount, "test")
    r0 = _max_radius(original.frame, original.vertices)
    h0 = _upright_extents(original.frame, original.vertices)[2]
    ratio = _max_radius(original.frame, plain.vertices) / r0
    assert ratio * reach > room.radius  # unfitted, it does not fit
    scale = gs.fit_scale(room, reach, height, ratio, 1.0)
    fitted = db.deform(original, "multipeak", amount, "test", scale)
    fitted_reach = _max_radius(original.frame, fitted.vertices) / r0 * reach
    fitted_height = _upright_extents(original.frame, fitted.vertices)[2] / h0 * height
    assert fitted_reach <= max(reach, room.radius - gs.FIT_MARGIN_M) + 1e-6
    assert fitted_height <= room.height - gs.FIT_MARGIN_M
    # The shape keeps its character: five lobes of the same relative amplitude, the bottom in place.
    assert _max_radius(original.frame, fitted.vertices) == pytest.approx(scale * ratio * r0, rel=1e-6)
    assert fitted.vertices[:, 2].min() == pytest.approx(plain.vertices[:, 2].min(), abs=1e-9)
