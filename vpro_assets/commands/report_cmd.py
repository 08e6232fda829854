"""`vpro report`: tables (Markdown, LaTeX) and plots (PNG) from a results database."""

from __future__ import annotations

import sys
from pathlib import Path

from vpro_assets.report.write import write_report


def add_parser(sub) -> None:
    p = sub.add_parser(
        "report",
        help="tables and plots like the paper's from a results database (vpro eval or vla-eval)",
        description="Write report.md and tables.tex (category matrix with SR and drop from Normal, "
        "per-view staleness and availability, contradiction by attribute, distractors by type with "
        "contact composition, precondition vs ambiguity, geometry, phase-triggered corruption) and "
        "PNG plots. Success rates count finished episodes only, with n and a 95%% Wilson interval; "
        "errors and unavailable episodes are listed apart.",
    )
    p.add_argument(
        "results",
        type=Path,
        metavar="RESULTS",
        help="results database written by vpro eval, or a vla-eval results directory (its "
        "recording-*.sqlite or *_aggregate.json; docs/vla-eval.md)",
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    p.add_argument(
        "--run", dest="run_ids", action="append", default=[], metavar="RUN_ID", help="only these runs (repeatable)"
    )
    p.add_argument("--no-plots", action="store_true", help="tables only")
    p.add_argument(
        "--pool-simulators",
        action="store_true",
        help="allow episodes from different simulators (mujoco / robosuite / hf-libero versions) in one "
        "report; without it such a report is refused (docs/simulator.md)",
    )
    p.set_defaults(run=run_report)


def run_report(args) -> int:

    written = write_report(
        args.results, args.out, args.run_ids or None, plots=not args.no_plots, pool_simulators=args.pool_simulators
    )
    files = [written["markdown"], written["latex"], *written["plots"]]
    print("vpro report: wrote " + ", ".join(str(f) for f in files), file=sys.stderr)
    return 0
