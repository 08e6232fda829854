"""Child processes that die with their parent.

A process killed by a signal (`pkill` on a build worker's command line, the kernel's OOM killer)
runs none of its cleanup, so its children are reparented and carry on: a rollout worker simulating
into the void, a build worker's child still running coacd for an object nobody will read. On
Linux the child asks the kernel to kill it when its parent dies (`PR_SET_PDEATHSIG`).

Through ctypes because neither Python's standard library (`os` has no prctl) nor a package of this
environment binds prctl (psutil does not); it is a single libc call with two integer arguments.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any, TypeVar

PR_SET_PDEATHSIG = 1  # from <sys/prctl.h>

T = TypeVar("T")


def die_with_parent(parent_pid: int) -> None:
    """Have the kernel SIGKILL this process when `parent_pid`, its parent, dies; exit at once if
    it died before this call (the kernel only signals a death that comes after the request).
    Elsewhere than Linux nothing: a child there outlives a killed parent.

    The kernel's "parent" is the thread that started the child: a child started by a thread that
    ends before its process is killed then (`call_in_child`'s is started by its caller's thread,
    which waits for the result)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)  # the libc this interpreter runs on
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent_pid:
        os.kill(os.getpid(), signal.SIGKILL)


def call_in_child(fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """`fn(*args, **kwargs)` in a spawned child process that dies with this one; its result.
    Spawned, not forked: a fork would copy this process's MuJoCo models and threads."""
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(
        max_workers=1, mp_context=context, initializer=die_with_parent, initargs=(os.getpid(),)
    ) as child:
        return child.submit(fn, *args, **kwargs).result()
