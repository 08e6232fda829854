"""A child started by `call_in_child` dies with its parent (the build worker's deformed-object
generation, `generate_deformed_object(..., isolate=True)`), however the parent is killed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from vpro_assets.core.lifetime import call_in_child
from vpro_assets.core.paths import REPO_ROOT

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")

# The parent: a script, so that the spawned child can import `work` from it (spawn re-imports the
# parent's main module); `work` says it runs, then works far longer than the test waits.
PARENT = textwrap.dedent(
    """
    import os, sys, time
    from pathlib import Path

    from vpro_assets.core.lifetime import call_in_child


    def work(ready):
        Path(ready).write_text(str(os.getpid()))
        time.sleep(600)


    if __name__ == "__main__":
        call_in_child(work, sys.argv[1])
    """
)


def _alive(pid: int) -> bool:
    """Running (a zombie waiting for its reaper counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _wait(condition, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return condition()


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])  # SIGTERM: what pkill sends
def test_the_child_dies_when_its_parent_is_killed(tmp_path, sig):
    script, ready = tmp_path / "parent.py", tmp_path / "child.pid"
    script.write_text(PARENT)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])}
    parent = subprocess.Popen([sys.executable, str(script), str(ready)], env=env)
    child = None
    try:
        assert _wait(lambda: ready.is_file() and ready.read_text(), 120), "the child never started its work"
        child = int(ready.read_text())
        assert _alive(child) and child != parent.pid
        parent.send_signal(sig)
        parent.wait(timeout=30)
        assert _wait(lambda: not _alive(child), 30), f"child {child} still runs after its parent was killed"
    finally:
        if parent.poll() is None:
            parent.kill()
        if child is not None and _alive(child):
            os.kill(child, signal.SIGKILL)


def test_call_in_child_returns_the_result_of_another_process():
    assert call_in_child(os.getpid) != os.getpid()
