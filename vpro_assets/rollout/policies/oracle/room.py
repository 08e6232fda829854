"""Where on a shared region a held object is set down (`pick_place.resolve`).

libero_10-08 puts both moka pots on the stove: LIBERO's `On` wants each pot's body position inside
the cook region's 15 x 15 cm box, and the pots stand on the stove's 19 x 19 cm plate. A pot lying
on its side (the precondition case's `-lying`) is 16.6 x 8.3 cm in plan; set down in the middle it
left 5-5.7 cm of plate either side, less than the 8.1 cm of the upright second pot, which then
went down at the plate's corner, half off it, and fell to the table (7 of 10 trials). So:
- while other objects are still to go onto the same region (`coming`), the held one goes where the
  plate keeps the widest free strip beside it: against one side of the plate;
- where another object stands at the region's centre, the held one goes to the spot nearest the
  centre where its footprint stays on the plate and GAP_M clear of the objects already there.
Footprints are the objects' world boxes in plan; the plate is the box of the region owner's pieces
that stand level with the surface under the region's centre near the region's box.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.rollout.policies.oracle.clearance import object_boxes
from vpro_assets.rollout.policies.oracle.grasp import ROBOT_BASE_XY
from vpro_assets.rollout.policies.oracle.world import World

GAP_M = 0.01  # a footprint this far from the objects already on the region
EDGE_M = 0.005  # and this far inside the plate's edge
LEVEL_M = 0.003  # a piece of the owner this close to the surface's height is part of the plate
REACH_M = 0.03  # if it comes this close to the region's box (the stove's knobs stand 6 cm off it)
GRID_M = 0.01  # candidate body positions this far apart
INSIDE = 0.8  # candidates within this fraction of the region's half size (LIBERO's box, strictly inside)
TIE_M = 0.002  # strips this close are equally wide


def plate(world: World, owner: str, region: str, surface_z: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo, hi) in plan of the owner's pieces level with `surface_z` that come within REACH_M of
    the region's box; None when the owner has none (a region of the table)."""
    try:
        boxes = object_boxes(world, owner)
    except (KeyError, ValueError, VProError):  # a region of the table: its owner has no body of its own
        return None
    center, half = world.site_pos(region)[:2], world.region_half(region)[:2] + REACH_M
    level = np.abs(boxes[:, 1, 2] - surface_z) < LEVEL_M
    inside = np.all(boxes[:, 0, :2] < center + half, axis=1) & np.all(boxes[:, 1, :2] > center - half, axis=1)
    top = boxes[level & inside]
    if not len(top):
        return None
    return top[:, 0, :2].min(axis=0), top[:, 1, :2].max(axis=0)


def spot(
    world: World, region: str, held: str, owner: str, surface_z: float, others: list[str], coming: bool
) -> np.ndarray | None:
    """Where `held`'s body position goes on `region` (see the module's rules), or None when no
    candidate fits (the caller falls back to the nearest free point of the region)."""
    shelf = plate(world, owner, region, surface_z)
    if shelf is None:
        return None
    lo_s, hi_s = shelf[0] + EDGE_M, shelf[1] - EDGE_M
    box, body = world.box(held), world.body_pos(held)[:2]
    off_lo, off_hi = box.lo[:2] - body, box.hi[:2] - body
    center, half = world.site_pos(region)[:2], world.region_half(region)[:2] * INSIDE
    axes = [np.arange(-h, h + 1e-9, GRID_M) for h in half]
    cand = center + np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    f_lo, f_hi = cand + off_lo, cand + off_hi
    fits = np.all(f_lo >= lo_s, axis=1) & np.all(f_hi <= hi_s, axis=1)
    for other in others:
        o = world.box(other)
        apart = np.maximum(np.maximum(o.lo[:2] - f_hi, f_lo - o.hi[:2]), 0.0)
        fits &= np.linalg.norm(apart, axis=1) >= GAP_M
    if not fits.any():
        return None
    cand, f_lo, f_hi = cand[fits], f_lo[fits], f_hi[fits]
    near = np.linalg.norm(cand - center, axis=1)
    if not coming:
        return cand[int(np.argmin(near))]
    # The widest strip of plate left beside the footprint; of the widest, the nearest the centre,
    # then the farthest from the arm (the others then come down on the near side, not over it).
    strip = np.maximum(np.max(f_lo - lo_s, axis=1), np.max(hi_s - f_hi, axis=1))
    best = strip >= strip.max() - TIE_M
    far = np.linalg.norm(cand - ROBOT_BASE_XY, axis=1)
    order = np.lexsort((-far, np.round(near, 4), ~best))
    return cand[int(order[0])]
