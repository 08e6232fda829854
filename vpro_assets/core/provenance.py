"""Which toolkit code produced a result: the git commit of the checkout the toolkit runs from, with
"+dirty" where its tracked sources (`vpro_assets/`) differ from that commit. Recorded with every
episode (`rollout.store`), so a certificate's trials can be replayed with the oracle that solved
them; None where the toolkit does not run from a git checkout (an installed wheel) or git is missing."""

from __future__ import annotations

import functools
import subprocess

from vpro_assets.core import paths

ROOT = paths.REPO_ROOT
GIT_TIMEOUT_S = 10.0


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=GIT_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.TimeoutExpired):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


@functools.cache
def code_version() -> str | None:
    """Once per process: a worker runs the code it imported when it started."""
    head = _git("rev-parse", "HEAD")
    if not head:
        return None
    changed = _git("status", "--porcelain", "--untracked-files=no", "--", "vpro_assets")
    return head + ("+dirty" if changed else "")
