"""`vpro report`: tables (Markdown, LaTeX) and plots (PNG) from a results database."""

from __future__ import annotations

import sys
from pathlib import Path

from vpro_assets.benchmark import certificate as cert
from vpro_assets.report.write import write_report


def add_parser(sub) -> None:
    p = sub.add_parser(
        "report",
        help="tables and plots like the paper's from a results database (vpro eval or vla-eval)",
        description="Write report.md and tables.tex (category matrix with SR and drop from Normal, and "
        "the oracle's reachable ceiling per category from the solvability certificate, "
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
    p.add_argument(
        "--certificate",
        type=Path,
        metavar="FILE",
        help="solvability certificate whose oracle success on the same cases is the category matrix's "
        "'oracle ceiling' row (default: the repository's solvability.json when present)",
    )
    p.add_argument("--no-ceiling", action="store_true", help="leave the oracle ceiling row out")
    p.set_defaults(run=run_report)


def run_report(args) -> int:
    certificate = args.certificate
    if certificate is None and cert.certificate_path().is_file():
        certificate = cert.certificate_path()
    written = write_report(
        args.results,
        args.out,
        args.run_ids or None,
        plots=not args.no_plots,
        pool_simulators=args.pool_simulators,
        certificate=None if args.no_ceiling else certificate,
    )
    files = [written["markdown"], written["latex"], *written["plots"]]
    print("vpro report: wrote " + ", ".join(str(f) for f in files), file=sys.stderr)
    return 0
