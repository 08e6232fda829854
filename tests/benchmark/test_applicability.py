from vpro_assets.benchmark import allocation as al
from vpro_assets.benchmark import applicability as ap
from vpro_assets.benchmark import taxonomy as tx


def test_rules_read_task_structure(tasks):
    by_key = {t.key: t for t in tasks}
    open_drawer, push_plate, drawer_bowl = by_key["libero_goal-00"], by_key["libero_goal-05"], by_key["libero_goal-03"]
    assert open_drawer.target is None and open_drawer.articulations
    assert push_plate.target == "plate_1" and push_plate.receptacle is None and not push_plate.requires_grasp
    assert drawer_bowl.openable_receptacle
    openness = tx.setting("vpro/task_precondition_variation/receptacle_openness-v1")
    assert [t.key for t in ap.meaningful_tasks(openness, tasks)] == [
        "libero_goal-02",
        "libero_goal-03",
        "libero_goal-04",
        "libero_10-03",
        "libero_10-09",
    ]
    # The ghost of the other state does not satisfy a goal that opens the drawer: libero_goal-00 too.
    ghost = tx.setting("vpro/visual_state_ambiguity/receptacle_openness-v1")
    assert [t.key for t in ap.meaningful_tasks(ghost, tasks)][0] == "libero_goal-00"
    rec_mask = tx.setting("vpro/target_receptacle_masking/ratio50-always-v1")
    assert push_plate not in ap.meaningful_tasks(rec_mask, tasks)
    assert open_drawer in ap.meaningful_tasks(tx.setting("vpro/camera_staleness/wrist-freeze-v1"), tasks)


def test_selection_is_exact_and_only_picks_meaningful_tasks(tasks):
    chosen = al.select(tasks, ("libero_spatial", "libero_object", "libero_goal", "libero_10"))
    assert sum(len(v) for v in chosen.values()) == al.TOTAL_CASES
    for s in tx.SETTINGS:
        allowed = {(v.name, t.key) for v, ts in al.candidates(s, tasks) for t in ts}
        assert chosen[s.id], s.id
        assert {(c.variant.name, c.task.key) for c in chosen[s.id]} <= allowed
