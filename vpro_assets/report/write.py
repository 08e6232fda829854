"""`vpro report`: every table in Markdown (`report.md`) and LaTeX (`tables.tex`), plus PNG plots."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vpro_assets.benchmark import certificate as cert
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.libero.bridge import SIMULATOR_PACKAGES, simulator_label
from vpro_assets.report.ceiling import ceiling
from vpro_assets.report.plots import write_plots
from vpro_assets.report.tables import LATEX_PREAMBLE, all_tables
from vpro_assets.report.vla_eval_results import is_vla_eval_results, read_vla_eval
from vpro_assets.rollout.store import ResultsStore


def simulators_of(rows: Sequence[dict], runs: Sequence[dict]) -> dict[str, int]:
    """Episode count per simulator label; rows without one (schema 1) take their run's versions."""
    run_versions = {r["run_id"]: r["versions"] for r in runs}
    counts: dict[str, int] = {}
    for row in rows:
        versions = row.get("simulator") or {
            k: v for k, v in run_versions.get(row["run_id"], {}).items() if k in SIMULATOR_PACKAGES
        }
        label = simulator_label(versions) if versions else "simulator not recorded"
        counts[label] = counts.get(label, 0) + 1
    return counts


def write_report(
    results: Path | str,
    out: Path | str,
    run_ids: Sequence[str] | None = None,
    plots: bool = True,
    pool_simulators: bool = False,
    certificate: Path | None = None,
) -> dict:
    """`certificate`: a solvability certificate whose oracle success on the same cases is the
    category matrix's ceiling row (None: no such row)."""
    results, out = Path(results), Path(out)
    if is_vla_eval_results(results):  # a vla-eval results directory (docs/vla-eval.md)
        runs, all_rows = read_vla_eval(results)
    elif not results.is_file():
        raise VProError(f"{results}: no such results database or vla-eval results directory")
    else:
        with ResultsStore(results) as store:
            runs = store.runs()
            all_rows = [row for r in runs for row in store.episodes(r["run_id"])]
    known = {r["run_id"] for r in runs}
    for rid in run_ids or []:
        if rid not in known:
            raise VProError(f"{results}: no run {rid!r} (runs: {', '.join(sorted(known)) or 'none'})")
    chosen = [r for r in runs if not run_ids or r["run_id"] in run_ids]
    rows = [row for row in all_rows if row["run_id"] in {r["run_id"] for r in chosen}]
    if not rows:
        raise VProError(f"{results}: no episodes recorded" + (f" in runs {', '.join(run_ids)}" if run_ids else ""))
    simulators = simulators_of(rows, chosen)
    if len(simulators) > 1 and not pool_simulators:
        raise VProError(
            f"{results}: the episodes come from {len(simulators)} simulators ("
            + "; ".join(f"{label}: {n} episode(s)" for label, n in sorted(simulators.items()))
            + "); choose runs of one with --run, or pool them with --pool-simulators"
        )
    reachable = ceiling(rows, cert.load(certificate)) if certificate is not None else None
    tables = all_tables(rows, reachable)
    header = [
        "# LIBERO-VPro report",
        "",
        f"Results: `{results}`; {len(rows)} episode row(s) from {len(chosen)} run(s):",
        "",
    ]
    for label, n in sorted(simulators.items()):
        header.append(
            f"- simulator: {label} ({n} episode(s))"
            + (" POOLED with other simulators (--pool-simulators)" if len(simulators) > 1 else "")
        )
    for r in chosen:
        s = r["settings"]
        header.append(
            f"- `{r['run_id']}`: policy `{r['policy_id']}` ({r['policy_spec']}), {r['trials']} trial(s)/case, "
            f"resolution {s['resolution']}, {s['wait_steps']} wait steps, max steps "
            f"{s['max_steps_override'] or s['max_steps']}"
        )
    if reachable is not None:
        header.append(
            f"- oracle ceiling: `{certificate}`"
            + (f" ({len(reachable.missing)} case(s) of these rows not certified)" if reachable.missing else "")
        )
    md = "\n".join(header) + "\n\n" + "\n".join(t.markdown() for t in tables)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "report.md", md)
    write_text_atomic(out / "tables.tex", LATEX_PREAMBLE + "\n" + "\n".join(t.latex() for t in tables))
    written = {"markdown": out / "report.md", "latex": out / "tables.tex", "plots": []}
    if plots:
        written["plots"] = write_plots(rows, out)
    return written
