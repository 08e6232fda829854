"""Getting a grasped object out from under things before lifting it.

An object may stand under an overhang: under an opened drawer (libero_goal's bowl after the top
drawer opens over it) or in a drawer under the cabinet's top (libero_spatial-04). Lifting it
straight up knocks it out of the fingers. So the lift goes up as far as the lowest overhang over
the object's footprint allows, slides sideways to the nearest spot with nothing overhead (and
nothing in the way at that height), and only then rises. Obstacles are the world boxes of the
other objects' and fixtures' collision geoms.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.core.mjgeom import geom_corners
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.motion import CLOSE, Actions
from vpro_assets.rollout.policies.oracle.world import World

MARGIN_M = 0.01
SLIDE_STEP_M = 0.02
SLIDE_MAX_M = 0.20
DIRECTIONS = 16


def obstacle_boxes(world: World, exclude: tuple[str, ...]) -> np.ndarray:
    """(N, 2, 3) world boxes (lo, hi) of the obstacles' collision geoms."""
    boxes = []
    for g in world.obstacle_geoms(exclude):
        pts = geom_corners(world.m, world.d, [g])
        boxes.append((pts.min(0), pts.max(0)))
    return np.array(boxes).reshape(-1, 2, 3)


def _overlap_xy(boxes: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.all(boxes[:, 0, :2] < hi[:2] + MARGIN_M, axis=1) & np.all(boxes[:, 1, :2] > lo[:2] - MARGIN_M, axis=1)


def overhead(boxes: np.ndarray, lo: np.ndarray, hi: np.ndarray, up_to: float) -> float | None:
    """Lowest bottom of an obstacle over the footprint [lo, hi] between its top and `up_to`."""
    over = _overlap_xy(boxes, lo, hi) & (boxes[:, 0, 2] > hi[2] - 0.005) & (boxes[:, 0, 2] < up_to)
    return float(boxes[over, 0, 2].min()) if over.any() else None


def _blocked(boxes: np.ndarray, lo: np.ndarray, hi: np.ndarray, up_to: float) -> bool:
    """Anything in the footprint between the object's bottom and `up_to`."""
    hit = _overlap_xy(boxes, lo, hi) & (boxes[:, 1, 2] > lo[2] + 0.005) & (boxes[:, 0, 2] < up_to)
    return bool(hit.any())


def lift_clear(world: World, held: str, up_to: float) -> Actions:
    """Raise the held object until its bottom is at `up_to` - its height, sliding out from under any
    overhang first."""
    boxes = obstacle_boxes(world, (held,))
    box = world.box(held)
    roof = overhead(boxes, box.lo, box.hi, up_to)
    orient = world.eef_mat()
    if roof is not None:
        rise = max(0.0, roof - MARGIN_M - box.hi[2])
        yield from motion.move_to(world, world.eef() + [0, 0, rise], CLOSE, orient, tol=0.01, max_steps=40, speed=0.4)
        box = world.box(held)
        shift = _escape(boxes, box.lo, box.hi, up_to)
        if shift is not None:
            yield from motion.move_to(world, world.eef() + shift, CLOSE, orient, tol=0.01, max_steps=80, speed=0.4)


def _escape(boxes: np.ndarray, lo: np.ndarray, hi: np.ndarray, up_to: float) -> np.ndarray | None:
    """The shortest horizontal shift after which nothing is over or beside the object up to `up_to`."""
    height = hi[2] - lo[2]
    for dist in np.arange(SLIDE_STEP_M, SLIDE_MAX_M + 1e-9, SLIDE_STEP_M):
        for k in range(DIRECTIONS):
            ang = 2 * np.pi * k / DIRECTIONS
            shift = np.array([np.cos(ang), np.sin(ang), 0.0]) * dist
            if not _blocked(boxes, lo + shift, hi + shift, up_to + height):
                return shift
    return None
