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

An object held off its middle (libero_10-08's inverted moka pot, by its handle) tipped out along
that line hangs over the grip and is still too tall (SkillFailed, 10 of 10 trials); it is
tipped toward the grip instead (`toward_grip`), hanging under it, and the hand first rises so the
tipping object clears the surface (`clear_tip`: tipped at the carry's height, the pot struck the
stove and slipped out of the fingers). Laid so, its body ends at z 0.977, 3 cm under the limit
(1.0075; standing on its lid, 1.016).

A region on a slope (`spot`) has its box tilted with it: libero_goal-09's wine rack shelf rises 31
degrees toward the back from a 1.4 cm lip, and its region's box (in LIBERO's `mat @ (p - site)`)
reaches 0-10 cm up the shelf from the lip and 2.2 cm either side of a plane 0.5 cm over the shelf.
The inverted bottle is laid there along the shelf's contour line, centred in that box: it rolls
down against the lip, its base's centre a radius (2.2 cm) over the shelf, inside the box.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.objects.deformed import UP_AXES
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.grasp import ROBOT_BASE_XY, grasp_orientation
from vpro_assets.rollout.policies.oracle.motion import Actions
from vpro_assets.rollout.policies.oracle.world import World

LIBERO_ON_HEIGHT_M = 0.10  # `SiteObject.under`'s other_height: the body at most this over the region's top
# The hand points this far below the horizontal when it lets go, so the object's far end touches
# first: level, the hand (6.6 cm across) reached 3.3 cm under the grip site, below the 2.2 cm bottle.
LAY_TILT_RAD = np.radians(20.0)
# A region whose LIBERO box rises less steeply than this (the cosine of its "up" axis with the
# vertical) is a slope: libero_goal-09's wine rack shelf, its box's up axis 62 degrees from vertical.
LEVEL_COS = 0.9
TURN_STEPS = 60
AIM_TOL_M, AIM_STEPS = 0.01, 40
CLEAR_TIP_M = 0.02  # the tipped object's lowest point this far over the surface before it tips
# An object whose up axis (as LIBERO stands it) is farther than this from vertical lies on its side.
LYING_COS = np.cos(np.radians(45.0))


def rise(world: World, held: str) -> float:
    """How high an object's body position stands over its lowest point, as it stands (or is held)."""
    return float(world.body_pos(held)[2] - world.points(held)[:, 2].min())


def up_axis(world: World, instance: str) -> np.ndarray | None:
    """The world direction of `instance`'s up axis as LIBERO stands it (`UP_AXES`, in its body's
    frame); None for an object of no measured up axis."""
    up = UP_AXES.get(dict(world.task.objects).get(instance, ""))
    if up is None:
        return None
    return world.body_mat(instance)[:, "xyz".index(up[1])] * (1.0 if up[0] == "+" else -1.0)


def lying(world: World, instance: str) -> bool:
    """Whether `instance` lies on its side: its up axis as LIBERO stands it (`UP_AXES`, in its
    body's frame) more than 45 degrees from the vertical. An object of no measured up axis: no."""
    axis = up_axis(world, instance)
    return axis is not None and bool(axis[2] < LYING_COS)


def sloped(world: World, region: str) -> bool:
    """Whether `region`'s LIBERO box is tilted with a slope (`LEVEL_COS`)."""
    return abs(world.site_mat(region)[2, 2]) < LEVEL_COS


def spot(world: World, region: str, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(where the laid object's extent is centred, the level direction it lies along) on `region`,
    `xy` its destination. A level region: `xy`, along the line from the arm's base. A slope (the
    wine rack's shelf, `LEVEL_COS`): the middle of LIBERO's box (`SiteObject.under` tests
    `mat @ (p - site)` against it), up the slope from its lip, and along the slope's contour line,
    pointing away from the arm: across the line from the base, the bottle set down at the lip
    (libero_goal-09's region) had one end off the shelf's front and fell to the table."""
    out = np.append(xy - ROBOT_BASE_XY, 0.0)
    if not sloped(world, region):
        return xy, out / np.linalg.norm(out)
    up = world.site_mat(region)[2]  # LIBERO's "up" of the box, in the world
    middle = world.site_mat(region).T @ [0.0, 0.0, world.site_size(region)[2] + LIBERO_ON_HEIGHT_M / 2]
    level = np.array([-up[1], up[0], 0.0]) / np.linalg.norm(up[:2])
    return (world.site_pos(region) + middle)[:2], level * np.sign(level @ out)


def toward_grip(world: World, held: str) -> np.ndarray:
    """The level direction from the held object's body position to the grip site."""
    d = np.append((world.eef() - world.body_pos(held))[:2], 0.0)
    return d / np.linalg.norm(d)


def orientations(world: World, along: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the hand pointing down, its fingers closing across `along` (a level unit vector); that hand
    tipped forward about the fingers' axis to point out along `along`, LAY_TILT_RAD below the
    horizontal)."""
    out = along
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


def clear_tip(world: World, held: str, tipped: np.ndarray, surface_z: float) -> Actions:
    """Rise, where the object tipped would reach below CLEAR_TIP_M over the surface."""
    pts, _ = turned(world, held, tipped)
    low = world.eef()[2] + float(pts[:, 2].min())
    if low < surface_z + CLEAR_TIP_M:
        goal = world.eef() + [0.0, 0.0, surface_z + CLEAR_TIP_M - low]
        yield from motion.move_to(world, goal, world.hold_grip, world.eef_mat(), tol=0.01, max_steps=40, speed=0.6)


def tip(world: World, tipped: np.ndarray) -> Actions:
    """Turn the hand to `tipped` where it is."""
    yield from motion.turn_in_place(world, tipped, TURN_STEPS)


def centre_over(world: World, held: str, xy: np.ndarray) -> Actions:
    """Move the hand level until the held object's extent is centred over `xy`."""
    orient = world.eef_mat()
    for _ in range(AIM_STEPS):
        pts = world.points(held)
        off = xy - (pts.min(0) + pts.max(0))[:2] / 2
        if np.linalg.norm(off) < AIM_TOL_M:
            return
        yield motion.action_to(world, world.eef() + np.append(off, 0.0), world.hold_grip, orient, speed=0.6)
