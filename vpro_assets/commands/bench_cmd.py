"""`vpro bench`: measurements that write their own section of docs/benchmarks.md.

- `vpro bench perturb` (`bench_perturb`): step time of each observation setting against the clean env;
- `vpro bench build` (`bench_build`): the scene build and validation, robosuite's path against the
  render-free one, per stage, with the seconds MuJoCo needs in each.
"""

from __future__ import annotations

from vpro_assets.commands import bench_build, bench_perturb
from vpro_assets.commands.bench_doc import update_markdown_section  # noqa: F401 (re-exported)
from vpro_assets.commands.bench_perturb import observation_settings  # noqa: F401 (re-exported)
from vpro_assets.commands.bench_perturb_table import markdown_table  # noqa: F401 (re-exported)
from vpro_assets.commands.build_cmd import SELECT_HELP


def add_parser(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="measure the cost of the observation perturbations and of the scene build",
        description="Benchmarks. `vpro bench perturb` measures, for each observation-level setting, "
        "the step time of the perturbed env against the clean env in one interleaved run and "
        "writes the ratios to a JSON file and a table to docs/benchmarks.md. `vpro bench build` "
        "builds and validates scene cases on robosuite's path and on the render-free path side by "
        "side and reports seconds per stage, the MuJoCo seconds in each, and the peak memory.",
    )
    bsub = p.add_subparsers(dest="bench", metavar="BENCH", required=True)
    bench_perturb.add_parser(bsub)
    bench_build.add_parser(bsub, SELECT_HELP)
