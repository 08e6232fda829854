"""Defining property of each of the 74 observation-level settings, on synthetic frames, masks and
phase timelines (no simulator): every setting of the taxonomy is built from its catalog case and
run through an 80-step synthetic episode; the check asserts what the setting's name promises."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.core import paths
from vpro_assets.core.seeding import rng
from vpro_assets.libero.env import CAMERAS
from vpro_assets.libero.tasks import get_task
from vpro_assets.perturb.base import Episode, Step
from vpro_assets.perturb.phases import PLACED, PhaseState
from vpro_assets.perturb.pipeline import FAMILIES

OBS_SETTINGS = [s for s in tx.SETTINGS if tx.category(s.category).level == tx.OBSERVATION]
STEPS, H, W = 80, 64, 64
AGENT, WRIST = CAMERAS
GRASP_ONSET, PLACE_ONSET = 25, 60


def test_there_are_74_observation_settings_and_each_has_a_family():
    assert len(OBS_SETTINGS) == 74
    assert {s.category for s in OBS_SETTINGS} <= set(FAMILIES)


@pytest.fixture(scope="module")
def catalog():
    return load_catalog(paths.catalog_path())


def first_case(catalog, setting):
    return next(c for c in catalog["cases"] if c["setting"] == setting.id)


def phase_at(t: int) -> PhaseState:
    phase = (
        "approach"
        if t < 20
        else "grasp"
        if t < 30
        else "transport"
        if t < 50
        else "pre_placement"
        if t < PLACE_ONSET
        else PLACED
    )
    return PhaseState(t, phase, GRASP_ONSET if t >= GRASP_ONSET else None, PLACE_ONSET if t >= PLACE_ONSET else None)


def disc(cy, cx, r):
    yy, xx = np.mgrid[:H, :W]
    return (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r


class FakeMasks:
    """Synthetic entity masks: the target moves and shrinks below 50 px on some steps; the
    gripper meets the target during grasp and transport; the target meets the receptacle late."""

    def __init__(self, t: int):
        self.shapes = dict.fromkeys(CAMERAS, (H, W))
        self.t, self.renders = t, 0
        r_target = 3 if 10 <= t < 14 else 9  # 29 px vs 253 px
        cx = 16 + min(t, 60) * 0.5
        self._m = {
            "target": disc(30, cx, r_target),
            "receptacle": disc(30, 50, 10) if t < 55 else disc(42, 50, 10),
            "gripper": disc(18, cx, 7) if 20 <= t < 50 else disc(8, 8, 6),
        }

    def may_meet(self, cam, a, b, radius):
        return True  # no windows known: the masks decide

    def mask(self, cam, label):
        self.renders = 1
        shift = 0 if cam == AGENT else 3  # the two views see different pixels
        return np.roll(self._m[label], shift, axis=1)


def clean_frames(t: int) -> dict[str, np.ndarray]:
    g = np.random.default_rng(1000 + t)
    return {cam: g.integers(0, 256, (H, W, 3), dtype=np.uint8) for cam in CAMERAS}


def run(setting, case, trial=0, predicted=None):
    task = get_task(case["task"])
    pert = FAMILIES[setting.category](case["id"], case["params"], task)
    pert.reset(Episode(case["id"], trial, task))
    out = []
    for t in range(STEPS):
        clean = clean_frames(t)
        step = Step(t, phase_at(t), clean, FakeMasks(t), predicted(t) if predicted else None)
        frames = dict(clean)
        pert.apply(frames, step)
        out.append((clean, frames, step))
    return pert, out


def changed(a, b):
    return np.any(a != b, axis=-1)


def check_entity_masking(setting, case, catalog):
    p = setting.param_dict
    _, out = run(setting, case)
    seen_active = seen_inactive = 0
    for t, (clean, frames, step) in enumerate(out):
        active = {
            "always": True,
            "before_grasp": t < GRASP_ONSET,
            "after_grasp": t >= GRASP_ONSET,
            "around_placement": t >= 50,
        }[p["schedule"]]
        for cam in CAMERAS:
            entity = step.masks.mask(cam, p["entity"])
            diff = changed(clean[cam], frames[cam])
            if not active:
                assert not diff.any(), f"step {t}: masked outside the schedule"
                seen_inactive += 1
                continue
            assert not (diff & ~entity).any(), "occluder outside the entity's pixels"
            assert np.all(frames[cam][diff] == p["occluder_gray"]), "occluder is not flat grey"
            if entity.sum() >= 50:
                frac = diff[entity].mean()
                assert abs(frac - p["ratio"]) <= 0.03, (
                    f"step {t} {cam}: masked {frac:.3f} of the entity, ratio {p['ratio']}"
                )
                seen_active += 1
    assert seen_active > 0
    assert seen_inactive > 0 or p["schedule"] == "always"


def expected_region(masks, cam, region, d):
    """Pixels within distance d of both entities (independent of the implementation's dilation)."""
    if region == "gripper":
        return masks.mask(cam, "gripper")
    a, b = {"gripper_object_contact": ("gripper", "target"), "placement_contact": ("target", "receptacle")}[region]
    dist = [
        cv2.distanceTransform((~masks.mask(cam, x)).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        for x in (a, b)
    ]
    return (dist[0] <= d + 1e-4) & (dist[1] <= d + 1e-4)


def check_cue_masking(setting, case, catalog):
    p = setting.param_dict
    d = max(1, round(p["dilation_px"] * H / 256)) if p["dilation_px"] else 0
    _, out = run(setting, case)
    nonempty = 0
    for t, (clean, frames, step) in enumerate(out):
        for cam in CAMERAS:
            diff = changed(clean[cam], frames[cam])
            want = expected_region(step.masks, cam, p["region"], d)
            assert np.all(frames[cam][diff] == p["occluder_gray"]), "occluder is not flat grey"
            assert np.array_equal(diff, want), f"step {t} {cam}: masked pixels are not exactly the region"
            nonempty += bool(want.any())
    assert nonempty > 0


def check_corruption(setting, case, catalog):
    p = setting.param_dict
    pert, out = run(setting, case)
    if p["trigger"] == "phase":
        expected = {t for t in range(STEPS) if phase_at(t).phase == p["phase"]}
    else:  # independent re-derivation of the burst rule from the same seeded stream
        g, until, expected = rng(case["id"], 0, "corruption-bursts"), -1, set()
        for t in range(STEPS):
            u = g.random()
            if t > until and u < p["onset_prob"]:
                until = t + p["burst_steps"] - 1
            if t <= until:
                expected.add(t)
    got = set()
    for t, (clean, frames, _) in enumerate(out):
        hit = [not np.array_equal(clean[c], frames[c]) for c in CAMERAS]
        assert hit[0] == hit[1], "both views are corrupted together"
        if hit[0]:
            got.add(t)
            if p["mode"] == "blackout":
                assert all(not frames[c].any() for c in CAMERAS), "blackout frame not all zero"
    assert got == expected
    if p["trigger"] == "phase":
        assert got, "the phase occurs in the synthetic timeline"
    if p["mode"] == "noise" and got:
        _, again = run(setting, case)
        t = min(got)
        for c in CAMERAS:
            assert np.array_equal(out[t][1][c], again[t][1][c]), "noise not reproducible from the seed"
        _, other = run(setting, case, trial=1)
        if t in {s for s, (cl, fr, _) in enumerate(other) if not np.array_equal(cl[AGENT], fr[AGENT])}:
            assert not np.array_equal(out[t][1][AGENT], other[t][1][AGENT]), "another trial draws other noise"
        residual = out[t][1][AGENT].astype(float) - out[t][0][AGENT]
        mid = (out[t][0][AGENT] > 64) & (out[t][0][AGENT] < 192)  # far from clipping
        assert abs(residual[mid].std() - p["noise_std"]) < 0.1 * p["noise_std"] + 10


def check_views(setting, case, catalog):
    p = setting.param_dict
    pert, out = run(setting, case)
    cam, other = p["camera"], next(c for c in CAMERAS if c != p["camera"])
    assert (cam in pert.cameras(CAMERAS)) == (p["replacement"] != "single_view")
    for clean, frames, _ in out:
        assert np.array_equal(frames[other], clean[other])
        if p["replacement"] == "single_view":
            assert cam not in frames
        elif p["replacement"] == "constant":
            assert frames[cam].shape == clean[cam].shape and np.all(frames[cam] == p["constant_value"])
        else:
            assert np.array_equal(frames[cam], clean[other])


def check_staleness(setting, case, catalog):
    p = setting.param_dict
    _, out = run(setting, case)
    cam, other = p["camera"], next(c for c in CAMERAS if c != p["camera"])
    for t, (clean, frames, _) in enumerate(out):
        assert np.array_equal(frames[other], clean[other]), "the other view stays current"
        if p["mode"] == "delay":
            src = max(t - p["delay_steps"], 0)
        elif p["mode"] == "freeze":
            src = min(t, p["freeze_step"])
        else:
            s, w = p["replay_start"], p["replay_window"]
            src = t if t < s else s - w + (t - s) % w
        assert np.array_equal(frames[cam], out[src][0][cam]), f"step {t}: expected the clean frame of step {src}"


def check_contradiction(setting, case, catalog):
    p = setting.param_dict
    pert, out = run(setting, case)
    assert set(pert.render_edits()) == {p["camera"]}, "only the manipulated camera draws an edited scene"
    for clean, frames, _ in out:  # the edit lives in the render pass; the frames pass through
        assert all(frames[c] is clean[c] for c in CAMERAS)


def check_prediction(setting, case, catalog):
    def predicted(t):
        if t == 0 or t % 7 == 3:
            return None  # no new prediction: the last shown frame stays
        g = np.random.default_rng(5000 + t)
        return {c: g.integers(0, 256, (H, W, 3), dtype=np.uint8) for c in CAMERAS}

    _, out = run(setting, case, predicted=predicted)
    last = {c: out[0][0][c] for c in CAMERAS}
    for t, (clean, frames, step) in enumerate(out):
        for c in CAMERAS:
            if t == 0:
                assert np.array_equal(frames[c], clean[c]), "ground truth at the first observation"
            elif step.predicted:
                assert np.array_equal(frames[c], step.predicted[c])
            else:
                assert np.array_equal(frames[c], last[c])
            last[c] = frames[c]


CHECKS = {
    "target_object_masking": check_entity_masking,
    "target_receptacle_masking": check_entity_masking,
    "interaction_cue_masking": check_cue_masking,
    "temporary_observation_corruption": check_corruption,
    "view_unavailability": check_views,
    "camera_staleness": check_staleness,
    "cross_view_contradiction": check_contradiction,
    "prediction_reality_divergence": check_prediction,
}


@pytest.mark.parametrize("setting", OBS_SETTINGS, ids=[s.id.removeprefix("vpro/") for s in OBS_SETTINGS])
def test_setting_defining_property(setting, catalog):
    CHECKS[setting.category](setting, first_case(catalog, setting), catalog)


def test_bad_parameters_name_the_case_and_value(catalog):
    from vpro_assets.core.errors import InvalidParameterError

    setting = tx.setting("vpro/target_object_masking/ratio50-always-v1")
    case = first_case(catalog, setting)
    bad = dict(case["params"], ratio=1.7)
    with pytest.raises(InvalidParameterError, match=r"ratio=1\.7") as err:
        FAMILIES[setting.category](case["id"], bad, get_task(case["task"]))
    assert case["id"] in str(err.value)
