"""The tables of Task-Relevant Scene Variation: distractor contact composition, Table VI
(precondition vs ambiguity, by attribute: a setting's cell pools its variants) and its
per-variant breakdown (which opening level, which pose)."""

from __future__ import annotations

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.variants import BASE, variants_of
from vpro_assets.report.metrics import composition, group, normal_rate
from vpro_assets.report.table_model import Cell, Table, cell, params, policies

# Table VI's columns: (category, setting name) in the paper's order.
TABLE_VI = (
    ("task_precondition_variation", "receptacle_openness", "Precondition: Openness"),
    ("task_precondition_variation", "object_pose", "Precondition: Object Pose"),
    ("visual_state_ambiguity", "receptacle_openness", "Ambiguity: Openness"),
    ("visual_state_ambiguity", "object_pose", "Ambiguity: Object Pose"),
)


def variant_of(row: dict) -> str:
    """The variant an episode row ran (BASE for the setting as defined), read from its case id:
    `<task>/<setting without vpro/>[-<variant>]`."""
    tail = f"{row['task']}/{row['setting'].removeprefix('vpro/')}"
    return row["case_id"][len(tail) + 1 :] if row["case_id"].startswith(tail + "-") else BASE


def distractor_composition(rows: list[dict]) -> Table:
    kinds = list(tx.DISTRACTOR_RULES)
    table = Table(
        "contact_composition",
        "Gripper contact composition (% of episodes) per distractor type",
        ["Policy", "Distractor", "Target only", "Distractor only", "Both", "Neither", "n"],
    )
    for pid in policies(rows):
        cat = [r for r in rows if r["policy_id"] == pid and r["category"] == "task_relevant_distractors"]
        by = group(cat, lambda r: params(r["setting"]).get("distractor"))
        for kind in kinds:
            counts = composition(by.get(kind, []))
            n = sum(counts.values())
            pct = [f"{100 * counts[k] / n:.1f}" if n else "–" for k in counts]
            table.rows.append([pid, kind] + pct + [str(n)])
    return table


def precondition_ambiguity(rows: list[dict]) -> Table:
    table = Table(
        "precondition_ambiguity",
        "Task-Precondition Variation vs Visual State Ambiguity (SR %)",
        [
            "Policy",
            "Normal",
            "Precondition: Openness",
            "Precondition: Object Pose",
            "Ambiguity: Openness",
            "Ambiguity: Object Pose",
        ],
    )
    for pid in policies(rows):
        prow = [r for r in rows if r["policy_id"] == pid]
        cells = []
        for cat in ("task_precondition_variation", "visual_state_ambiguity"):
            by = group([r for r in prow if r["category"] == cat], lambda r: params(r["setting"]).get("attribute"))
            cells += [cell(by.get("receptacle_openness", []), prow), cell(by.get("object_pose", []), prow)]
        table.rows.append([pid, Cell(normal_rate(prow))] + cells)
    return table


def _variant_label(setting: tx.Setting, name: str) -> str:
    if name != BASE:
        return name
    return "other state" if setting.param_dict.get("attribute") == "receptacle_openness" else "inverted"


def scene_variants(rows: list[dict]) -> Table:
    """Table VI per variant: every (setting, variant) column, so the pooled cells can be read apart."""
    columns = []
    for cat, name, title in TABLE_VI:
        s = next(s for s in tx.settings_of(cat) if s.name == name)
        columns += [(s.id, v.name, f"{title} ({_variant_label(s, v.name)})") for v in variants_of(s)]
    table = Table(
        "precondition_ambiguity_variants",
        "Task-Precondition Variation and Visual State Ambiguity per variant (SR %)",
        ["Policy", "Normal"] + [c[2] for c in columns],
        note="The cells of the table above pool these variants (docs/taxonomy.md, Variants).",
    )
    for pid in policies(rows):
        prow = [r for r in rows if r["policy_id"] == pid]
        by = group(
            [r for r in prow if r["category"] in ("task_precondition_variation", "visual_state_ambiguity")],
            lambda r: f"{r['setting']}|{variant_of(r)}",
        )
        table.rows.append(
            [pid, Cell(normal_rate(prow))] + [cell(by.get(f"{sid}|{v}", []), prow) for sid, v, _ in columns]
        )
    return table
