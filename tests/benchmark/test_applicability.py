import pytest
from hypothesis import given
from hypothesis import strategies as st

from vpro_assets.benchmark import applicability as ap
from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core.errors import VProError


@given(st.lists(st.integers(0, 50), min_size=1, max_size=25), st.integers(0, 600))
def test_water_fill_is_exact_capped_and_fair(capacities, budget):
    if budget > sum(capacities):
        with pytest.raises(VProError):
            ap.water_fill(budget, capacities)
        return
    shares = ap.water_fill(budget, capacities)
    assert sum(shares) == budget
    assert all(0 <= s <= c for s, c in zip(shares, capacities))
    # Max-min fair: a share below another one is only allowed when it is at its capacity.
    for s, c in zip(shares, capacities):
        assert s == c or all(s >= o - 1 for o in shares)


def test_rules_read_task_structure(tasks):
    by_key = {t.key: t for t in tasks}
    open_drawer, push_plate, drawer_bowl = by_key["libero_goal-00"], by_key["libero_goal-05"], by_key["libero_goal-03"]
    assert open_drawer.target is None and open_drawer.articulations
    assert push_plate.target == "plate_1" and push_plate.receptacle is None and not push_plate.requires_grasp
    assert drawer_bowl.openable_receptacle
    openness = tx.setting("vpro/task_precondition_variation/receptacle_openness-v1")
    assert [t.key for t in ap.meaningful_tasks(openness, tasks)] == ["libero_goal-03", "libero_10-03", "libero_10-09"]
    rec_mask = tx.setting("vpro/target_receptacle_masking/ratio50-always-v1")
    assert push_plate not in ap.meaningful_tasks(rec_mask, tasks)
    assert open_drawer in ap.meaningful_tasks(tx.setting("vpro/camera_staleness/wrist-freeze-v1"), tasks)


def test_selection_is_exact_and_keeps_observation_settings_whole(tasks):
    chosen = ap.select(tasks, ("libero_spatial", "libero_object", "libero_goal", "libero_10"))
    assert sum(len(v) for v in chosen.values()) == ap.TOTAL_CASES
    for s in tx.SETTINGS:
        meaningful = ap.meaningful_tasks(s, tasks)
        assert chosen[s.id], s.id
        assert {t.key for t in chosen[s.id]} <= {t.key for t in meaningful}
        if tx.category(s.category).level == tx.OBSERVATION:
            assert chosen[s.id] == meaningful
