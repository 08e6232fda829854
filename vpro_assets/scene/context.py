"""What a generator gets: the case, its task, the measured base scene, and shared placement rules
(free spots near the target, instance naming, the destination of the task's goal)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vpro_assets.core.errors import GeneratorError, VProError
from vpro_assets.scene import pool as pool_mod
from vpro_assets.scene.base_scene import BaseScene
from vpro_assets.scene.bddl_doc import Region

SPOT_RADII = (
    0.14,
    0.18,
    0.22,
    0.26,
    0.30,
    0.34,
    0.38,
    0.42,
    0.46,
    0.50,
)  # m from the target's familiar position, nearest first
SPOT_ANGLES = 24
SPOT_CLEARANCE = 0.02  # m between a new object's disc and every other footprint, in every trial row
BOUNDS_PAD = 0.15  # m: new objects stay within the box of the scene's objects and fixtures, grown by this
REGION_HALF = 0.01  # m: half-size of a region written for an added object (LIBERO's own are 1 cm)


@dataclass
class GenContext:
    case: dict
    base: BaseScene

    @property
    def case_id(self) -> str:
        return self.case["id"]

    @property
    def task(self):
        return self.base.task

    def fail(self, why: str) -> VProError:
        return GeneratorError(f"case {self.case_id}: {why}")

    # ---- names and lists -------------------------------------------------------------------
    def new_instance(self, category: str) -> str:
        taken = {i for i, _ in self.base.bddl.objects + self.base.bddl.fixtures}
        n = 1
        while f"{category}_{n}" in taken:
            n += 1
        return f"{category}_{n}"

    def init_with(
        self, replace: dict[str, str] | None = None, add: list[str] | None = None, drop: tuple[str, ...] = ()
    ) -> list[str]:
        """The base init predicates; `replace` maps an old predicate to a new one."""
        out = []
        for p in self.base.bddl.init:
            if p in drop:
                continue
            out.append((replace or {}).get(p, p))
        return out + list(add or [])

    def init_of(self, instance: str) -> str:
        for p in self.base.bddl.init:
            parts = p.strip("()").split()
            if len(parts) == 3 and parts[0].lower() in ("on", "in") and parts[1] == instance:
                return p
        raise self.fail(f"the base BDDL has no init placement for {instance}")

    # ---- geometry ----------------------------------------------------------------------------
    def familiar_xy(self, instance: str) -> np.ndarray:
        return np.asarray(self.base.mean_pos[instance][:2], dtype=float)

    def destination_xy(self) -> np.ndarray:
        """Where the target goes: the receptacle's mean position, or the goal region's centre."""
        task = self.task
        if task.receptacle:
            return self.familiar_xy(task.receptacle)
        for pred, *args in task.goal:
            if pred in ("on", "in") and args[0] == task.target:
                region = self.base.bddl.parsed["regions"].get(args[1])
                if region and region["ranges"]:
                    x0, y0, x1, y1 = region["ranges"][0]
                    return self.base.workspace_offset[:2] + np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        raise self.fail("cannot locate where the goal puts the target")

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        pos = np.array([v["pos"][:2] for v in self.base.layouts[0].values()])
        return pos.min(0) - BOUNDS_PAD, pos.max(0) + BOUNDS_PAD

    def clearance(self, xy: np.ndarray, radius: float, ignore: tuple[str, ...] = ()) -> float:
        """Smallest gap between a disc at `xy` and any object or fixture footprint, over the trials."""
        worst = math.inf
        for layout in self.base.layouts:
            for name, v in layout.items():
                if name in ignore:
                    continue
                lo, hi = v["lo"], v["hi"]
                dx = max(lo[0] - xy[0], 0.0, xy[0] - hi[0])
                dy = max(lo[1] - xy[1], 0.0, xy[1] - hi[1])
                worst = min(worst, math.hypot(dx, dy) - radius)
        return worst

    def free_spot(
        self, around: np.ndarray, radius: float, ignore: tuple[str, ...] = (), radii: tuple[float, ...] = SPOT_RADII
    ) -> np.ndarray:
        """The rule for a new object's nominal spot: on the nearest ring around `around` that has
        a spot clear of every footprint by SPOT_CLEARANCE in every trial row, inside the scene's
        bounds, over the table (not beyond its edge) and inside the central 85% of the agentview image, the spot of that ring with the
        most clearance (first angle on ties)."""
        lo, hi = self.bounds()
        for r in radii:
            best, best_gap = None, -math.inf
            for k in range(SPOT_ANGLES):
                theta = 2 * math.pi * k / SPOT_ANGLES
                xy = around + r * np.array([math.cos(theta), math.sin(theta)])
                if np.any(xy < lo) or np.any(xy > hi) or not self.base.in_view(xy) or not self.base.on_surface(xy):
                    continue
                gap = self.clearance(xy, radius, ignore)
                if gap >= SPOT_CLEARANCE and gap > best_gap + 1e-9:
                    best, best_gap = xy, gap
            if best is not None:
                return np.round(best, 4)
        raise self.fail(
            f"no free spot within {radii[-1]:.2f} m of ({around[0]:.3f}, {around[1]:.3f}) "
            f"for an object of radius {radius:.3f} m"
        )

    def region_at(self, name: str, xy: np.ndarray, half: float = REGION_HALF) -> Region:
        cx, cy = self.base.to_region_xy(xy)
        return Region(
            name,
            self.base.workspace,
            (round(cx - half, 4), round(cy - half, 4), round(cx + half, 4), round(cy + half, 4)),
        )

    def pool_object(self, name: str) -> pool_mod.PoolObject:
        return pool_mod.get(name, self.case_id)

    def target_pool(self) -> pool_mod.PoolObject:
        return self.pool_object(self.task.target_category)
