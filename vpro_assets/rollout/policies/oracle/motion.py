"""Motion primitives: 7-D OSC_POSE actions that drive the grip site to a pose, as generators.

A skill is a generator of actions: it yields one action per control step and reads the simulator
state again when it resumes, so every primitive is closed-loop. Position is a proportional law on
the grip site's error, clipped to the action box; orientation keeps the gripper pointing down and
turns it about the vertical to a commanded yaw (the error rotation through MuJoCo's
`mju_mat2Quat` / `mju_quat2Vel`). robosuite's OSC_POSE scales an action of 1 to 5 cm and 0.5 rad.
"""

from __future__ import annotations

from collections.abc import Generator, Iterator

import mujoco
import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, quat_matrix
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

Actions = Iterator[np.ndarray]
Posing = Generator[np.ndarray, None, np.ndarray]  # actions, then the orientation reached

OSC_MAX_STEP_M = 0.05  # OSC_POSE output_max for position
OSC_MAX_ROT = 0.5  # OSC_POSE output_max for rotation (rad)
GAIN = 2.0  # proportional gain on the position error, in units of OSC_MAX_STEP_M
ROT_GAIN = 1.0
OPEN, CLOSE = -1.0, 1.0
GRIPPER_STEPS = 12  # control steps for the fingers to close or open
TOL_M = 0.008
TURN_TOL = 0.05  # rad
WAY_TOL = 0.3  # rad: a way point of a turn (`turn_about`) is passed this close (on the move)
TURN_IN_PLACE_SPEED = 0.5  # of the action's full turn (`turn_in_place`)
STALL_M = 0.003  # a move has stalled when the grip site moved less than this in its stall steps
TURN_STALL_RAD = np.radians(1.0)  # a turn has stalled when what it still has to go shrank less than this
UP = np.array([0.0, 0.0, 1.0])
DOWN = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])  # grip site pointing down, fingers along world y


def yaw_of(mat: np.ndarray) -> float:
    """Heading of the gripper's x axis about the vertical (the gripper is pointing down)."""
    return float(np.arctan2(mat[1, 0], mat[0, 0]))


def down_with_yaw(yaw: float) -> np.ndarray:
    return quat_matrix(axis_angle_quat([0, 0, 1], yaw)) @ DOWN


def facing(approach, fingers, current: np.ndarray | None = None) -> np.ndarray:
    """Hand orientation pointing along `approach` with the fingers closing along `fingers`
    (perpendicular unit vectors); of the two finger signs, the one nearer `current`."""
    a = np.asarray(approach, dtype=float) / np.linalg.norm(approach)
    best, best_angle = None, np.inf
    for sign in (1.0, -1.0):
        f = sign * np.asarray(fingers, dtype=float) / np.linalg.norm(fingers)
        mat = np.column_stack([f, np.cross(a, f), a])
        angle = 0.0 if current is None else float(np.linalg.norm(rotation_error(current, mat)))
        if angle < best_angle:
            best, best_angle = mat, angle
    assert best is not None  # two candidates, one always kept
    return best


def rotation_error(current: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """Axis-angle (world frame) of the rotation taking `current` to `goal`."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, (goal @ current.T).flatten())
    vel = np.zeros(3)
    mujoco.mju_quat2Vel(vel, q, 1.0)
    return vel


def action_to(
    world: World, goal: np.ndarray, grip: float, orient: np.ndarray | None = None, speed: float = 1.0
) -> np.ndarray:
    """One action moving the grip site toward `goal` (and the hand toward `orient`)."""
    delta = np.clip((np.asarray(goal) - world.eef()) / OSC_MAX_STEP_M * GAIN, -speed, speed)
    rot = np.zeros(3)
    if orient is not None:
        rot = np.clip(rotation_error(world.eef_mat(), orient) / OSC_MAX_ROT * ROT_GAIN, -1.0, 1.0)
    return np.concatenate([delta, rot, [grip]])


def move_to(
    world: World,
    goal,
    grip: float,
    orient: np.ndarray | None = None,
    tol: float = TOL_M,
    max_steps: int = 120,
    speed: float = 1.0,
    strict: bool = False,
    stall_steps: int | None = None,
    turn_tol: float | None = TURN_TOL,
) -> Actions:
    """Drive the grip site to `goal` (within `tol`) and the hand to `orient` (within `turn_tol`
    rad; None: a way point, passed whatever the turn still to go); gives up after `max_steps`
    (SkillFailed when `strict`), or with `stall_steps`, once the grip site moved less than STALL_M
    in that many steps (the hand resting on something: a door's edge under the palm)."""
    goal = np.asarray(goal, dtype=float)
    trail: list[np.ndarray] = []
    for _ in range(max_steps):
        if np.linalg.norm(goal - world.eef()) < tol and (
            orient is None or turn_tol is None or np.linalg.norm(rotation_error(world.eef_mat(), orient)) < turn_tol
        ):
            return
        trail.append(world.eef())
        if stall_steps and len(trail) > stall_steps and np.linalg.norm(trail[-1] - trail[-1 - stall_steps]) < STALL_M:
            break
        yield action_to(world, goal, grip, orient, speed)
    if strict:
        raise SkillFailed(
            f"grip site did not reach {np.round(goal, 3).tolist()} (at {np.round(world.eef(), 3).tolist()})"
        )


def gripper(world: World, grip: float, steps: int = GRIPPER_STEPS, orient: np.ndarray | None = None) -> Actions:
    """Open or close the fingers in place."""
    hold = world.eef()
    for _ in range(steps):
        yield action_to(world, hold, grip, orient)


def turn_in_place(
    world: World,
    goal: np.ndarray,
    steps: int,
    at: np.ndarray | None = None,
    speed: float = 1.0,
    tol: float = TURN_TOL,
    stall_steps: int | None = None,
) -> Actions:
    """Turn the hand to `goal` holding what it holds, at TURN_IN_PLACE_SPEED of the action's full
    turn (at most `steps` actions): a held object turned faster draws the grip site off its place.
    The grip site stays where it is, or moves toward `at` at `speed` of the action's full move. With
    `stall_steps`, it gives up once the turn still to go shrank less than TURN_STALL_RAD in that
    many steps (it has settled short of `tol`)."""
    hold = world.eef() if at is None else at
    errors: list[float] = []
    for _ in range(steps):
        error = float(np.linalg.norm(rotation_error(world.eef_mat(), goal)))
        if error < tol:
            return
        errors.append(error)
        if stall_steps and len(errors) > stall_steps and errors[-1 - stall_steps] - error < TURN_STALL_RAD:
            return
        action = action_to(world, hold, world.hold_grip, goal, speed=speed)
        action[3:6] *= TURN_IN_PLACE_SPEED
        yield action


def wrist_yaw_room(world: World, yaw: float) -> float:
    """How far the wrist's last joint stays from its nearer limit after the hand, pointing down,
    turns `yaw` rad more about the vertical (negative: past it)."""
    per_rad = float(world.d.xaxis[world.wrist_joint][2])  # the wrist's turn per radian of yaw
    return world.wrist_room(yaw * per_rad)


def yaw_turns(world: World, axis: np.ndarray) -> list[float]:
    """The turns about the vertical that bring the hand, pointing down, to its fingers along `axis`
    or `-axis`: each the short way and a full turn either way round of it."""
    now = yaw_of(world.eef_mat())
    turns = []
    for fingers in (axis, -axis):
        turn = (float(np.arctan2(fingers[1], fingers[0])) - now + np.pi) % (2 * np.pi) - np.pi
        turns += [turn + k * 2 * np.pi for k in (-1, 0, 1)]
    return turns


def wrist_turn(world: World, angle: float) -> float:
    """Of turning the hand `angle` about the vertical or the other way round to the same heading,
    the one that keeps the wrist's last joint within its range (an inverted mug, taken by its
    handle on the opening's side, turns half a circle: the short way took libero_10-09's wrist
    from 2.24 rad into its 2.90 limit, and the hand stayed there with the mug's handle inward)."""
    other = angle - 2 * np.pi * np.sign(angle) if angle else angle
    return max((angle, other), key=lambda a: wrist_yaw_room(world, a))


def turn_about(
    world: World, axis, angle: float, at: np.ndarray | None = None, *, tol: float, max_steps: int
) -> Actions:
    """Turn the hand `angle` rad about `axis` (world frame) holding what it holds, the grip site
    held at (or moving toward) `at`, where it is when None: through way points at most a quarter
    turn apart (a half turn commanded at once goes the short way, whichever that is), each passed
    within WAY_TOL, the last reached within TURN_TOL; `tol` and `max_steps` are each move's
    (`move_to`)."""
    start = world.eef_mat()
    at = world.eef() if at is None else at
    pieces = max(1, int(np.ceil(abs(angle) / (np.pi / 2) - 1e-6)))
    for k in range(1, pieces + 1):
        goal = quat_matrix(axis_angle_quat(axis, angle * k / pieces)) @ start
        turn_tol = TURN_TOL if k == pieces else WAY_TOL
        yield from move_to(world, at, world.hold_grip, goal, tol=tol, max_steps=max_steps, turn_tol=turn_tol)


def hold_still(world: World, grip: float, steps: int) -> Actions:
    for _ in range(steps):
        yield np.concatenate([np.zeros(6), [grip]])
