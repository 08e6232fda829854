"""Manipulation phase tracker from privileged simulator state.

Phases, in order: approach -> grasp -> transport -> pre_placement -> placed. The tracker is
monotone (a phase once reached is never left; a dropped object does not re-open "approach"), so
schedules such as "before grasp" have one well-defined boundary. Detection, per observation:

- grasp phase starts when any gripper geom touches the interaction object (the target, or the
  first articulated fixture of a fixture-only goal), or the grip site comes within
  `REACH_M` of one of the object's geoms;
- grasp onset (an event) is the first step where both fingers touch the target (robosuite's own
  grasp test); for fixture-only goals the first gripper contact;
- transport starts once the target is grasped and lifted `LIFT_M` above its height at grasp onset;
- pre_placement starts during transport when the target is within `PRE_PLACE_XY_M` of the
  receptacle horizontally (tasks with a receptacle only);
- placed (placement onset, an event) is the first step in pre_placement where the target touches
  the receptacle or is released (no finger contact).

Every step is logged; `timeline()` returns the (step, phase) changes and the two onsets.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vpro_assets.benchmark.taxonomy import PHASES
from vpro_assets.perturb.entities import EntityIndex

PLACED = "placed"
ALL_PHASES = PHASES + (PLACED,)
REACH_M = 0.04
LIFT_M = 0.01
PRE_PLACE_XY_M = 0.10


@dataclass
class PhaseState:
    step: int
    phase: str
    grasp_onset: int | None
    placement_onset: int | None


@dataclass(frozen=True)
class _GeomMasks:
    """The tracked entities' geoms as boolean masks over the model's geoms (`PhaseTracker._touch`)."""

    entities: EntityIndex
    obj_geoms: np.ndarray  # the interaction object's geom ids
    obj: np.ndarray
    gripper: np.ndarray
    left: np.ndarray
    right: np.ndarray
    receptacle: np.ndarray

    @classmethod
    def of(cls, ent: EntityIndex) -> _GeomMasks:
        def mask(geoms) -> np.ndarray:
            out = np.zeros(ent.model.ngeom, dtype=bool)
            out[np.asarray(geoms, dtype=np.int64)] = True
            return out

        obj = ent.interaction
        obj_geoms = np.asarray(obj.geoms if obj is not None else [], np.int32)
        return cls(
            ent,
            obj_geoms,
            mask(obj_geoms),
            mask(ent.gripper.geoms),
            mask(ent.left_finger_geoms),
            mask(ent.right_finger_geoms),
            mask(ent.receptacle.geoms if ent.receptacle is not None else []),
        )


@dataclass
class PhaseTracker:
    entities: EntityIndex
    history: list[str] = field(default_factory=list)
    grasp_onset: int | None = None
    placement_onset: int | None = None
    _phase: int = 0
    _grasp_height: float | None = None
    _masks: _GeomMasks | None = field(default=None, repr=False)

    def reset(self, entities: EntityIndex | None = None) -> None:
        if entities is not None:
            self.entities = entities
        self.history.clear()
        self.grasp_onset = self.placement_onset = None
        self._phase = 0
        self._grasp_height = None

    @property
    def phase(self) -> str:
        return ALL_PHASES[self._phase]

    @property
    def step(self) -> int:
        return len(self.history) - 1

    def _contacts(self, data) -> tuple[np.ndarray, np.ndarray]:
        n = data.ncon
        if n == 0:
            return np.empty(0, np.int32), np.empty(0, np.int32)
        return np.asarray(data.contact.geom1[:n]), np.asarray(data.contact.geom2[:n])

    def _geom_masks(self) -> _GeomMasks:
        if self._masks is None or self._masks.entities is not self.entities:
            self._masks = _GeomMasks.of(self.entities)
        return self._masks

    @staticmethod
    def _touch(g1: np.ndarray, g2: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether a contact (g1[i], g2[i]) joins a geom of `a` and one of `b` (boolean masks over
        the model's geoms: a lookup per contact where np.isin sorted both lists at every call)."""
        return bool(np.any((a[g1] & b[g2]) | (b[g1] & a[g2])))

    def update(self, sim) -> PhaseState:
        """Advance by one observation of `sim`'s current state; returns the state for this step."""
        ent, data = self.entities, sim.data._data
        step = len(self.history)
        obj = ent.interaction
        if obj is not None:
            masks = self._geom_masks()
            g1, g2 = self._contacts(data)
            obj_geoms = masks.obj_geoms
            touching = self._touch(g1, g2, masks.gripper, masks.obj)
            both = self._touch(g1, g2, masks.left, masks.obj) and self._touch(g1, g2, masks.right, masks.obj)
            if self._phase == 0:
                near = (
                    ent.grip_site >= 0
                    and np.min(np.linalg.norm(data.geom_xpos[obj_geoms] - data.site_xpos[ent.grip_site], axis=1))
                    < REACH_M
                )
                if touching or near:
                    self._phase = 1
            grasped = both if ent.target is not None else touching
            if grasped and self.grasp_onset is None:
                self.grasp_onset = step
                self._phase = max(self._phase, 1)
                self._grasp_height = float(data.xpos[obj.root][2])
            if ent.target is not None and self.grasp_onset is not None and self._grasp_height is not None:
                height = float(data.xpos[obj.root][2])
                if self._phase == 1 and both and height > self._grasp_height + LIFT_M:
                    self._phase = 2
                if ent.receptacle is not None and self._phase in (2, 3):
                    xy = np.linalg.norm(data.xpos[obj.root][:2] - data.xpos[ent.receptacle.root][:2])
                    if self._phase == 2 and xy < PRE_PLACE_XY_M:
                        self._phase = 3
                    on = self._touch(g1, g2, masks.obj, masks.receptacle)
                    released = not (
                        self._touch(g1, g2, masks.left, masks.obj) or self._touch(g1, g2, masks.right, masks.obj)
                    )
                    if self._phase == 3 and (on or released):
                        self._phase = 4
                        self.placement_onset = step
        self.history.append(self.phase)
        return PhaseState(step, self.phase, self.grasp_onset, self.placement_onset)

    def timeline(self) -> dict:
        changes = [(i, p) for i, p in enumerate(self.history) if i == 0 or self.history[i - 1] != p]
        return {
            "changes": changes,
            "grasp_onset": self.grasp_onset,
            "placement_onset": self.placement_onset,
            "steps": len(self.history),
        }
