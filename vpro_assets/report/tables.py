"""The paper's tables from episode rows, as data first, then Markdown and LaTeX.

Tables (file stems): `category_matrix` (SR per category with drop from Normal, robustness
categories marked up-arrow, diagnostic ones diamond; with a certificate, the oracle's reachable
ceiling per category as its last row: `report.ceiling`), `view_reliance` (staleness per stale view,
availability per retained view), `contradiction` (by attribute), `distractors` (by type) and
`contact_composition`, `precondition_ambiguity` (openness, object pose; a setting's cell pools
its variants) and `precondition_ambiguity_variants` (per variant), `geometry` (by deformation
and by severity), `phase_corruption` (by trigger phase and frequency), `interaction_cue` (by
region), `suites`, `episodes` (status counts and errors). A cell holds a success rate over `ok`
episodes with its trial count, a 95% Wilson interval and its drop from Normal on the same tasks.
Cells and their renderings: `report.table_model`; the scene-variation tables: `report.scene_tables`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.report import scene_tables
from vpro_assets.report.ceiling import LABEL as CEILING_LABEL
from vpro_assets.report.ceiling import Ceiling
from vpro_assets.report.metrics import Rate, group, normal_rate, rate
from vpro_assets.report.table_model import (
    DIAG_MARK,
    LATEX_PREAMBLE,
    ROBUST_MARK,
    Cell,
    Table,
    cell,
    params,
    policies,
)

__all__ = ["LATEX_PREAMBLE", "Cell", "Table", "all_tables", "params", "policies"]


def _by_param(
    title: str,
    key: str,
    category: str,
    param: str,
    columns: Mapping[Any, str],
    rows: list[dict],
    note: str = "",
    extra: Callable[[dict], bool] | None = None,
) -> Table:
    """One column per value of a setting parameter within one category."""
    table = Table(key, title, ["Policy", "Normal"] + list(columns.values()), note=note)
    for pid in policies(rows):
        prow = [r for r in rows if r["policy_id"] == pid]
        cat = [r for r in prow if r["category"] == category and (extra is None or extra(r))]
        cells = group(cat, lambda r: params(r["setting"]).get(param))
        tasks = {r["task"] for r in cat if r["status"] == "ok"}
        table.rows.append(
            [pid, Cell(normal_rate(prow, tasks or None))] + [cell(cells.get(v, []), prow) for v in columns]
        )
    return table


def _average(cells: list[Cell]) -> str | Cell:
    srs = [c.rate.sr for c in cells if c.rate.sr is not None]
    drops = [c.drop for c in cells if c.drop is not None]
    if not srs:
        return Cell(Rate(0, 0))
    return f"{sum(srs) / len(srs):.2f}" + (f" ↓{sum(drops) / len(drops):.1f}" if drops else "")


def category_matrix(rows: list[dict], ceiling: Ceiling | None = None) -> Table:
    cats = list(tx.CATEGORIES)
    present = {r["category"] for r in rows}
    cats = [c for c in cats if c.id in present] or cats
    cols = ["Policy", "Normal"] + [
        f"{c.title} {ROBUST_MARK if c.indicator == tx.ROBUSTNESS else DIAG_MARK}" for c in cats
    ]
    table = Table(
        "category_matrix",
        "Success rate (%) per category, drop from Normal on the same tasks",
        cols + ["Overall Avg."],
        note=f"{ROBUST_MARK} robustness indicator (higher is better); {DIAG_MARK} diagnostic indicator "
        "(high SR may reflect priors or other cues). Cells: SR ↓drop (n = successful-or-failed "
        "episodes; 95% Wilson interval). Errors and unavailable episodes are not counted.",
    )
    for pid in policies(rows):
        prow = [r for r in rows if r["policy_id"] == pid]
        cells = [cell([r for r in prow if r["category"] == c.id], prow) for c in cats]
        table.rows.append([pid, Cell(normal_rate(prow))] + cells + [_average(cells)])
    if ceiling is not None:
        cells = [Cell(ceiling.categories.get(c.id, Rate(0, 0))) for c in cats]
        table.rows.append([CEILING_LABEL, Cell(ceiling.normal)] + cells + [_average(cells)])
        table.note += (
            f" {CEILING_LABEL}: the privileged oracle's certified success on the same cases (solvability.json: "
            "a scene case its own entry, an observation case its task's Normal baseline; each entry once), "
            "the reachable ceiling per category"
            + (f"; {len(ceiling.missing)} case(s) not in the certificate left out." if ceiling.missing else ".")
        )
    return table


def view_reliance(rows: list[dict]) -> Table:
    table = Table(
        "view_reliance",
        "Per-view success rate (%): staleness of one view; availability of one view",
        [
            "Policy",
            "Normal",
            "Staleness: Third",
            "Staleness: Wrist",
            "Availability: Third retained",
            "Availability: Wrist retained",
        ],
        note="Staleness: only the named camera is stale. Availability: only the named view is kept "
        "(the other removed by any replacement).",
    )
    for pid in policies(rows):
        prow = [r for r in rows if r["policy_id"] == pid]
        stale = group(
            [r for r in prow if r["category"] == "camera_staleness"], lambda r: params(r["setting"]).get("view")
        )
        avail = group(
            [r for r in prow if r["category"] == "view_unavailability"], lambda r: params(r["setting"]).get("view")
        )
        table.rows.append(
            [
                pid,
                Cell(normal_rate(prow)),
                cell(stale.get("third_person", []), prow),
                cell(stale.get("wrist", []), prow),
                cell(avail.get("wrist", []), prow),
                cell(avail.get("third_person", []), prow),
            ]
        )
    return table


def episodes_table(rows: list[dict]) -> Table:
    table = Table(
        "episodes",
        "Episodes by category and status",
        ["Policy", "Category", "ok", "error", "unavailable", "first error"],
    )
    for pid in policies(rows):
        by = group([r for r in rows if r["policy_id"] == pid], lambda r: r["category"])
        for cat in ["normal"] + [c.id for c in tx.CATEGORIES]:
            if cat not in by:
                continue
            rs = by[cat]
            n = {s: sum(r["status"] == s for r in rs) for s in ("ok", "error", "unavailable")}
            first = next((r["error"] for r in rs if r["error"]), "")
            table.rows.append([pid, cat, n["ok"], n["error"], n["unavailable"], first[:120].replace("|", "/")])
    return table


def suites_table(rows: list[dict]) -> Table:
    suites = sorted({r["suite"] for r in rows})
    table = Table(
        "suites", "Success rate (%) per suite: Normal and all perturbed cases", ["Policy", "Condition"] + suites
    )
    for pid in policies(rows):
        prow = [r for r in rows if r["policy_id"] == pid]
        for label, pick in (
            ("Normal", lambda r: r["category"] == "normal"),
            ("Perturbed", lambda r: r["category"] != "normal"),
        ):
            by = group([r for r in prow if pick(r)], lambda r: r["suite"])
            table.rows.append([pid, label] + [Cell(rate(by.get(s, []))) for s in suites])
    return table


# Long on purpose: the list of the paper's tables, in the report's order.
def all_tables(rows: list[dict], ceiling: Ceiling | None = None) -> list[Table]:
    phases = {p: p.replace("_", "-") for p in tx.PHASES}
    return [
        category_matrix(rows, ceiling),
        view_reliance(rows),
        _by_param(
            "Success rate (%) under Cross-View Contradiction, by attribute",
            "contradiction",
            "cross_view_contradiction",
            "attribute",
            {"quantity": "Quantity", "existence": "Existence", "position": "Position", "state": "State"},
            rows,
        ),
        _by_param(
            "Success rate (%) under Task-Relevant Distractors, by type",
            "distractors",
            "task_relevant_distractors",
            "distractor",
            {
                "same_category": "Category",
                "same_color": "Color",
                "same_shape": "Shape",
                "same_affordance": "Afford.",
                "familiar_position": "Position",
                "trajectory_obstacle": "Trajectory",
            },
            rows,
        ),
        scene_tables.distractor_composition(rows),
        scene_tables.precondition_ambiguity(rows),
        scene_tables.scene_variants(rows),
        _by_param(
            "Success rate (%) under Target Geometry Variation, by deformation",
            "geometry",
            "target_geometry_variation",
            "deformation",
            {"taper": "Taper", "multipeak": "Multi-peak", "twist": "Twist", "asymmetric": "Asymmetric"},
            rows,
        ),
        _by_param(
            "Success rate (%) under Target Geometry Variation, by severity",
            "geometry_severity",
            "target_geometry_variation",
            "severity",
            {1: "Severity 1", 2: "Severity 2", 3: "Severity 3"},
            rows,
        ),
        _by_param(
            "Success rate (%) under phase-triggered Temporary Observation Corruption",
            "phase_corruption",
            "temporary_observation_corruption",
            "phase",
            phases,
            rows,
            note="Blackout and noise pooled; frequency-triggered settings are in the next table.",
        ),
        _by_param(
            "Success rate (%) under frequency-triggered Temporary Observation Corruption",
            "frequency_corruption",
            "temporary_observation_corruption",
            "onset_prob",
            {v: f"{k} ({v:g}/step)" for k, v in tx.CORRUPTION_FREQUENCIES.items()},
            rows,
        ),
        _by_param(
            "Success rate (%) under Interaction-Cue Masking, by region",
            "interaction_cue",
            "interaction_cue_masking",
            "region",
            {
                "gripper": "Gripper",
                "gripper_object_contact": "Gripper-object contact",
                "placement_contact": "Placement contact",
            },
            rows,
        ),
        suites_table(rows),
        episodes_table(rows),
    ]
