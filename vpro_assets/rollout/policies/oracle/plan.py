"""The order of skills that reaches a BDDL goal from the current state.

The goal is LIBERO's own parsed goal of the episode's env (`parsed_problem["goal_state"]`, the
conjunction every libero_10 task states), and each predicate is checked with LIBERO's own
predicate functions, so a predicate that already holds gets no skill. The order:
1. switch knobs (`TurnOn`, `TurnOff`): the stove is reached before pots stand in front of it;
2. open what the goal asks open, every closed door something must go *into*, and every drawer
   something must go into that LIBERO's `Open` does not hold for (a drawer part open is not out
   far enough: libero_10-03's bottom drawer at -0.105 of -0.16 leaves 7.3 cm between its front and
   the middle drawer's handle above it, and the 10.7 cm bowl, lowered there, rested on the handle);
3. placements (`On`, `In`), in the goal's order;
4. close what the goal asks closed (after whatever goes inside).
Before a door opens in 2, the objects standing in its swing are pushed out of it (`swing`).
Before 2, a drawer out over an object still to be moved (`sweep`: the box its geoms pass through
between closed and open covers the object's footprint) is closed if the goal does not need it open
(neither asked open nor filled): the open drawer stops the hand coming down on the object.
A flat object too wide to pinch that must go onto a table region is pushed there; an object that
must go into a covered cavity (the microwave) goes in sideways through its opening, stood upright
first when it lies on its side (`stand`). An upside-down object that must go into a region whose box
its body position, so standing, stays above (libero_10-05's book into the caddy) is turned over
first (`turn_over`); one lying flat, too wide every way to pinch, is stood on its end first (`pivot`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from vpro_assets.libero.task_record import TABLE_CATEGORIES
from vpro_assets.rollout.policies.oracle import (
    cavity,
    door,
    drawer,
    knob,
    pivot,
    push,
    stand,
    sweep,
    swing,
    turn_over,
)
from vpro_assets.rollout.policies.oracle.articulation import fully_open, is_drawer, joint_for, needs_opening, owner_of
from vpro_assets.rollout.policies.oracle.motion import Actions
from vpro_assets.rollout.policies.oracle.pick_place import pick_place
from vpro_assets.rollout.policies.oracle.shape import MAX_PINCH_M, narrowest
from vpro_assets.rollout.policies.oracle.world import World

PLACEMENT = ("on", "in")
PUSH_MAX_HEIGHT_M = 0.03


@dataclass(frozen=True)
class Step:
    skill: str  # module of the skill: pick_place, drawer, door, knob, push
    predicate: tuple[str, ...]  # the goal predicate it makes true (lower-case name first)
    run: Callable[[World], Actions]

    def __str__(self) -> str:
        return f"{self.skill}({' '.join(self.predicate)})"


def _is_door(world: World, fixture: str) -> bool:
    return any(world.m.jnt_type[j] == 3 for j in world.joints_of(fixture))  # mjJNT_HINGE


def _articulated(world: World, arg: str) -> bool:
    owner = owner_of(world, arg)
    return owner in dict(world.task.fixtures) and bool(world.joints_of(owner))


def _open_step(world: World, arg: str, opening: bool, full: bool = False) -> Step:
    owner = owner_of(world, arg)
    module = door if _is_door(world, owner) else drawer
    if full:  # a drawer out to the end of its range
        run: Callable[[World], Actions] = lambda w: drawer.open_(w, arg, full=True)  # noqa: E731
    else:
        run = (lambda w: module.open_(w, arg)) if opening else (lambda w: module.close(w, arg))
    return Step(module.__name__.rsplit(".", 1)[1], ("open" if opening else "close", arg), run)


def _pushable(world: World, obj: str, dest: str) -> bool:
    if dest in [inst for inst, _ in world.task.objects]:
        return False
    pts = world.points(obj)
    height = pts[:, 2].max() - pts[:, 2].min()
    table_region = dict(world.task.fixtures).get(owner_of(world, dest)) in TABLE_CATEGORIES  # not a basket's
    return table_region and height < PUSH_MAX_HEIGHT_M and narrowest(pts)[1] > MAX_PINCH_M


def _switch(world: World, fixture: str, on: bool) -> Actions:
    return knob.switch(world, fixture, on=on)


def _push(world: World, obj: str, region: str) -> Actions:
    return push.push_to(world, obj, region)


def _put_in(world: World, held: str, region: str) -> Actions:
    return cavity.put_in(world, held, region)


def _stand_up(world: World, held: str) -> Actions:
    return stand.stand_up(world, held)


def _turn_over(world: World, held: str) -> Actions:
    return turn_over.turn_over(world, held)


def _stand_on_end(world: World, held: str) -> Actions:
    return pivot.stand_up(world, held)


def _pick_place(world: World, held: str, relation: str, dest: str, coming: tuple[str, ...] = ()) -> Actions:
    return pick_place(world, held, relation, dest, coming)


def _drawers_out_of_the_way(world: World, goal: list[tuple[str, ...]], todo: list[tuple[str, ...]]) -> list[Step]:
    """Close steps for the drawers that are out over an object still to be moved and that the goal
    does not need open (neither asked open, held or not yet, nor something put in them)."""
    movers = [pred[1] for pred in todo if pred[0] in PLACEMENT]
    needed = {
        joint_for(world, pred[-1]).id
        for pred in goal
        if (pred[0] == "open" or (pred[0] == "in" and _articulated(world, pred[2]))) and is_drawer(world, pred[-1])
    }
    return [
        _open_step(world, joint.region, False)
        for joint in sweep.drawer_joints(world)
        if joint.id not in needed
        and sweep.is_out(world, joint)
        and any(sweep.under_sweep(world, joint, obj) for obj in movers)
    ]


def _push_out(world: World, region: str, obj: str) -> Actions:
    return swing.push_out(world, joint_for(world, region), obj)


def _out_of_the_swing(world: World, door_region: str) -> list[Step]:
    """Push steps for the objects standing where the door opens (`swing`)."""
    joint = joint_for(world, door_region)
    return [
        Step("swing", ("clear", obj, joint.fixture), partial(_push_out, region=door_region, obj=obj))
        for obj, _ in world.task.objects
        if swing.in_swing(world, joint, world.points(obj))
    ]


def _opening(world: World, region: str, full: bool = False) -> list[Step]:
    """The open step of a drawer or door; before a door's, pushes out of its swing. `full`: a drawer
    out to the end of its range."""
    door_first = _out_of_the_swing(world, region) if _is_door(world, owner_of(world, region)) else []
    return [*door_first, _open_step(world, region, True, full)]


WIDE_END_M = 0.02  # an object whose lowest slice is this much wider than its top goes in wide end first
END_SLICE_M = 0.01


def _wide_end_down(world: World, obj: str) -> bool:
    """Whether `obj` stands wide end down (an inverted bowl: its 10.7 cm rim under its 4.6 cm foot),
    so that it goes into a drawer wide end first."""
    pts = world.points(obj)
    z = pts[:, 2]

    def width(sl: np.ndarray) -> float:
        return float(np.ptp(sl[:, :2], axis=0).max())

    return width(pts[z < z.min() + END_SLICE_M]) > width(pts[z > z.max() - END_SLICE_M]) + WIDE_END_M


def plan(world: World, goal: list[tuple[str, ...]], holds: Callable[[tuple[str, ...]], bool]) -> list[Step]:
    """Steps for the goal predicates that do not hold yet, in dependency order."""
    todo = [(g[0].lower(), *g[1:]) for g in goal if not holds(tuple(g))]
    steps: list[Step] = []
    for pred in todo:
        if pred[0] in ("turnon", "turnoff"):
            steps.append(Step("knob", pred, partial(_switch, fixture=pred[1], on=pred[0] == "turnon")))
    steps += _drawers_out_of_the_way(world, [(g[0].lower(), *g[1:]) for g in goal], todo)
    opened: set[str] = set()
    for pred in todo:
        if pred[0] == "open":
            steps += _opening(world, pred[1])
            opened.add(pred[1])
    for pred in todo:
        if pred[0] != "in" or not _articulated(world, pred[2]) or pred[2] in opened:
            continue
        # Wide end first, a drawer's mouth must be as wide as the drawer goes (libero_10-03's
        # object_pose: at LIBERO's -0.146 an inverted bowl's rim caught the handles above and fell
        # in on edge, jamming the close).
        full = is_drawer(world, pred[2]) and _wide_end_down(world, pred[1])
        if needs_opening(world, pred[2], holds(("open", pred[2]))) or (full and not fully_open(world, pred[2])):
            steps += _opening(world, pred[2], full)
            opened.add(pred[2])
    for pred in todo:
        if pred[0] in PLACEMENT:
            _, obj, dest = pred
            if _pushable(world, obj, dest):
                steps.append(Step("push", pred, partial(_push, obj=obj, region=dest)))
            elif pred[0] == "in" and cavity.covered(world, dest) is not None:
                if stand.on_side(world, obj):  # held lying, it stands too tall for the cavity (`stand`)
                    steps.append(Step("stand", ("upright", obj), partial(_stand_up, held=obj)))
                steps.append(Step("cavity", pred, partial(_put_in, held=obj, region=dest)))
            else:
                if pred[0] == "in" and turn_over.needs_turning_over(world, obj, dest):  # upside down, too tall
                    steps.append(Step("turn_over", ("upright", obj), partial(_turn_over, held=obj)))
                elif pred[0] == "in" and pivot.needs_pivot(world, obj, dest):  # flat, too wide to pinch
                    steps.append(Step("pivot", ("upright", obj), partial(_stand_on_end, held=obj)))
                # The objects that go onto the same region after this one (`room`).
                coming = tuple(p[1] for p in todo[todo.index(pred) + 1 :] if p[0] == pred[0] and p[2] == dest)
                run = partial(_pick_place, held=obj, relation=pred[0], dest=dest, coming=coming)
                steps.append(Step("pick_place", pred, run))
    for pred in todo:
        if pred[0] == "close":
            steps.append(_open_step(world, pred[1], False))
    return steps


def unmet(goal: list[tuple[str, ...]], holds: Callable[[tuple[str, ...]], bool]) -> list[tuple[str, ...]]:
    return [tuple(g) for g in goal if not holds(tuple(g))]
