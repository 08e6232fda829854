"""Observation-level cases around a fork's own LIBERO env (part of the pack runtime,
`vpro_libero_fork`; see `vpro_assets.packs.fork_runtime`): `wrap(env, case)` returns a `ForkEnv`
whose observations follow the case, `reset(env, case, trial, init_states)` starts a trial as the
frozen scenes expect.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.settled import seeded_reset
from vpro_assets.libero.task_record import TaskRecord
from vpro_assets.perturb.observer import CaseObserver


def pack_root() -> Path:
    """The pack this module was loaded from: in a pack it lies two folders below the pack's root, in
    the private copy of the toolkit's packages (in the toolkit: the folder above the package,
    which holds no cases)."""
    return Path(__file__).resolve().parents[2]


def load_case(case: Mapping | str | os.PathLike, root: Path | None = None) -> dict:
    """A case: a dict as is, a case JSON file, or a case id looked up in the pack's cases/."""
    if isinstance(case, Mapping):
        return dict(case)
    path = Path(case)
    if path.suffix == ".json" and path.is_file():
        return json.loads(path.read_text(encoding="utf-8"))
    root = root or pack_root()
    for candidate in sorted((root / "cases").glob("*/*.json")):
        data = json.loads(candidate.read_text(encoding="utf-8"))
        if data.get("id") == str(case):
            return data
    raise InvalidParameterError(f"case {str(case)!r}: not a case JSON file nor a case of the pack at {root}")


class ForkEnv:
    """A fork's LIBERO env whose observations follow an observation-level case.

    Keeps LIBERO's `reset()`, `set_init_state(state)` and `step(action)` and returns raw
    (bottom-up) frames, so the fork's own flips and resizes still apply. The trial (which seeds the
    case's random streams) is the number of earlier `reset()` calls unless `env.trial` is set or
    `reset(env, case, trial)` is used. Under single-view View Unavailability the removed camera's
    key is absent from the observation (`available_cameras` lists what the policy receives).
    """

    def __init__(self, env, case: Mapping | str | os.PathLike):
        if not all(hasattr(env, m) for m in ("reset", "step", "set_init_state", "sim")):
            raise InvalidParameterError(f"wrap() needs a LIBERO env (OffScreenRenderEnv), got {type(env).__name__}")
        self.env = env
        self.case = load_case(case)
        case_id = self.case.get("id", "<case>")
        if self.case.get("level") != "observation":
            raise InvalidParameterError(
                f"case {case_id}: level {self.case.get('level')!r}, it changes the scene: build "
                "its env from the pack's BDDL instead of wrapping the base task's env"
            )
        if "task_record" not in self.case:
            raise InvalidParameterError(f"case {case_id}: no task_record; pass the pack's case JSON or its id")
        self.task = TaskRecord.from_json(self.case["task_record"])
        self.trial = 0
        self._observer: CaseObserver | None = None

    def __getattr__(self, name):
        if name in ("env", "case", "_observer"):
            raise AttributeError(name)
        return getattr(self.env, name)

    @property
    def available_cameras(self) -> tuple[str, ...]:
        return self._require().available_cameras

    def _require(self) -> CaseObserver:
        if self._observer is None:
            raise InvalidParameterError(f"case {self.case['id']}: call reset() before using the env")
        return self._observer

    def reset(self):
        raw = self.env.reset()
        self._observer = CaseObserver(self.env, self.case, self.trial, self.task)
        self.trial += 1
        return self._observer.on_reset(raw)

    def set_init_state(self, state):
        # LIBERO's loops set the initial state right after reset: the episode (step 0) starts here.
        return self._require().on_reset(self.env.set_init_state(state))

    def step(self, action, predicted_frames: Mapping | None = None):
        observer = self._require()
        observer.feed_predicted(predicted_frames)
        raw, reward, done, info = self.env.step(action)
        return observer.on_step(raw), reward, done, info

    def phase_timeline(self) -> dict:
        return self._require().phase_timeline()


def wrap(env, case: Mapping | str | os.PathLike) -> ForkEnv:
    """Wrap a fork's LIBERO env so its observations follow `case` (an observation-level case)."""
    return ForkEnv(env, case)


def reset(env, case: Mapping | str | os.PathLike, trial: int, init_states=None):
    """Start trial `trial` of `case` as the frozen scenes expect: `env.seed(case's trial seed)`,
    `env.reset()` placing the fixtures as a new env's first reset (`seeded_reset`), then (with
    `init_states`, the suite's `get_task_init_states(i)`) row `trial`. `env` is the fork's env or
    `wrap`'s; return the first observation (perturbed when wrapped)."""
    case = load_case(case)
    seeds = case.get("trial_seeds") or []
    if not isinstance(trial, int) or not 0 <= trial < len(seeds):
        raise InvalidParameterError(f"case {case.get('id')}: trial {trial!r} out of range (0..{len(seeds) - 1})")
    if isinstance(env, ForkEnv):
        env.trial = trial
    obs = seeded_reset(env, int(seeds[trial]))
    if init_states is not None:
        if not 0 <= trial < len(init_states):
            raise InvalidParameterError(f"case {case.get('id')}: trial {trial} but {len(init_states)} initial states")
        obs = env.set_init_state(init_states[trial])
    return obs
