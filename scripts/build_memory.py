"""Resident memory of one build process around every stage of each case it builds.

Builds the given scene cases in this process, in the order given, as `vpro build -j 1` does (the
same asset-cache bound), and prints per stage (base scene, generate, bddl, variant env, settle) the
resident memory when it starts and ends and its own peak (Linux: VmHWM, reset at the start of
each stage through /proc/self/clear_refs), then what the known holders hold after each case: the
model cache, the base-scene cache and MuJoCo's asset cache. Resetting VmHWM also resets what
`resource.getrusage` reports, so the script prints the peak over all stages itself.

    VPRO_OUT=/tmp/mem .venv/bin/python scripts/build_memory.py \\
        libero_spatial-00/task_relevant_distractors/same_color-v1 \\
        libero_object-00/task_relevant_distractors/same_color-v1
"""

from __future__ import annotations  # noqa: I001 (vpro_assets before numpy: its import pins the kernels)

import argparse
import contextlib
import gc
import time
from pathlib import Path

import vpro_assets  # noqa: F401

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import mjcache, paths
from vpro_assets.libero import physics
from vpro_assets.scene import base_scene, build, stages


def status() -> dict[str, int]:
    """VmRSS and VmHWM of this process, MB."""
    out = {}
    for line in Path("/proc/self/status").read_text().splitlines():
        key, value = line.split(":", 1)
        if key in ("VmRSS", "VmHWM"):
            out[key] = int(value.split()[0]) // 1024
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("cases", nargs="+", help="scene case ids, built in this order")
    args = parser.parse_args()
    peak = [0]
    child_peak = [0.0]
    real_stage = stages.StageClock.stage

    @contextlib.contextmanager
    def stage(clock, name):
        before = status()
        peak[0] = max(peak[0], before["VmHWM"])
        Path("/proc/self/clear_refs").write_text("5")  # VmHWM back to VmRSS: this stage's own peak
        started = time.perf_counter()
        with real_stage(clock, name):
            yield
        after = status()
        peak[0] = max(peak[0], after["VmHWM"])
        print(
            f"    {name:12s} {time.perf_counter() - started:6.1f} s  RSS {before['VmRSS']:5d} -> "
            f"{after['VmRSS']:5d} MB, stage peak {after['VmHWM']:5d} MB",
            flush=True,
        )

    stages.StageClock.stage = stage  # type: ignore[method-assign]
    mjcache.set_capacity(build.ASSET_CACHE_BYTES)  # as `vpro build` does
    catalog = load_catalog(paths.catalog_path())
    for cid in args.cases:
        print(f"{cid} (RSS {status()['VmRSS']} MB)", flush=True)
        result = build.build_case(find_case(catalog, cid), force=True)
        child_peak[0] = max(child_peak[0], result.peak_child_rss_mb)
        gc.collect()
        models = sum(m.nbuffer for m in physics._MODELS.values()) >> 20
        print(
            f"  {result.status} {result.error}in {result.seconds:.1f} s; RSS {status()['VmRSS']} MB; model cache "
            f"{models} MB, base scenes kept {base_scene.base_scene.cache_info().currsize}, MuJoCo asset cache "
            f"{mjcache.size() >> 20} MB",
            flush=True,
        )
    print(f"peak over all stages: {max(peak[0], status()['VmHWM'])} MB")
    print(f"largest child process (a deformed object's generation): {child_peak[0]:.0f} MB")


if __name__ == "__main__":
    main()
