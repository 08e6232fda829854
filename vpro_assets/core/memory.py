"""The resident memory of this process: what a build worker and the child it generates an object
in report (`vpro build` prints the largest of each)."""

from __future__ import annotations

import resource
import sys
from pathlib import Path

_STATUS = Path("/proc/self/status")


def peak_rss_mb() -> float:
    """The largest resident memory of this process so far (MB). On Linux the kernel's VmHWM, which
    starts again at exec: a spawned child's own peak, where getrusage would keep the resident size
    of the process it was forked from before the exec."""
    if _STATUS.is_file():
        for line in _STATUS.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 2**10
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS
    return peak / (2**20 if sys.platform == "darwin" else 2**10)
