"""The oracle's reachable ceiling beside a model's success: per category, from the certificate's
entries of the cases the model ran (an observation case: its task's Normal baseline), each entry once."""

from vpro_assets.benchmark import certificate as cert
from vpro_assets.report.ceiling import LABEL, ceiling
from vpro_assets.report.tables import category_matrix

STALE = "vpro/camera_staleness/wrist-delay2-v1"
FAMILIAR = "vpro/task_relevant_distractors/familiar_position-v1"


def _row(case_id: str, category: str, level: str, success: bool) -> dict:
    task = case_id.split("/", 1)[0]
    setting = "" if category == "normal" else (STALE if level == "observation" else FAMILIAR)
    return {"policy_id": "model", "case_id": case_id, "task": task, "suite": task.rsplit("-", 1)[0],
            "setting": setting, "category": category, "level": level, "status": "ok", "success": success}  # fmt: skip


def _rows() -> list[dict]:
    rows = []
    for trial in range(10):
        for task in ("libero_goal-03", "libero_goal-04"):
            rows.append(_row(f"{task}/normal", "normal", "normal", True))
            rows.append(_row(f"{task}/camera_staleness/wrist-delay2-v1", "camera_staleness", "observation", trial < 3))
            rows.append(_row(f"{task}/camera_staleness/agent-delay2-v1", "camera_staleness", "observation", trial < 5))
        rows.append(_row("libero_goal-05/task_relevant_distractors/familiar_position-v1", "task_relevant_distractors",
                         "scene", trial < 1))  # fmt: skip
        rows.append(_row("libero_goal-06/task_relevant_distractors/familiar_position-v1", "task_relevant_distractors",
                         "scene", False))  # fmt: skip
    return rows


CERTIFICATE = {
    "cases": {
        "libero_goal-03/normal": {"trials": 10, "solved": 9},
        "libero_goal-04/normal": {"trials": 10, "solved": 10},
        "libero_goal-05/task_relevant_distractors/familiar_position-v1": {"trials": 10, "solved": 7},
    }
}


def test_observation_cases_count_their_tasks_baseline_once_and_uncertified_cases_are_named():
    reach = ceiling(_rows(), CERTIFICATE)
    # Four observation cases over two tasks: the two Normal baselines, once each.
    assert (reach.categories["camera_staleness"].successes, reach.categories["camera_staleness"].trials) == (19, 20)
    assert (reach.normal.successes, reach.normal.trials) == (19, 20)
    scene = reach.categories["task_relevant_distractors"]
    assert (scene.successes, scene.trials) == (7, 10)
    assert reach.missing == ("libero_goal-06/task_relevant_distractors/familiar_position-v1",)


def test_the_category_matrix_shows_the_ceiling_beside_the_model():
    table = category_matrix(_rows(), ceiling(_rows(), CERTIFICATE))
    model, oracle = table.rows
    assert model[0] == "model" and oracle[0] == LABEL
    col = next(i for i, c in enumerate(table.columns) if c.startswith("Camera Staleness"))
    assert model[col].rate.sr == 40.0 and oracle[col].rate.sr == 95.0
    assert "1 case(s) not in the certificate" in table.note
    assert LABEL in table.markdown()


def test_the_committed_certificate_gives_a_ceiling_for_every_normal_task():
    rows = [_row(f"libero_spatial-0{k}/normal", "normal", "normal", False) for k in range(10)]
    reach = ceiling(rows, cert.load())
    assert reach.missing == () and reach.normal.trials == 100 and reach.normal.successes >= 95
