"""Gripper contact composition of an episode, read from MuJoCo's contact list.

Each step, every active contact is checked for a gripper geom (robosuite names them `gripper0_*`)
against a geom of the target object or of a distractor (geoms of bodies named `<instance>_*`, as
LIBERO names an object's bodies). An episode is then `target_only`, `distractor_only`, `both` or
`neither`, with the first step of each kind of contact. Cases without a distractor can only be
`target_only` or `neither`.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from vpro_assets.libero.env import GRIPPER_PREFIX

COMPOSITIONS = ("target_only", "distractor_only", "both", "neither")


def _geoms_of(model, instances: Iterable[str]) -> set[int]:
    prefixes = tuple(f"{name}_" for name in instances if name)
    if not prefixes:
        return set()
    out = set()
    for gid in range(model.ngeom):
        body = model.body_id2name(int(model.geom_bodyid[gid])) or ""
        # An object's bodies are children of its `<instance>_main` body; walk to the top-level body.
        bid = int(model.geom_bodyid[gid])
        while bid != 0 and not body.startswith(prefixes):
            bid = int(model.body_parentid[bid])
            body = model.body_id2name(bid) or ""
        if body.startswith(prefixes):
            out.add(gid)
    return out


def _mask(ngeom: int, geoms: set[int]) -> np.ndarray:
    out = np.zeros(ngeom, dtype=bool)
    out[sorted(geoms)] = True
    return out


class ContactTracker:
    def __init__(self, sim, target: str | None, distractors: Iterable[str] = ()):
        model = sim.model
        self.sim = sim
        self.gripper = {g for g in range(model.ngeom) if (model.geom_id2name(g) or "").startswith(GRIPPER_PREFIX)}
        self.target = _geoms_of(model, [target] if target else [])
        self.distractor = _geoms_of(model, distractors) - self.target
        self.first_target: int | None = None
        self.first_distractor: int | None = None
        # The three sets as boolean masks over the model's geoms: a lookup per contact.
        self._gripper, self._target, self._distractor = (
            _mask(model.ngeom, self.gripper),
            _mask(model.ngeom, self.target),
            _mask(model.ngeom, self.distractor),
        )

    def update(self, step: int) -> None:
        if self.first_target is not None and (self.first_distractor is not None or not self.distractor):
            return  # both first steps known (or no distractor to find): nothing more to learn
        data = self.sim.data
        n = int(data.ncon)
        if n == 0:
            return
        gripper, target, distractor = self._gripper, self._target, self._distractor
        contact = data.contact  # MuJoCo's contact list: its fields as arrays over the ncon contacts
        g1, g2 = np.asarray(contact.geom1[:n], np.int64), np.asarray(contact.geom2[:n], np.int64)
        # the other geom of each gripper contact (a contact whose first geom is the gripper's: its second)
        other = np.where(gripper[g1], g2, g1)[gripper[g1] | gripper[g2]]
        if self.first_target is None and target[other].any():
            self.first_target = step
        if self.first_distractor is None and distractor[other].any():
            self.first_distractor = step

    @property
    def composition(self) -> str:
        t, d = self.first_target is not None, self.first_distractor is not None
        return "both" if t and d else "target_only" if t else "distractor_only" if d else "neither"

    def summary(self) -> dict:
        return {
            "composition": self.composition,
            "first_target_step": self.first_target,
            "first_distractor_step": self.first_distractor,
            "distractor_tracked": bool(self.distractor),
        }
