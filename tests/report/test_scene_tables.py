"""Table VI with several variants per task: the pooled cell and the per-variant breakdown."""

from vpro_assets.report.scene_tables import precondition_ambiguity, scene_variants, variant_of
from vpro_assets.report.tables import all_tables

OPEN = "vpro/task_precondition_variation/receptacle_openness-v1"
POSE = "vpro/task_precondition_variation/object_pose-v1"


def _row(case_id: str, setting: str, success: bool, category: str = "task_precondition_variation") -> dict:
    task = case_id.split("/", 1)[0]
    return {
        "policy_id": "p",
        "case_id": case_id,
        "task": task,
        "suite": task.rsplit("-", 1)[0],
        "setting": setting,
        "category": category,
        "status": "ok",
        "success": success,
        "error": "",
    }


def _rows() -> list[dict]:
    rows = []
    for trial in range(10):
        rows.append(_row("libero_goal-03/task_precondition_variation/receptacle_openness-v1", OPEN, trial < 8))
        rows.append(_row("libero_goal-03/task_precondition_variation/receptacle_openness-v1-open25", OPEN, trial < 2))
        rows.append(_row("libero_goal-03/task_precondition_variation/object_pose-v1-lying", POSE, trial < 5))
        rows.append(_row("libero_goal-03/normal", "", True, category="normal"))
    return rows


def test_variant_is_read_from_the_case_id():
    rows = _rows()
    assert [variant_of(r) for r in rows[:3]] == ["", "open25", "lying"]


def test_a_settings_cell_pools_its_variants_and_the_breakdown_splits_them():
    rows = _rows()
    pooled = precondition_ambiguity(rows).rows[0]
    assert pooled[2].rate.trials == 20 and pooled[2].rate.sr == 50.0  # openness: 8 + 2 of 20
    assert pooled[3].rate.sr == 50.0  # object pose: the lying variant alone
    table = scene_variants(rows)
    col = {name: i for i, name in enumerate(table.columns)}
    row = table.rows[0]
    assert row[col["Precondition: Openness (other state)"]].rate.sr == 80.0
    assert row[col["Precondition: Openness (open25)"]].rate.sr == 20.0
    assert row[col["Precondition: Openness (open75)"]].rate.trials == 0
    assert row[col["Precondition: Object Pose (lying)"]].rate.sr == 50.0
    assert row[col["Precondition: Object Pose (inverted)"]].rate.trials == 0
    assert "precondition_ambiguity_variants" in {t.key for t in all_tables(rows)}
    assert "open25" in table.markdown() and r"\begin{tabular}" in table.latex()
