"""The fit of a deformed target to an enclosed receptacle (generators.geometry_scene, issue 13):
the room of a drawer measured on LIBERO's compiled scene (`vpro_assets.scene.receptacle`), the
fit scale, and the per-case revision that rebuilds only the cases the fit concerns. No built scene
case is needed: LIBERO's own libero_10-03 scene, LIBERO's bowl and, for the rule end to end, the
multipeak-s3 bowl generated with coacd's lighter search are enough."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from conftest import scene_variant

from generators import geometry_scene as gs
from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.tasks import get_task
from vpro_assets.objects import deformed as tg
from vpro_assets.scene import case_key, plugins
from vpro_assets.scene.receptacle import Clearance, clearance, object_size, resting_size

# Measured on libero_10-03 (LIBERO's first initial state: the bottom drawer open 14.6 cm).
DRAWER = Clearance("white_cabinet_1_bottom_region", floor=0.9258, ceiling=0.9832, radius=0.0568)
BOWL = (0.0539, 0.0505)  # LIBERO's bowl: reach, height
# The hulls of vpro_akita_black_bowl_multipeak_s3_v1 and _taper_s3_v1 at rest (`resting_size`).
MULTIPEAK_S3 = (0.0665, 0.0520)
TAPER_S3 = (0.0461, 0.0520)


def _scaled(size, scale):
    return size[0] * scale, size[1] * scale


def test_multipeak_s3_bowl_is_scaled_into_libero_10_03s_bottom_drawer():
    scale = gs.fit_scale(DRAWER, BOWL, MULTIPEAK_S3)
    assert scale == 0.81  # a clean hundredth: it names the object and enters its key
    assert gs.fits(DRAWER, BOWL, _scaled(MULTIPEAK_S3, scale))
    # Unfitted, it reaches 6.65 cm about the drawer's centre: 1 cm into the middle drawer's front.
    assert not gs.fits(DRAWER, BOWL, MULTIPEAK_S3) and DRAWER.radius < MULTIPEAK_S3[0]
    # Normal's own bowl satisfies the margin on both measures.
    assert DRAWER.radius - BOWL[0] >= gs.FIT_MARGIN_M and DRAWER.height - BOWL[1] >= gs.FIT_MARGIN_M


def test_a_receptacle_with_room_keeps_the_deformed_target_as_it_is():
    roomy = Clearance("wooden_cabinet_1_top_region", floor=1.0642, ceiling=1.1252, radius=0.0759)  # libero_goal-03
    assert gs.fit_scale(roomy, BOWL, MULTIPEAK_S3) == 1.0
    assert gs.fit_scale(DRAWER, BOWL, TAPER_S3) == 1.0  # taper-s3 narrows the bowl


def test_the_original_bounds_the_allowance_from_below():
    tight = Clearance("r", 0.0, 0.052, 0.055)  # the bowl itself leaves 1.1 mm of reach, 1.5 mm of height
    assert gs.allowed(tight, BOWL) == BOWL
    assert gs.fit_scale(tight, BOWL, MULTIPEAK_S3) == 0.81  # to the original's reach: 0.0539 / 0.0665
    assert gs.fits(tight, BOWL, BOWL)


def test_fit_scale_is_the_largest_hundredth_that_fits():
    rng = np.random.default_rng(13)
    for _ in range(500):
        room = Clearance("r", 0.0, float(rng.uniform(0.03, 0.2)), float(rng.uniform(0.03, 0.15)))
        original = float(rng.uniform(0.02, 0.1)), float(rng.uniform(0.02, 0.15))
        deformed = original[0] * float(rng.uniform(0.7, 1.4)), original[1] * float(rng.uniform(0.9, 1.2))
        scale = gs.fit_scale(room, original, deformed)
        assert 0 < scale <= 1.0 and scale == round(scale, 2)
        assert gs.fits(room, original, _scaled(deformed, scale))
        if scale < 1.0:
            assert not gs.fits(room, original, _scaled(deformed, scale + tg.FIT_STEP))


def test_a_fitted_object_that_oversteps_as_made_is_taken_a_hundredth_smaller(monkeypatch):
    """coacd decomposes the scaled solid anew, so the rule measures the fitted object as made."""
    made = []

    def generate(category, deformation, severity, root, fit_scale=1.0, isolate=False):
        assert isolate  # made in the build worker's child process
        made.append(fit_scale)
        return SimpleNamespace(xml_path=str(fit_scale))

    def rest(xml_path, up_axis):  # as made, the fitted hulls reach 0.5 mm farther than scaled
        scale = float(xml_path)
        return MULTIPEAK_S3[0] * scale + (0.0005 if scale < 1.0 else 0.0), MULTIPEAK_S3[1] * scale

    monkeypatch.setattr(gs.tg, "generate_deformed_object", generate)
    monkeypatch.setattr(gs, "resting_size", rest)
    monkeypatch.setattr(gs, "clearance", lambda *args: DRAWER)
    monkeypatch.setattr(gs, "object_size", lambda *args: BOWL)
    ctx = SimpleNamespace(
        case={"task": "libero_10-03"}, task=get_task("libero_10-03"), base=SimpleNamespace(ray_scene=(None, None))
    )
    scale, fit = gs._fit(ctx, "akita_black_bowl", "multipeak", 3)
    assert made == [1.0, 0.81, 0.8] and scale == 0.8
    assert fit["fitted"]["reach"] <= fit["allowed"]["reach"]


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


def test_libero_10_03_drawer_measured_and_the_fitted_multipeak_s3_bowl_fits_it(tmp_path, monkeypatch):
    """On LIBERO's compiled libero_10-03 scene: the bottom drawer's room and the bowl, which
    `resting_size` measures as `object_size` does in the scene; then the rule end to end: the
    multipeak-s3 bowl generated (coacd's lighter search), measured at rest, fitted, and the fitted
    object as made stays within the allowance."""
    from vpro_assets.geometry.convex import FAST
    from vpro_assets.scene.base_scene import base_scene

    base = base_scene("libero_10-03")
    model, data = base.ray_scene
    room = clearance(model, data, "white_cabinet_1_bottom_region")
    original = object_size(model, data, "akita_black_bowl_1_main")
    assert room is not None
    assert room.height == pytest.approx(DRAWER.height, abs=0.002)  # floor 0.926 to the shelf at 0.983
    assert room.radius == pytest.approx(DRAWER.radius, abs=0.002)  # to the middle drawer's front
    assert original == pytest.approx(BOWL, abs=0.001)
    # LIBERO's bowl file dropped on a table measures as the bowl the settled scene holds.
    assert resting_size(tg.libero_object_xml("akita_black_bowl"), "+z") == pytest.approx(original, abs=3e-4)

    monkeypatch.setenv("VPRO_OUT", str(tmp_path))
    light = tg.default_coacd_params
    monkeypatch.setattr(tg, "default_coacd_params", lambda *args, **kw: light(*args, **{**FAST, **kw}))
    _ctx, variant = scene_variant("libero_10-03/target_geometry_variation/multipeak-s3-v1")
    fit = variant.details["fit"]
    size = {k: (fit[k]["reach"], fit[k]["height"]) for k in ("original", "deformed", "allowed", "fitted")}
    margin = gs.FIT_MARGIN_M
    assert size["allowed"] == pytest.approx((DRAWER.radius - margin, DRAWER.height - margin), abs=2e-4)
    assert size["deformed"][0] > size["allowed"][0]  # unfitted, it does not fit
    assert fit["fit_scale"] < 1.0
    assert variant.details["deformed_object"] == tg.object_name("akita_black_bowl", "multipeak", 3, fit["fit_scale"])
    fitted = tmp_path / "objects" / variant.details["deformed_object"]
    measured = resting_size(fitted / f"{fitted.name}.xml", "+z")
    assert measured == pytest.approx(size["fitted"], abs=1e-4)
    assert measured[0] <= size["allowed"][0] + 1e-4 and measured[1] <= size["allowed"][1] + 1e-4
    # Scaled about the bottom of its axis: reach and height go with the scale.
    assert measured == pytest.approx(_scaled(size["deformed"], fit["fit_scale"]), abs=5e-4)
