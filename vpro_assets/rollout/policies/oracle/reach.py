"""The arm's reach: how far the wrist may go from the shoulder before the elbow straightens.

LIBERO's arm (the Panda) has its shoulder at its 2nd hinge, its elbow at the 4th and its wrist at
the 6th; the upper arm and the forearm are rigid between their anchors, so the shoulder-to-wrist
distance is at most the two lengths end to end (0.719 m), reached with the elbow straight (the
Panda's joint 4 at -0.47 rad). Its limit (-0.07) lies 0.4 rad past straight: a hand driven as far
as the arm reaches passes through straight and the elbow bends the wrong way, where the
shoulder-to-wrist distance falls again to 0.705 m at the limit. There the OSC, which moves the hand
and not the elbow, brings the hand no nearer the shoulder: the elbow would have to pass through
straight again (libero_10-03 familiar_position: the bowl carried 0.31 m over the table 0.73-0.80
m out, the hand then stayed 2.7 cm short of where it turns to close the drawer for 100 steps of
full action). So the oracle keeps the wrist MARGIN_M short of that: a carry's goals move toward
the shoulder (`within`), and a pick's way out to a far grasp is no higher than the arm reaches
there (`lowered`; it kept the start's height). A pinch far out can still need the whole length
(the bowl's near wall 0.795 m out on the table: 0.717 m), and coming down to it the elbow went
past straight in most trials: before a carry such an elbow is brought back (`unbend`), the hand
driven out and up until the arm is straight, where the OSC's posture term (toward the starting
joints) bends the elbow back its own way.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.motion import Actions
from vpro_assets.rollout.policies.oracle.world import World

MARGIN_M = 0.02  # a carry's wrist stays this much short of the arm's full length
# Unbending: the hand's goal this far out along the line from the shoulder and up (driven out
# level, the straightened arm sagged 9 cm and set its bowl down), at most UNBEND_STEPS.
UNBEND_OUT_M, UNBEND_UP_M, UNBEND_STEPS = 0.05, 0.05, 40


def _anchors(world: World) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World anchors of the shoulder, the elbow and the wrist."""
    joints = world.arm_joints
    return world.d.xanchor[joints[1]].copy(), world.d.xanchor[joints[3]].copy(), world.d.xanchor[joints[5]].copy()


def full_length(world: World) -> float:
    """The shoulder-to-wrist distance with the elbow straight: the two links end to end."""
    shoulder, elbow, wrist = _anchors(world)
    return float(np.linalg.norm(elbow - shoulder) + np.linalg.norm(wrist - elbow))


def stretch(world: World, goal: np.ndarray | None = None) -> float:
    """The shoulder-to-wrist distance with the grip site at `goal` (now where it is) and the hand as
    it is turned now."""
    shoulder, _, wrist = _anchors(world)
    shift = np.zeros(3) if goal is None else np.asarray(goal, dtype=float) - world.eef()
    return float(np.linalg.norm(wrist + shift - shoulder))


def within(world: World, goal, margin: float = MARGIN_M) -> np.ndarray:
    """`goal` for the grip site moved horizontally toward the shoulder until the wrist is `margin`
    short of the arm's full length (the hand turned as now); as it is when it already is, or when
    no such move brings it there (too high or too low)."""
    goal = np.asarray(goal, dtype=float)
    shoulder, _, wrist = _anchors(world)
    toward = np.append(shoulder[:2] - (wrist + goal - world.eef())[:2], 0.0)  # the wrist to over the shoulder
    span = float(np.linalg.norm(toward))
    moved = _moved(world, goal, toward / span, span, margin) if span else None
    return goal if moved is None else moved


def lowered(world: World, goal, floor: float, margin: float = MARGIN_M) -> np.ndarray:
    """`goal` for the grip site lowered, no lower than `floor`, until the wrist is `margin` short of
    the arm's full length (as `within`); at `floor` when even there it is not."""
    goal = np.asarray(goal, dtype=float)
    down = np.array([0.0, 0.0, -1.0])
    most = max(float(goal[2]) - floor, 0.0)
    moved = _moved(world, goal, down, most, margin)
    return goal + down * most if moved is None else moved


def _moved(world: World, goal: np.ndarray, direction: np.ndarray, most: float, margin: float) -> np.ndarray | None:
    """`goal` moved along `direction` by the least distance, at most `most`, that brings the wrist
    `margin` short of the arm's full length (as it is when it already is); None when none does."""
    limit = full_length(world) - margin

    def excess(s: float) -> float:
        return stretch(world, goal + direction * s) - limit

    if excess(0.0) <= 0:
        return goal
    if most <= 0 or excess(most) > 0:
        return None
    return goal + direction * brentq(excess, 0.0, most, xtol=1e-4)


def _bend(world: World) -> float:
    """The elbow joint's angle from straight (rad, in the joint's sense)."""
    shoulder, elbow, wrist = _anchors(world)
    upper, fore = elbow - shoulder, wrist - elbow
    axis = world.d.xaxis[world.arm_joints[3]]
    return float(np.arctan2(axis @ np.cross(upper, fore), upper @ fore))


def past_straight(world: World) -> float:
    """How far (rad) the elbow is bent the wrong way: past straight toward the nearer end of its
    range (the bent side is the larger part of the range); 0 or less when bent its own way."""
    joints = world.arm_joints
    bend = _bend(world)
    straight = world.qpos(joints[3]) - bend
    lo, hi = (float(x) for x in world.m.jnt_range[joints[3]])
    return bend if straight - lo > hi - straight else -bend


def wrong_way_shortest(world: World) -> float:
    """The shoulder-to-wrist distance with the elbow bent the wrong way as far as its range goes
    (the Panda's: 0.705 m at its limit, 0.4 rad past straight): no nearer can such an elbow bring
    the wrist."""
    joints = world.arm_joints
    shoulder, elbow, wrist = _anchors(world)
    a, b = float(np.linalg.norm(elbow - shoulder)), float(np.linalg.norm(wrist - elbow))
    straight = world.qpos(joints[3]) - _bend(world)
    lo, hi = (float(x) for x in world.m.jnt_range[joints[3]])
    past = min(straight - lo, hi - straight)  # to the nearer end: the wrong side's
    return float(np.sqrt(a * a + b * b + 2 * a * b * np.cos(past)))


def unbend(world: World, grip: float, orient: np.ndarray | None = None) -> Actions:
    """Bring an elbow bent the wrong way (`past_straight`) back its own way: the hand driven out
    along the line from the shoulder and up, the arm straightening again, until the elbow is bent
    its own way (at most UNBEND_STEPS). Nothing when it already is."""
    for _ in range(UNBEND_STEPS):
        if past_straight(world) <= 0:
            return
        shoulder, _, _ = _anchors(world)
        out = np.append(world.eef()[:2] - shoulder[:2], 0.0)
        goal = world.eef() + out / np.linalg.norm(out) * UNBEND_OUT_M + [0.0, 0.0, UNBEND_UP_M]
        yield motion.action_to(world, goal, grip, orient)
