"""`vpro eval`: run a policy on selected cases and record every episode in a results database."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

from tqdm import tqdm

from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import describe, select_cases
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.rollout.episode import MAX_STEPS, EpisodeSettings
from vpro_assets.rollout.runner import run_eval


# Long on purpose: one declaration per option, in --help order.
def add_parser(sub) -> None:
    p = sub.add_parser(
        "eval",
        help="run a policy on cases and store every episode (SQLite, resumable)",
        description="Run a policy on the selected cases, N trials each, with LIBERO's conventions (10 no-op wait "
        "steps; at most 220/280/300/520 steps for libero_spatial/object/goal/10). Every episode becomes one row "
        "of the results database, committed as it ends; a killed run continues with --resume. Infrastructure "
        "errors (server down or slow, NaN or misshapen actions, simulator exceptions) are retried and recorded "
        "as errors, never as policy failures.",
    )
    p.add_argument(
        "--policy",
        required=True,
        metavar="SPEC",
        help="noop | random | oracle | openpi:HOST:PORT | ws://HOST:PORT | py:MODULE:ATTR",
    )
    p.add_argument(
        "--select",
        action="append",
        default=[],
        metavar="FILTER",
        help="case id, setting, category, dimension, suite or task (repeatable, union); "
        "'normal' selects the Normal baselines (narrowed by a suite or task given with it)",
    )
    p.add_argument("--trials", type=int, default=10, help="trials per case (default 10, LIBERO's first init states)")
    p.add_argument("--results", type=Path, required=True, metavar="FILE.sqlite", help="results database")
    p.add_argument("--run-id", help="name of the run (default: time and policy); with --resume, the run to continue")
    p.add_argument("--resume", action="store_true", help="continue a run (the latest one unless --run-id)")
    p.add_argument(
        "--retry-errors", action="store_true", help="with --resume, run again episodes that ended in an error"
    )
    p.add_argument(
        "--backend",
        choices=("local", "inline", "ray"),
        default="local",
        help="local process pool (default), inline (this process, for debugging) or ray",
    )
    p.add_argument("--workers", type=int, default=1, help="parallel episodes (default 1)")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    p.add_argument("--resolution", type=int, default=256, help="camera resolution (default 256)")
    p.add_argument("--wait-steps", type=int, default=10, help="no-op steps before the policy acts (default 10)")
    p.add_argument(
        "--max-steps",
        action="append",
        default=[],
        metavar="N|SUITE=N",
        help="step limit for every suite, or for one suite (repeatable)",
    )
    p.add_argument("--replan-steps", type=int, help="actions executed per openpi request (default 5)")
    p.add_argument("--connect-timeout", type=float, help="seconds to wait for the policy server handshake (default 10)")
    p.add_argument("--infer-timeout", type=float, help="seconds to wait for one policy reply (default 120)")
    p.add_argument("--policy-id", help="policy name recorded in every row (default: the spec)")
    p.add_argument("--retries", type=int, default=2, help="extra attempts after an infrastructure error (default 2)")
    p.add_argument(
        "--retry-delay", type=float, default=2.0, help="seconds before a retry, times the attempt (default 2)"
    )
    p.add_argument("--video", type=Path, metavar="DIR", help="write one mp4 per episode (clean | policy views)")
    p.add_argument(
        "--no-render",
        action="store_true",
        help="render-free episodes: no renderer, no cameras (policies that act from simulator state: "
        "oracle, noop, random); same seeding, success check and rows",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress line")
    p.set_defaults(run=run_eval_cmd)


def parse_max_steps(values: list[str]) -> tuple[int | None, dict]:

    override, per_suite = None, dict(MAX_STEPS)
    for value in values:
        suite, _, n = value.rpartition("=")
        if not n.isdigit() or int(n) < 1:
            raise VProError(f"--max-steps {value!r}: expected a positive integer or SUITE=N")
        if suite:
            if suite not in MAX_STEPS:
                raise VProError(f"--max-steps {value!r}: unknown suite {suite!r} ({', '.join(MAX_STEPS)})")
            per_suite[suite] = int(n)
        else:
            override = int(n)
    return override, per_suite


def episode_outcome(row: dict) -> list[str]:
    """What one result row adds to the progress tally."""
    status = row.get("status")
    if status == "ok":
        return ["ok", "success"] if row.get("success") else ["ok"]
    return ["unavailable"] if status == "unavailable" else ["error"]


def outcome_summary(tally: Counter) -> str:
    """The progress bar's postfix: success so far, errors and unavailable episodes."""
    text = f"success {100 * tally['success'] / tally['ok']:.1f}% of {tally['ok']}" if tally["ok"] else "success -"
    text += f", {tally['error']} error(s)" if tally["error"] else ""
    return text + (f", {tally['unavailable']} unavailable" if tally["unavailable"] else "")


def episode_settings(args) -> EpisodeSettings:
    override, per_suite = parse_max_steps(args.max_steps)
    return EpisodeSettings(
        resolution=args.resolution,
        wait_steps=args.wait_steps,
        max_steps=per_suite,
        max_steps_override=override,
        video_dir=str(args.video) if args.video else None,
        render=not args.no_render,
    )


class EpisodeProgress:
    """The progress bar of a run, made once the runner knows how many episodes are left."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.bar: tqdm | None = None
        self.tally: Counter = Counter()

    def plan(self, todo: int, skipped: int) -> None:
        self.bar = tqdm(
            total=todo + skipped,
            initial=skipped,
            desc="vpro eval",
            unit="episode",
            disable=not self.enabled,
            dynamic_ncols=True,
        )
        if skipped:
            tqdm.write(f"vpro eval: {skipped} episode(s) already recorded, {todo} to run", file=sys.stderr)

    def row(self, row: dict) -> None:
        self.tally.update(episode_outcome(row))
        if self.bar is not None:
            self.bar.set_postfix_str(outcome_summary(self.tally), refresh=False)
            self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_eval_cmd(args) -> int:
    if args.workers < 1:
        raise VProError(f"--workers must be at least 1, got {args.workers}")
    if args.retries < 0:
        raise VProError(f"--retries must be 0 or more, got {args.retries}")
    settings = episode_settings(args)
    catalog = load_catalog(paths.catalog_path())
    cases = select_cases(catalog, args.select)
    if not cases:
        raise VProError("the selection is empty")
    options = {
        "replan_steps": args.replan_steps,
        "connect_timeout": args.connect_timeout,
        "infer_timeout": args.infer_timeout,
        "policy_id": args.policy_id,
    }
    options = {k: v for k, v in options.items() if v is not None}
    print(
        f"vpro eval: {describe(cases)} x {args.trials} trial(s), policy {args.policy}, backend {args.backend} "
        f"({args.workers} worker(s)) -> {args.results}",
        file=sys.stderr,
    )
    progress = EpisodeProgress(enabled=not args.no_progress)
    summary = run_eval(
        cases,
        results=args.results,
        policy_spec=args.policy,
        policy_options=options,
        settings=settings,
        trials=args.trials,
        run_id=args.run_id,
        resume=args.resume,
        retry_errors=args.retry_errors,
        backend=args.backend,
        workers=args.workers,
        address=args.address,
        retries=args.retries,
        retry_delay=args.retry_delay,
        selection=args.select,
        on_plan=progress.plan,
        on_row=progress.row,
    )
    progress.close()
    counts = ", ".join(f"{n} {k}" for k, n in sorted(summary.counts.items())) or "no rows"
    print(
        f"vpro eval: run {summary.run_id}: {summary.recorded} episode(s) recorded in {summary.elapsed:.0f} s; "
        f"rows: {counts}",
        file=sys.stderr,
    )
    return 0
