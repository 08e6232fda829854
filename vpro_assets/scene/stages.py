"""The clock of a case's build: wall seconds per stage and, inside `physics.metered()`, the seconds
of them MuJoCo itself needed (compiling the scene model, mj_step, mj_forward)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

from vpro_assets.libero import physics


@dataclass
class StageClock:
    wall: dict[str, float] = field(default_factory=dict)
    physics: dict[str, float] = field(default_factory=dict)
    peak_child_rss_mb: float = 0.0  # of the child process a generated object was made in, if any

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        started, mj = time.perf_counter(), physics.COUNTERS.physics_seconds()
        try:
            yield
        finally:
            self.wall[name] = self.wall.get(name, 0.0) + time.perf_counter() - started
            used = physics.COUNTERS.physics_seconds() - mj
            if used:
                self.physics[name] = self.physics.get(name, 0.0) + used
