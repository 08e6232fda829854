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

from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.motion import Actions
from vpro_assets.rollout.policies.oracle.world import World

MARGIN_M = 0.01
SLIDE_STEP_M = 0.01
SLIDE_MAX_M = 0.20
DIRECTIONS = 16
PIECE_M = 0.02
BESIDE_M = 0.003  # sliding out from under an overhang, the object passes this close to walls


def obstacle_pieces(world: World, exclude: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2, 3) world boxes (lo, hi) of the obstacles' collision geoms, cut into pieces of at most
    PIECE_M so that rotated plates (a turned cabinet's walls and top) are not taken for blocks, and
    the geom of each box (N,)."""
    geoms = world.obstacle_geoms(exclude)
    boxes = [world.pieces(g, PIECE_M) for g in geoms]
    if not boxes:
        return np.zeros((0, 2, 3)), np.zeros(0, dtype=int)
    return np.concatenate(boxes), np.repeat(geoms, [len(b) for b in boxes])


def obstacle_boxes(world: World, exclude: tuple[str, ...]) -> np.ndarray:
    """The boxes of `obstacle_pieces`."""
    return obstacle_pieces(world, exclude)[0]


def object_boxes(world: World, instance: str) -> np.ndarray:
    """(M, 2, 3) world boxes of the pieces of an object's collision geoms: its footprint (a round
    bowl's, not the square around it)."""
    return np.concatenate([world.pieces(g, PIECE_M) for g in world.geoms(instance)])


def _overlap_xy(boxes: np.ndarray, own: np.ndarray, margin: float = MARGIN_M) -> np.ndarray:
    """Which obstacle boxes come within `margin` of any of the object's boxes `own`, in plan."""
    if not len(own):
        return np.zeros(len(boxes), dtype=bool)
    lo, hi = own[:, 0, :2] - margin, own[:, 1, :2] + margin
    # Only a box within the margin of the object's whole footprint can be within it of one of its
    # boxes: the pairs are compared for those few (the same comparisons of the same numbers).
    out = (boxes[:, 0, 0] < hi[:, 0].max()) & (boxes[:, 0, 1] < hi[:, 1].max())
    out &= (boxes[:, 1, 0] > lo[:, 0].min()) & (boxes[:, 1, 1] > lo[:, 1].min())
    near = boxes[out]
    out[out] = np.any(np.all(near[:, None, 0, :2] < hi, axis=2) & np.all(near[:, None, 1, :2] > lo, axis=2), axis=1)
    return out


def overhead(boxes: np.ndarray, own: np.ndarray, up_to: float) -> float | None:
    """Lowest bottom of an obstacle over the object (its boxes `own`) between its top and `up_to`."""
    top = own[:, 1, 2].max()
    over = (boxes[:, 0, 2] > top - 0.005) & (boxes[:, 0, 2] < up_to)
    over[over] = _overlap_xy(boxes[over], own)
    return float(boxes[over, 0, 2].min()) if over.any() else None


def _beside(boxes: np.ndarray, own: np.ndarray) -> bool:
    """Anything within BESIDE_M of the object's sides, between its bottom and its top (a drawer's
    walls around a bowl in it; not the floor it stands on nor the roof over it)."""
    hit = (boxes[:, 1, 2] > own[:, 0, 2].min() + 0.005) & (boxes[:, 0, 2] < own[:, 1, 2].max() - 0.005)
    return bool(hit.any() and _overlap_xy(boxes[hit], own, BESIDE_M).any())


def lift_clear(world: World, held: str, up_to: float) -> Actions:
    """Raise the held object until its bottom is at `up_to` - its height, sliding out from under any
    overhang first."""
    boxes = obstacle_boxes(world, (held,))
    own = object_boxes(world, held)
    roof = overhead(boxes, own, up_to)
    orient = world.eef_mat()
    if roof is not None:
        rise = max(0.0, roof - MARGIN_M - own[:, 1, 2].max())
        yield from motion.move_to(
            world, world.eef() + [0, 0, rise], world.hold_grip, orient, tol=0.01, max_steps=40, speed=0.4
        )
        shift = _escape(boxes, object_boxes(world, held), up_to)
        if shift is not None:
            yield from motion.move_to(
                world, world.eef() + shift, world.hold_grip, orient, tol=0.004, max_steps=80, speed=0.4
            )


def _escape(boxes: np.ndarray, own: np.ndarray, up_to: float) -> np.ndarray | None:
    """The shortest horizontal shift after which nothing is over the object up to `up_to`, along
    which it slides past nothing beside it."""
    for dist in np.arange(SLIDE_STEP_M, SLIDE_MAX_M + 1e-9, SLIDE_STEP_M):
        for k in range(DIRECTIONS):
            ang = 2 * np.pi * k / DIRECTIONS
            shift = np.array([np.cos(ang), np.sin(ang), 0.0]) * dist
            path = np.arange(SLIDE_STEP_M, dist + 1e-9, SLIDE_STEP_M) / dist
            if overhead(boxes, own + shift, up_to) is None and not any(_beside(boxes, own + shift * f) for f in path):
                return shift
    return None
