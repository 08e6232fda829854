"""The allocation: the paper's pinned counts, the shared rest, and variants."""

from collections import Counter, defaultdict

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vpro_assets.benchmark import allocation as al
from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.catalog import case_id
from vpro_assets.benchmark.variants import BASE, variant_params
from vpro_assets.core.errors import VProError

SUITES = ("libero_spatial", "libero_object", "libero_goal", "libero_10")
# The paper's counts (issue 12): a change to PINNED or to the rule that moves any of them fails here.
PAPER = {
    "task_relevant_distractors": 240,
    "task_precondition_variation": 80,
    "visual_state_ambiguity": 45,
    "target_geometry_variation": 432,
    "camera_staleness": 400,
    "prediction_reality_divergence": 40,
}
PAPER_SETTINGS = {
    "vpro/task_precondition_variation/receptacle_openness-v1": 21,
    "vpro/task_precondition_variation/object_pose-v1": 59,
    "vpro/visual_state_ambiguity/receptacle_openness-v1": 7,
    "vpro/visual_state_ambiguity/object_pose-v1": 38,
}


@pytest.fixture(scope="module")
def chosen(tasks):
    return al.select(tasks, SUITES)


@given(st.lists(st.integers(0, 50), min_size=1, max_size=25), st.integers(0, 600))
def test_water_fill_is_exact_capped_and_fair(capacities, budget):
    if budget > sum(capacities):
        with pytest.raises(VProError):
            al.water_fill(budget, capacities)
        return
    shares = al.water_fill(budget, capacities)
    assert sum(shares) == budget
    assert all(0 <= s <= c for s, c in zip(shares, capacities))
    # Max-min fair: a share below another one is only allowed when it is at its capacity.
    for s, c in zip(shares, capacities):
        assert s == c or all(s >= o - 1 for o in shares)


def test_pinned_counts_are_the_papers(chosen):
    per_cat = Counter(c.setting.category for cases in chosen.values() for c in cases)
    assert {k: per_cat[k] for k in PAPER} == PAPER
    assert {p.category: p.cases for p in al.PINNED} == PAPER
    assert sum(per_cat.values()) == al.TOTAL_CASES == 3296
    assert sum(n for k, n in per_cat.items() if k not in PAPER) == 2059
    assert {sid: len(chosen[sid]) for sid in PAPER_SETTINGS} == PAPER_SETTINGS
    assert len(chosen) == 96 and all(chosen.values())


def test_unpinned_settings_share_the_rest_evenly(chosen, tasks):
    rest = [s for s in tx.SETTINGS if al.pinned(s.category) is None]
    sizes = [len(chosen[s.id]) for s in rest]
    capacity = [sum(len(ts) for _, ts in al.candidates(s, tasks)) for s in rest]
    # Water-filled: every setting below the largest share is at its capacity.
    assert all(n == c or n >= max(sizes) - 1 for n, c in zip(sizes, capacity))
    for s in rest:
        per_suite = Counter(c.task.suite for c in chosen[s.id])
        assert max(per_suite.values()) - min(per_suite.values()) <= 3, (s.id, per_suite)


def test_every_distractor_type_covers_all_40_tasks(chosen, tasks):
    for s in tx.settings_of("task_relevant_distractors"):
        assert sorted(c.task.key for c in chosen[s.id]) == sorted(t.key for t in tasks), s.id


def test_geometry_settings_cover_the_same_36_tasks(chosen):
    task_sets = {frozenset(c.task.key for c in chosen[s.id]) for s in tx.settings_of("target_geometry_variation")}
    assert len(task_sets) == 1 and len(next(iter(task_sets))) == 36


def test_variants_fill_after_the_base_and_have_their_own_ids_and_params(chosen):
    ids = Counter()
    for cases in chosen.values():
        per_task = defaultdict(list)
        for c in cases:
            cid = case_id(c.task, c.setting, c.variant)
            ids[cid] += 1
            per_task[c.task.key].append(c.variant.name)
            params = variant_params(c.setting, c.variant)
            if c.variant.name == BASE:
                assert cid == f"{c.task.key}/{c.setting.id.removeprefix('vpro/')}"
                assert params == c.setting.param_dict  # existing cases keep their parameters
            else:
                assert cid.endswith(f"-v{c.setting.version}-{c.variant.name}")
                assert params["variant"] == c.variant.name
        assert all(len(v) == len(set(v)) for v in per_task.values())
    assert max(ids.values()) == 1
    openness = chosen["vpro/task_precondition_variation/receptacle_openness-v1"]
    assert Counter(c.variant.name for c in openness) == {"": 5, "open25": 6, "open50": 6, "open75": 4}
    pose = chosen["vpro/task_precondition_variation/object_pose-v1"]
    assert Counter(c.variant.name for c in pose) == {"": 37, "lying": 22}


def test_a_pinned_count_beyond_capacity_is_refused(monkeypatch, tasks):
    broken = tuple(
        al.Pinned(p.category, p.cases, p.source, (("receptacle_openness", 70), ("object_pose", 10)))
        if p.category == "task_precondition_variation"
        else p
        for p in al.PINNED
    )
    monkeypatch.setattr(al, "PINNED", broken)
    with pytest.raises(VProError, match="receptacle_openness-v1: pinned 70 cases"):
        al.select(tasks, SUITES)
