"""The paper's tables from episode rows, as data first, then Markdown and LaTeX.

Tables (file stems): `category_matrix` (SR per category with drop from Normal, robustness
categories marked up-arrow, diagnostic ones diamond), `view_reliance` (staleness per stale view,
availability per retained view), `contradiction` (by attribute), `distractors` (by type) and
`contact_composition`, `precondition_ambiguity` (openness, object pose), `geometry` (by deformation
and by severity), `phase_corruption` (by trigger phase and frequency), `interaction_cue` (by
region), `suites`, `episodes` (status counts and errors). A cell holds a success rate over `ok`
episodes with its trial count, a 95% Wilson interval and its drop from Normal on the same tasks.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.report.metrics import Rate, composition, drop, group, normal_rate, rate

ROBUST_MARK, DIAG_MARK = "↑", "◇"
LATEX_MARKS = {tx.ROBUSTNESS: r"$\,\uparrow$", tx.DIAGNOSTIC: r"$\,\diamond$"}
LATEX_PREAMBLE = r"""% Macros used by these tables (redefine \ci as {} to hide intervals):
% \usepackage{xcolor}
\providecommand{\drop}[1]{{\color{gray}\scriptsize$\downarrow$#1}}
\providecommand{\gain}[1]{{\color{gray}\scriptsize$\uparrow$#1}}
\providecommand{\ci}[3]{{\tiny\,[#1,#2]\,n=#3}}
"""


@dataclass
class Cell:
    rate: Rate
    drop: float | None = None

    def markdown(self) -> str:
        if self.rate.sr is None or self.rate.ci is None:
            return "–" + (f" ({self.rate.errors} err)" if self.rate.errors else "")
        lo, hi = self.rate.ci
        d = "" if self.drop is None else (f" ↓{self.drop:.1f}" if self.drop >= 0 else f" ↑{-self.drop:.1f}")
        err = f", {self.rate.errors} err" if self.rate.errors else ""
        return f"{self.rate.sr:.1f}{d} (n={self.rate.trials}; {lo:.1f}–{hi:.1f}{err})"

    def latex(self) -> str:
        if self.rate.sr is None or self.rate.ci is None:
            return "--"
        lo, hi = self.rate.ci
        d = (
            ""
            if self.drop is None
            else (rf"\drop{{{self.drop:.1f}}}" if self.drop >= 0 else rf"\gain{{{-self.drop:.1f}}}")
        )
        return rf"{self.rate.sr:.2f}{d}\ci{{{lo:.1f}}}{{{hi:.1f}}}{{{self.rate.trials}}}"


@dataclass
class Table:
    key: str
    title: str
    columns: list[str]
    rows: list[list] = field(default_factory=list)  # first entry: row label; others Cell or str
    note: str = ""
    latex_columns: list[str] | None = None

    def markdown(self) -> str:
        out = [f"### {self.title}", ""]
        if self.note:
            out += [self.note, ""]
        out.append("| " + " | ".join(self.columns) + " |")
        out.append("|" + "|".join("---" for _ in self.columns) + "|")
        for row in self.rows:
            out.append("| " + " | ".join(c.markdown() if isinstance(c, Cell) else str(c) for c in row) + " |")
        return "\n".join(out) + "\n"

    def latex(self) -> str:
        cols = self.latex_columns or [_tex(c) for c in self.columns]
        lines = [
            r"\begin{table}[t]",
            rf"\caption{{{_tex(self.title)}}}",
            rf"\label{{tab:vpro_{self.key}}}",
            r"\centering",
            r"\scriptsize",
            r"\resizebox{\columnwidth}{!}{%",
            rf"\begin{{tabular}}{{l{'c' * (len(cols) - 1)}}}",
            r"\hline",
            " & ".join(cols) + r" \\",
            r"\hline",
        ]
        for row in self.rows:
            lines.append(" & ".join(c.latex() if isinstance(c, Cell) else _tex(str(c)) for c in row) + r" \\")
        lines += [r"\hline", r"\end{tabular}%", "}", r"\end{table}"]
        return "\n".join(lines) + "\n"


def _tex(text: str) -> str:
    for a, b in (
        ("\\", r"\textbackslash{}"),
        ("&", r"\&"),
        ("%", r"\%"),
        ("_", r"\_"),
        ("#", r"\#"),
        ("↑", r"$\uparrow$"),
        ("◇", r"$\diamond$"),
        ("↓", r"$\downarrow$"),
    ):
        text = text.replace(a, b)
    return text


@functools.cache
def params(setting_id: str) -> dict:
    try:
        return tx.setting(setting_id).param_dict
    except Exception:  # a setting of another taxonomy version: no parameters to group by
        return {}


def policies(rows: list[dict]) -> list[str]:
    return sorted({r["policy_id"] for r in rows})


def cell(cell_rows: list[dict], policy_rows: list[dict]) -> Cell:
    return Cell(rate(cell_rows), drop(cell_rows, policy_rows))


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


def category_matrix(rows: list[dict]) -> Table:
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
        srs = [c.rate.sr for c in cells if c.rate.sr is not None]
        drops = [c.drop for c in cells if c.drop is not None]
        overall = Cell(Rate(0, 0)) if not srs else None
        avg = f"{sum(srs) / len(srs):.2f}" + (f" ↓{sum(drops) / len(drops):.1f}" if drops else "") if srs else "–"
        table.rows.append([pid, Cell(normal_rate(prow))] + cells + [avg if overall is None else overall])
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
def all_tables(rows: list[dict]) -> list[Table]:
    phases = {p: p.replace("_", "-") for p in tx.PHASES}
    return [
        category_matrix(rows),
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
        distractor_composition(rows),
        precondition_ambiguity(rows),
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
