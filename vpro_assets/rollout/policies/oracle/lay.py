"""Laying a held object on its side onto a region it stands too tall for (`pick_place.lay_down`).

LIBERO's `On` of a region (`SiteObject.under`) wants the object's body position at most
LIBERO_ON_HEIGHT_M over the region's top. An object whose body position stands higher over its
bottom, as it stands before it is taken, cannot satisfy it standing: libero_goal-02's inverted wine bottle (its body
position is the bottle's base, 15.8 cm over the cap it stands on), set down on the cabinet, stood on
its cap with the goal unmet (9 of 10 trials; the tenth toppled as it was let go). It is laid down:
carried with the fingers closing across the line from the arm's base, then, over the region, the
hand tips forward about the fingers' axis to point out along that line, LAY_TILT_RAD below the
horizontal; the object's far end comes down first, and let go there it falls flat, its body position
a radius over the top.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.grasp import ROBOT_BASE_XY, grasp_orientation
from vpro_assets.rollout.policies.oracle.motion import Actions
from vpro_assets.rollout.policies.oracle.world import World

LIBERO_ON_HEIGHT_M = 0.10  # `SiteObject.under`'s other_height: the body at most this over the region's top
# The hand points this far below the horizontal when it lets go, so the object's far end touches
# first: level, the hand (6.6 cm across) reached 3.3 cm under the grip site, below the 2.2 cm bottle.
LAY_TILT_RAD = np.radians(20.0)
TURN_SPEED = 0.5  # of the action's full turn: turning at full speed draws the grip site off its place
TURN_TOL_RAD, TURN_STEPS = 0.05, 60
AIM_TOL_M, AIM_STEPS = 0.01, 40


def rise(world: World, held: str) -> float:
    """How high an object's body position stands over its lowest point, as it stands (or is held)."""
    return float(world.body_pos(held)[2] - world.points(held)[:, 2].min())


def orientations(world: World, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the hand pointing down, its fingers closing across the line from the arm's base to `xy`;
    that hand tipped forward about the fingers' axis to point out along the line, LAY_TILT_RAD below
    the horizontal)."""
    out = np.append(xy - ROBOT_BASE_XY, 0.0)
    out /= np.linalg.norm(out)
    down = grasp_orientation(world, np.cross(out, [0.0, 0.0, 1.0]))
    fingers = down[:, 0]
    approach = out * np.cos(LAY_TILT_RAD) - np.array([0.0, 0.0, np.sin(LAY_TILT_RAD)])
    return down, np.column_stack([fingers, np.cross(approach, fingers), approach])


def turned(world: World, held: str, orient: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the held object's points, its body position), relative to the grip site, once the hand
    turns from its orientation now to `orient` about the grip site."""
    turn = orient @ world.eef_mat().T
    grip = world.eef()
    return (world.points(held) - grip) @ turn.T, turn @ (world.body_pos(held) - grip)


def laid_rise(world: World, held: str, tipped: np.ndarray) -> float:
    """How high the body position will stand over the object's lowest point once tipped."""
    pts, body = turned(world, held, tipped)
    return float(body[2] - pts[:, 2].min())


def carry_target(world: World, held: str, xy: np.ndarray, down: np.ndarray, tipped: np.ndarray) -> np.ndarray:
    """Where the carry (`pick_place.carry`, the hand turned to `down`) brings the held object's body
    position so that, tipped there, the object's extent is centred over `xy`."""
    laid, _ = turned(world, held, tipped)
    _, body = turned(world, held, down)
    grip = xy - (laid.min(0) + laid.max(0))[:2] / 2
    return grip + body[:2]


def tip(world: World, tipped: np.ndarray) -> Actions:
    """Turn the hand to `tipped` where it is, at TURN_SPEED."""
    hold = world.eef()
    for _ in range(TURN_STEPS):
        if np.linalg.norm(motion.rotation_error(world.eef_mat(), tipped)) < TURN_TOL_RAD:
            return
        action = motion.action_to(world, hold, world.hold_grip, tipped)
        action[3:6] *= TURN_SPEED
        yield action


def centre_over(world: World, held: str, xy: np.ndarray) -> Actions:
    """Move the hand level until the held object's extent is centred over `xy`."""
    orient = world.eef_mat()
    for _ in range(AIM_STEPS):
        pts = world.points(held)
        off = xy - (pts.min(0) + pts.max(0))[:2] / 2
        if np.linalg.norm(off) < AIM_TOL_M:
            return
        yield motion.action_to(world, world.eef() + np.append(off, 0.0), world.hold_grip, orient, speed=0.6)
