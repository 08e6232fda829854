"""MuJoCo's asset cache bounded for a block (`vpro_assets.core.mjcache`)."""

from __future__ import annotations

import mujoco

from vpro_assets.core import mjcache
from vpro_assets.libero import bridge as libero_bridge


def test_capacity_bounds_the_cache_inside_the_block_and_restores_it():
    """A textured LIBERO object compiled inside `capacity(SMALLEST)` leaves at most that much in
    the cache (what the distractor pool's measurement relies on), and the capacity comes back."""
    before = mujoco.mj_getCacheCapacity(mujoco.mj_getCache())
    path = libero_bridge.libero_envs().OBJECTS_DICT["akita_black_bowl"](name="probe").file
    with mjcache.capacity(mjcache.SMALLEST):
        mujoco.MjModel.from_xml_path(path)
        assert mjcache.size() <= mjcache.SMALLEST
    assert mujoco.mj_getCacheCapacity(mujoco.mj_getCache()) == before
