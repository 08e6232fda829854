"""Turning a held object back to the tilt it was taken at, before it is set down (`pick_place`).

A pinch of a narrow part off the object's middle (a moka pot's handle) is a pivot: the object turns
in the fingers about their axis when the carry starts and stays turned, held by friction.
libero_10-08's deformed moka pot (multipeak-s1) hung 1 degree off upright when lifted and 31
degrees once the carry set off sideways; set down so, it landed on its edge, toppled as it was let
go and rolled off the stove (5 of 10 trials). Over the destination the hand turns, about the grip
site, by the smallest rotation that brings the object's up axis (the direction that was up when it
was taken) back to vertical; the object turns with it and is set down standing.

How far it may hang off before it is turned back depends on how easily it topples: half the tilt
at which its box, standing on its narrower side, would tip over (`max_tilt`). multipeak-s2's first
pot (its box tips at 21 degrees: it may hang 10.7) hung 12-13 degrees off upright, under the 15
degrees then asked of every object; let go 1.8 cm over the burner, it landed on its edge and
toppled off the stove (4 of 10 trials). A bowl is let go as it hangs: libero_spatial-04's, pinched
at its wall and hanging 17 degrees off over the plate, settles flat; turning it back, as the fixed
15 degrees did, cost 40 steps of a pick-and-place that has about 150 (trial 3).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.motion import Actions
from vpro_assets.rollout.policies.oracle.world import World

TOPPLE_SHARE = 0.5  # of the tilt at which the object's box tips over on its narrower side
# The turn ends once it settles short of motion.TURN_TOL (it shrank less than TURN_STALL_RAD in so
# many steps): libero_spatial-04's deformed bowl (multipeak-s1), its arm's elbow at its limit, came to
# 3.4 degrees in 25 steps and swayed there until TURN_STEPS ran out.
TURN_STEPS, TURN_STALL_STEPS = 40, 5


def correction(world: World, held: str, taken: np.ndarray) -> Rotation:
    """The smallest world rotation that brings the object's up axis, as it stood when taken (its
    orientation `taken`), back to vertical."""
    return to_vertical(world.body_mat(held) @ (taken.T @ [0.0, 0.0, 1.0]))


def to_vertical(up: np.ndarray) -> Rotation:
    """The smallest world rotation that turns the direction `up` to the vertical."""
    turn, _ = Rotation.align_vectors([[0.0, 0.0, 1.0]], [up])
    return turn


def max_tilt(size: np.ndarray) -> float:
    """How far an object whose box (as it stood when taken) has `size` may hang off upright and
    still be set down as it hangs: TOPPLE_SHARE of the tilt at which the box, standing on its
    narrower side, tips over."""
    return TOPPLE_SHARE * float(np.arctan2(min(size[0], size[1]) / 2, size[2]))


def upright(world: World, held: str, taken: np.ndarray, limit: float) -> Actions:
    """Turn the hand where it is until the held object stands as it was taken (`taken`: its
    orientation then), when it has tilted more than `limit` (`max_tilt`) in the fingers; as near
    as the turn comes before it stalls (TURN_STALL_STEPS)."""
    turn = correction(world, held, taken)
    if turn.magnitude() < limit:
        return
    yield from motion.turn_in_place(world, turn.as_matrix() @ world.eef_mat(), TURN_STEPS, stall_steps=TURN_STALL_STEPS)
