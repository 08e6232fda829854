"""`vpro certify`: prove the cases solvable with the privileged oracle and write the certificate."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

from tqdm import tqdm

from vpro_assets.benchmark import certificate as cert
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import describe, select_cases
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.report.certify import Outputs, certifiable_cases, run_certify, write_outputs

DEFAULT_RESULTS = Path("out/certify/certify.sqlite")


# Long on purpose: one declaration per option, in --help order.
def add_parser(sub) -> None:
    p = sub.add_parser(
        "certify",
        help="run the oracle on the Normal baselines and scene cases; write the solvability certificate",
        description="Run the privileged oracle render-free on the Normal baselines and the scene cases "
        "(observation cases inherit their base task's certificate) through vpro eval's episode runner, "
        "then write solvability.json (per case: trials solved, steps, final-state fingerprints, the catalog "
        "and lock hashes) and docs/solvability.md (per setting and task: k/n, median steps, failure reasons "
        "read from a replay of each failed trial, a picture of every case not fully solved). The results "
        "accumulate in one run of the results database: certify more cases with --resume.",
    )
    p.add_argument(
        "--select",
        action="append",
        default=[],
        metavar="FILTER",
        help="case id, setting, category, dimension, suite or task (repeatable, union); default: every Normal "
        "baseline and scene case; an observation case stands for its task's Normal baseline",
    )
    p.add_argument("--trials", type=int, default=10, help="trials per case (default 10)")
    p.add_argument("-j", "--workers", type=int, default=1, help="parallel episodes (default 1)")
    p.add_argument("--backend", choices=("local", "inline", "ray"), default="local", help="episode backend")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue the certification run of the results database; into a database without one, start "
        "from the committed certificate (its cases whose records are unchanged keep their trials)",
    )
    p.add_argument(
        "--redo",
        action="append",
        default=[],
        metavar="FILTER",
        help="run these cases again (as --select; e.g. after improving the oracle): their trials are dropped",
    )
    p.add_argument(
        "--results",
        type=Path,
        default=DEFAULT_RESULTS,
        metavar="FILE.sqlite",
        help=f"results database (default {DEFAULT_RESULTS})",
    )
    p.add_argument(
        "--certificate",
        type=Path,
        default=None,
        help="certificate to write (default: the repository's solvability.json)",
    )
    p.add_argument(
        "--doc", type=Path, default=None, help="document to write (default: docs/solvability.md of the repository)"
    )
    p.add_argument(
        "--write-only", action="store_true", help="run nothing; write the certificate and document from the database"
    )
    p.add_argument(
        "--no-replays",
        action="store_true",
        help="write without replaying failed trials (their reasons: only those already replayed)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress line")
    p.set_defaults(run=run_certify_cmd)


def run_certify_cmd(args) -> int:
    if args.workers < 1:
        raise VProError(f"-j/--workers must be at least 1, got {args.workers}")
    catalog_file = paths.catalog_path()
    catalog = load_catalog(catalog_file)
    doc = args.doc or paths.REPO_ROOT / "docs" / "solvability.md"
    outputs = Outputs(args.certificate or cert.certificate_path(), doc, doc.parent / "solvability")
    if not args.write_only:
        if args.select:
            cases = certifiable_cases(catalog, select_cases(catalog, args.select))
        else:
            cases = catalog["normal"] + [c for c in catalog["cases"] if c.get("level") == "scene"]
        redo = certifiable_cases(catalog, select_cases(catalog, args.redo)) if args.redo else []
        cases += [c for c in redo if c not in cases]
        carry = (catalog, cert.load(outputs.certificate)) if args.resume and outputs.certificate.is_file() else None
        if not cases:
            raise VProError("the selection holds no case to certify")
        print(f"vpro certify: {describe(cases)} x {args.trials} trial(s) -> {args.results}", file=sys.stderr)
        tally: Counter = Counter()
        bar = tqdm(desc="vpro certify", unit="episode", disable=args.no_progress, dynamic_ncols=True)

        def plan(todo: int, skipped: int) -> None:
            bar.reset(total=todo + skipped)
            bar.update(skipped)

        def row(r: dict) -> None:
            tally.update([r["status"]] + (["solved"] if r.get("success") else []))
            bar.set_postfix_str(f"solved {tally['solved']} of {tally['ok']}, {tally['error']} error(s)", refresh=False)
            bar.update(1)

        summary = run_certify(
            cases,
            args.results,
            args.trials,
            args.resume,
            args.backend,
            args.workers,
            args.address,
            args.select,
            on_row=row,
            on_plan=plan,
            carry_from=carry,
            redo=[c["id"] for c in redo],
        )
        bar.close()
        print(
            f"vpro certify: {summary.recorded} episode(s) in {summary.elapsed:.0f} s "
            f"({3600 * summary.recorded / max(summary.elapsed, 1e-9):.0f} per hour)",
            file=sys.stderr,
        )
    certificate = write_outputs(catalog_file, args.results, outputs, replays=not args.no_replays)
    entries = certificate["cases"].values()
    solved, trials = sum(e["solved"] for e in entries), sum(e["trials"] for e in entries)
    print(
        f"{outputs.certificate}: {len(certificate['cases'])} case(s), {solved}/{trials} trials solved; "
        f"{outputs.document} written"
    )
    return 0
