import dataclasses
import json
import re
from collections import Counter

import pytest

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core.errors import UnknownIdError

ID = re.compile(r"^vpro/[a-z_]+/[a-z0-9_-]+-v\d+$")


def test_counts_match_the_paper():
    assert len(tx.DIMENSIONS) == 4
    assert len(tx.CATEGORIES) == 12
    assert len(tx.SETTINGS) == 96
    per_dim = Counter(tx.category(s.category).dimension for s in tx.SETTINGS)
    assert per_dim == {
        "visual_evidence_degradation": 55,
        "camera_staleness": 10,
        "visual_source_consistency": 9,
        "task_relevant_scene_variation": 22,
    }
    per_cat = Counter(s.category for s in tx.SETTINGS)
    assert per_cat == {
        "target_object_masking": 16,
        "target_receptacle_masking": 16,
        "interaction_cue_masking": 3,
        "temporary_observation_corruption": 14,
        "view_unavailability": 6,
        "camera_staleness": 10,
        "cross_view_contradiction": 8,
        "prediction_reality_divergence": 1,
        "task_relevant_distractors": 6,
        "task_precondition_variation": 2,
        "visual_state_ambiguity": 2,
        "target_geometry_variation": 12,
    }
    assert sum(tx.category(s.category).level == tx.OBSERVATION for s in tx.SETTINGS) == 74


def test_ids_are_unique_versioned_and_json():
    ids = [s.id for s in tx.SETTINGS]
    assert len(set(ids)) == 96
    assert all(ID.match(i) for i in ids), [i for i in ids if not ID.match(i)]
    for s in tx.SETTINGS:
        record = json.loads(json.dumps(s.to_json()))
        assert record["id"] == s.id and record["params"] == s.param_dict
        with pytest.raises(dataclasses.FrozenInstanceError):
            s.name = "x"  # frozen


def test_indicators_follow_the_paper():
    diagnostic = {c.id for c in tx.CATEGORIES if c.indicator == tx.DIAGNOSTIC}
    assert diagnostic == {
        "target_object_masking",
        "target_receptacle_masking",
        "interaction_cue_masking",
        "cross_view_contradiction",
        "visual_state_ambiguity",
    }


def test_parameters_span_the_described_grid():
    masks = [s.param_dict for s in tx.settings_of("target_object_masking")]
    assert {(p["ratio"], p["schedule"]) for p in masks} == {
        (r / 100, sch)
        for r in (25, 50, 75, 100)
        for sch in ("always", "before_grasp", "after_grasp", "around_placement")
    }
    stale = [s.param_dict for s in tx.settings_of("camera_staleness")]
    assert sorted(p["delay_steps"] for p in stale if p["mode"] == "delay") == [5, 5, 10, 10, 20, 20]
    geo = [s.param_dict for s in tx.settings_of("target_geometry_variation")]
    assert {(p["deformation"], p["severity"]) for p in geo} == {
        (d, k) for d in ("taper", "multipeak", "twist", "asymmetric") for k in (1, 2, 3)
    }


def test_unknown_setting_suggests_close_matches():
    with pytest.raises(UnknownIdError) as err:
        tx.setting("vpro/camera_staleness/wrist-delay2-v2")
    assert "vpro/camera_staleness/wrist-delay2-v1" in str(err.value)
