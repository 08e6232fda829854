import pytest

from vpro_assets.core.errors import UnknownIdError
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.tasks import get_task


def test_forty_tasks_in_libero_order(tasks):
    names = libero_bridge.suite_task_names()
    assert [len(v) for v in names.values()] == [10, 10, 10, 10]
    assert [(t.suite, t.name) for t in tasks] == [(s, n) for s, ns in names.items() for n in ns]
    assert [t.index for t in tasks] == list(range(10)) * 4


def test_records_come_from_the_bddl(tasks):
    by_key = {t.key: t for t in tasks}
    bowl_on_plate = by_key["libero_spatial-00"]
    assert bowl_on_plate.target == "akita_black_bowl_1" and bowl_on_plate.target_category == "akita_black_bowl"
    assert bowl_on_plate.receptacle == "plate_1" and bowl_on_plate.placement_relation == "on"
    assert bowl_on_plate.problem_class == "libero_tabletop_manipulation"
    basket = by_key["libero_object-03"]
    assert basket.receptacle == "basket_1" and basket.receptacle_region == "contain_region"
    assert basket.problem_class == "libero_floor_manipulation"
    stove = by_key["libero_goal-07"]
    assert stove.goal == (("turnon", "flat_stove_1"),)
    assert [(a.name, a.kind) for a in stove.articulations] == [("flat_stove_1", "switchable")]
    microwave = by_key["libero_10-09"]
    assert ("close", "microwave_1") in microwave.goal and microwave.openable_receptacle
    for t in tasks:
        assert t.language and t.objects and t.fixtures and t.goal
        assert t.target is None or t.target in dict(t.objects)
        assert (libero_bridge.libero_root() / "bddl_files" / t.bddl_relpath).is_file()


def test_lookup_by_key_or_name_and_suggestions():
    assert get_task("libero_goal-03").name == "open_the_top_drawer_and_put_the_bowl_inside"
    assert get_task("open_the_top_drawer_and_put_the_bowl_inside").key == "libero_goal-03"
    with pytest.raises(UnknownIdError) as err:
        get_task("libero_gaol-03")
    assert "libero_goal-03" in str(err.value)
