"""The solvability certificate and its document, from the rows of a `vpro certify` run.

`certificate(...)` is the content of `solvability.json` (`vpro_assets.benchmark.certificate`);
`document(...)` is `docs/solvability.md`: the oracle's success per Normal suite and per scene
setting, per task and per case (trials solved k/n, median steps, failure reasons), and a picture of
every case not fully solved. Only rows with `status = 'ok'` are trials; an episode that raised is an
error, counted beside them and never as unsolved. A hand-written block between FINDINGS_BEGIN and
FINDINGS_END (what each failure is: an unsound scene or a limit of the oracle) is kept when the
document is written again.
"""

from __future__ import annotations

import statistics
from collections import defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from vpro_assets.benchmark.certificate import SCHEMA_VERSION, case_sha256, certifiable

NORMAL_TASK_MIN = 8  # of 10 trials: every Normal task (issue 13)
NORMAL_SUITE_MIN = 0.95
SCENE_CASE_MIN = 7  # of 10 trials: every scene case
SCENE_SETTING_MIN = 0.90
FINDINGS_BEGIN = "<!-- findings: written by hand, kept by `vpro certify` -->"
FINDINGS_END = "<!-- end of findings -->"
UNRECORDED = "unrecorded"


@dataclass
class CaseResult:
    case: dict
    solved: list[int] = field(default_factory=list)  # trial indices
    failed: list[int] = field(default_factory=list)
    errors: dict[int, str] = field(default_factory=dict)  # trial -> error message
    steps: dict[int, int] = field(default_factory=dict)
    final_state: dict[int, str] = field(default_factory=dict)
    code_version: dict[int, str | None] = field(default_factory=dict)  # trial -> toolkit commit

    @property
    def trials(self) -> int:
        return len(self.solved) + len(self.failed)

    @property
    def median_steps(self) -> float | None:
        solved = [self.steps[t] for t in self.solved if t in self.steps]
        return statistics.median(solved) if solved else None


def collect(cases: Iterable[dict], rows: Iterable[Mapping]) -> dict[str, CaseResult]:
    """Per certifiable case with at least one row, its trials (in case order)."""
    results = {c["id"]: CaseResult(c) for c in cases if certifiable(c)}
    for row in rows:
        res = results.get(row["case_id"])
        if res is None or row["status"] == "unavailable":
            continue
        t = int(row["trial"])
        if row["status"] == "error":
            res.errors[t] = str(row.get("error") or "error")
            continue
        (res.solved if row["success"] else res.failed).append(t)
        res.steps[t] = int(row["steps"])
        res.final_state[t] = str(row["final_state"])
        res.code_version[t] = row.get("code_version")
    return {cid: r for cid, r in results.items() if r.trials or r.errors}


def code_versions(r: CaseResult) -> dict[str, list[int]]:
    """The toolkit commits that ran the case's trials (`core.provenance`), each with its trials;
    UNRECORDED for trials run before the results recorded it."""
    out: dict[str, list[int]] = {}
    for t in sorted(r.solved + r.failed):
        out.setdefault(r.code_version.get(t) or UNRECORDED, []).append(t)
    return out


def certificate(
    results: Mapping[str, CaseResult],
    catalog_sha: str | None,
    lock_sha: str | None,
    settings: dict,
    versions: dict,
) -> dict:
    cases = {}
    for cid, r in results.items():
        trials = sorted(r.solved + r.failed)
        cases[cid] = {
            "case_sha256": case_sha256(r.case),
            "trials": r.trials,
            "solved": len(r.solved),
            "errors": len(r.errors),
            "solved_trials": sorted(r.solved),
            "steps": [r.steps[t] for t in trials],
            "final_state": [r.final_state[t] for t in trials],
            "trial_ids": trials,
            "code_versions": code_versions(r),
        }
    return {
        "schema_version": SCHEMA_VERSION,
        "catalog_sha256": catalog_sha,
        "lock_sha256": lock_sha,
        "policy": "oracle",
        "settings": settings,
        "versions": versions,
        "inherited": "observation cases: their base task's Normal baseline (<task>/normal)",
        "cases": cases,
    }


def _frac(k: int, n: int) -> str:
    return f"{k}/{n} ({100 * k / n:.1f}%)" if n else "-"


def _steps(x: float | None) -> str:
    return "-" if x is None else f"{x:.0f}"


def _group_rows(groups: dict[str, list[CaseResult]], min_case: int, min_rate: float) -> list[str]:
    out = []
    for name, rs in sorted(groups.items()):
        k, n = sum(len(r.solved) for r in rs), sum(r.trials for r in rs)
        errors = sum(len(r.errors) for r in rs)
        full = sum(1 for r in rs if r.trials and len(r.solved) >= min_case * r.trials / 10)
        meets = "yes" if n and k / n >= min_rate and full == len(rs) else "no"
        out.append(f"| {name} | {len(rs)} | {_frac(k, n)} | {errors} | {full}/{len(rs)} | {meets} |")
    return out


def _reasons(r: CaseResult, reasons: Mapping[tuple[str, int], str]) -> str:
    cid = r.case["id"]
    parts = [f"t{t}: {reasons.get((cid, t), 'not replayed')}" for t in sorted(r.failed)]
    parts += [f"t{t}: error: {msg[:120]}" for t, msg in sorted(r.errors.items())]
    return "; ".join(parts).replace("|", "/") or "-"


def _case_table(rs: list[CaseResult], reasons: Mapping[tuple[str, int], str]) -> list[str]:
    out = ["| case | solved | median steps | failures |", "|---|---|---|---|"]
    for r in rs:
        out.append(
            f"| {r.case['id']} | {_frac(len(r.solved), r.trials)} | {_steps(r.median_steps)} | {_reasons(r, reasons)} |"
        )
    return out


# Long on purpose: the document's sections, in order.
def document(
    results: Mapping[str, CaseResult],
    reasons: Mapping[tuple[str, int], str],
    pictures: Mapping[str, str],
    header: Mapping[str, str],
    findings: str,
    uncertified_scene: int,
) -> str:
    """docs/solvability.md. `reasons`: (case, trial) -> why the trial failed; `pictures`: case ->
    path of its contact sheet relative to docs/; `header`: lines of provenance (catalog, lock,
    versions, command); `findings`: the hand-written block kept between regenerations."""
    normal = [r for r in results.values() if not r.case.get("setting")]
    scene = [r for r in results.values() if r.case.get("setting")]
    lines = [
        "# Solvability certificate",
        "",
        "Every Normal baseline and every scene case run with the privileged oracle "
        "(`vpro_assets/rollout/policies/oracle/`), render-free, through `vpro eval`'s episode runner "
        "(same seeding, step limits, success check and result rows). Written by `vpro certify` from its "
        "results database; `solvability.json` holds the per-case numbers and final-state fingerprints, and "
        "`vpro catalog verify` checks it belongs to the current catalog. A trial that raised is an error "
        "(listed), never an unsolved trial.",
        "",
        "**Observation cases inherit their base task's certificate.** An observation-level case changes "
        "only what the policy sees, never the physics: the same actions give the same simulator states as "
        "the Normal baseline (`tests/perturb/test_render.py::test_physics_unchanged` for representative "
        "settings, `test_physics_unchanged_every_setting` (slow) for every observation setting). So the "
        "oracle, which acts from the simulator state, solves them exactly when it solves `<task>/normal`.",
        "",
        *[f"- {k}: {v}" for k, v in header.items()],
        "",
        "Goals (issue 13): Normal at least 95% of its trials with every task at least 8 of 10; every scene "
        "setting at least 90% with every case at least 7 of 10 (scaled to the trials run).",
        "",
        "## Normal baselines per suite",
        "",
        "| suite | tasks | trials solved | errors | tasks at goal | meets goal |",
        "|---|---|---|---|---|---|",
    ]
    by_suite: dict[str, list[CaseResult]] = defaultdict(list)
    for r in normal:
        by_suite[r.case["suite"]].append(r)
    lines += _group_rows(by_suite, NORMAL_TASK_MIN, NORMAL_SUITE_MIN)
    k, n = sum(len(r.solved) for r in normal), sum(r.trials for r in normal)
    lines += [f"| all | {len(normal)} | {_frac(k, n)} | {sum(len(r.errors) for r in normal)} | | |", ""]
    lines += ["## Scene settings", ""]
    if uncertified_scene:
        lines += [f"{uncertified_scene} scene case(s) of the catalog are not certified yet (not in the table).", ""]
    lines += [
        "| setting | cases | trials solved | errors | cases at goal | meets goal |",
        "|---|---|---|---|---|---|",
    ]
    by_setting: dict[str, list[CaseResult]] = defaultdict(list)
    for r in scene:
        by_setting[r.case["setting"]].append(r)
    lines += _group_rows(by_setting, SCENE_CASE_MIN, SCENE_SETTING_MIN)
    lines += ["", "## Findings", "", FINDINGS_BEGIN, findings.strip() or "(none written yet)", FINDINGS_END, ""]
    lines += ["## Normal baselines per task", "", *_case_table(normal, reasons), ""]
    lines += ["## Scene cases", ""]
    for setting, rs in sorted(by_setting.items()):
        lines += [f"### {setting}", "", *_case_table(rs, reasons), ""]
    unsolved = [r for r in results.values() if r.failed or r.errors]
    lines += ["## Cases not fully solved", ""]
    if not unsolved:
        lines += ["None.", ""]
    for r in unsolved:
        cid = r.case["id"]
        lines += [f"### {cid}", "", f"{_frac(len(r.solved), r.trials)} solved. {_reasons(r, reasons)}", ""]
        if cid in pictures:
            lines += [f"![{cid}]({pictures[cid]})", ""]
    return "\n".join(lines).rstrip() + "\n"


def kept_findings(previous: str | None) -> str:
    """The hand-written findings block of a previous document ('' when there is none)."""
    if not previous or FINDINGS_BEGIN not in previous or FINDINGS_END not in previous:
        return ""
    body = previous.split(FINDINGS_BEGIN, 1)[1].split(FINDINGS_END, 1)[0].strip()
    return "" if body == "(none written yet)" else body
