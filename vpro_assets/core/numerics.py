"""numpy's floating-point kernels, pinned so that what the toolkit builds and simulates is the same
bytes on every x86-64 CPU with AVX2.

numpy picks kernels by the CPU when it loads: OpenBLAS (matrix products, solves: robosuite's OSC
controller, which settles every scene; numpy's and scipy's each) its `DYNAMIC_ARCH` core, and numpy its own SIMD loops
(AVX-512 ones where the CPU has them). The results differ in the last bits, and settling carries
them into the initial states: one scene case built on this machine under seven OpenBLAS cores gave
five different `.pruned_init` files (docs/simulator.md, "Numerics"). Pinning OpenBLAS to its Haswell
core (AVX2 + FMA: Intel since 2013, every AMD Zen) and leaving numpy's AVX-512 loops off gives one
answer; both are read from the environment when numpy loads, so `pin()` runs when `vpro_assets` is
imported, before anything imports numpy, and `check()` refuses to build when numpy was loaded
before that (or under another setting the user chose). On other architectures (aarch64: other
MuJoCo binaries, other OpenBLAS cores) nothing is pinned or checked: their bytes differ from an
x86-64 lock anyway.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

from vpro_assets.core.errors import VProError

OPENBLAS_CORE = "Haswell"
# numpy's names of the AVX-512 feature groups (an unknown or absent name is ignored by numpy).
NUMPY_DISABLED = "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR"
PINNED = {"OPENBLAS_CORETYPE": OPENBLAS_CORE, "NPY_DISABLE_CPU_FEATURES": NUMPY_DISABLED}
X86_64 = platform.machine().lower() in ("x86_64", "amd64")


def pin() -> None:
    """Set the pinned kernels for numpy loaded from now on (here and in child processes); a value the
    user set is kept (and `check` says where it differs)."""
    if not X86_64:
        return
    for key, value in PINNED.items():
        os.environ.setdefault(key, value)


def problems() -> list[str]:
    """How numpy's loaded kernels differ from the pinned ones (empty: they do not, or not x86-64)."""
    if not X86_64:
        return []
    import numpy as np
    from threadpoolctl import threadpool_info

    out = []
    for lib in threadpool_info():
        core = lib.get("architecture")
        if lib.get("internal_api") == "openblas" and core and core.lower() != OPENBLAS_CORE.lower():
            out.append(f"OpenBLAS ({Path(lib['filepath']).name}) runs its {core} core, not {OPENBLAS_CORE}")
    umath = (getattr(np, "_core", None) or np.core)._multiarray_umath  # numpy 2 renamed numpy.core
    # Only loops numpy has count: numpy 1.26 has no AVX512_SPR ones (it cannot disable that name and
    # says so), so on a Sapphire Rapids CPU the feature stays on without changing a result.
    dispatched = set(umath.__cpu_dispatch__)
    on = [f for f in NUMPY_DISABLED.split() if umath.__cpu_features__.get(f) and f in dispatched]
    if on:
        out.append(f"numpy runs its {'/'.join(on)} loops")
    return out


def check(what: str) -> None:
    """VProError when numpy's kernels are not the pinned ones: `what` would not be the lock's bytes."""
    found = problems()
    if found:
        env = " ".join(f"{k}='{v}'" for k, v in PINNED.items())
        raise VProError(
            f"{what}: {'; '.join(found)}, so the results would differ from the lock's in the last bits "
            f"(numpy was loaded before vpro_assets, or the environment sets other kernels); run it as {env} ..."
        )
