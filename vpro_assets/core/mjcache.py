"""MuJoCo's asset cache: the meshes and textures its compiles decoded, kept process-wide (500 MB
by default) so that compiling the same files again skips decoding them.

Worth its memory where the same files are compiled again soon (a scene's variant env after its
base scene: about 0.2 s against 1.6-3.6 s cold), not for files compiled once (the distractor pool's
26 objects with their textures filled all 500 MB). `capacity` bounds it for a block; both start
from an empty cache.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import mujoco

SMALLEST = 1 << 20  # bytes: MuJoCo 3.3.7 crashes with a capacity of 0


def set_capacity(nbytes: int) -> int:
    """Empty the cache and bound it at `nbytes`; returns the capacity before. Emptied first:
    MuJoCo 3.3.7's mj_setCacheCapacity once looped forever in mjCCache::Delete, shrinking a cache
    that a test session had filled. A MuJoCo without the cache (before 3.3) has nothing to bound."""
    if not hasattr(mujoco, "mj_getCache"):
        return 0
    cache = mujoco.mj_getCache()
    before = int(mujoco.mj_getCacheCapacity(cache))
    mujoco.mj_clearCache(cache)
    mujoco.mj_setCacheCapacity(cache, max(int(nbytes), SMALLEST))
    return before


@contextlib.contextmanager
def capacity(nbytes: int) -> Iterator[None]:
    """The cache bounded at `nbytes` inside the block, its capacity before restored after it."""
    before = set_capacity(nbytes)
    try:
        yield
    finally:
        if before:
            set_capacity(before)


def size() -> int:
    """Bytes the cache holds now."""
    return int(mujoco.mj_getCacheSize(mujoco.mj_getCache())) if hasattr(mujoco, "mj_getCache") else 0
