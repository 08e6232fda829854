"""`vpro validate`: check built scene cases the way a user's LIBERO would meet them.

For each case: the BDDL parses with LIBERO's parser and keeps the task's language and goal; every
generated object's MJCF compiles alone; LIBERO builds the env from the BDDL; the scene's MJCF
(`sim.model.get_xml()`) compiles again in MuJoCo with no warning; every frozen initial state has
the model's width and loads; visual-only additions have no geom that can collide; and one second of zero actions from each leaves every object at rest
(moved less than 1 cm, slower than 2 cm/s) with no MuJoCo warning raised while stepping, and every
movable object comes up under a gentle pull (none starts locked: `start_checks.stuck_objects`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field

import mujoco
import numpy as np
from tqdm import tqdm

from vpro_assets.core import mjcache, paths
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.init_states import read_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene import bddl_doc, sim
from vpro_assets.scene.build import built_case
from vpro_assets.scene.build import worker_init as build_worker_init
from vpro_assets.scene.start_checks import drift, stuck_objects

log = logging.getLogger(__name__)

# MuJoCo's asset cache in a validation process. Validation compiles each scene twice with its
# textures (LIBERO's env, then the MJCF written back), 216-374 MB of decoded meshes and textures
# for one scene (libero_10-02 to libero_10-00), and the cases of a task, validated one after the
# other, share most of them. Under the build's 256 MB (a scene's meshes without textures) a compile
# found only part of its files (least recently used eviction, files read in the same order each
# time): a warm textured compile took 1.2-1.5 s against 0.8-1.0 s with room for the scene.
ASSET_CACHE_BYTES = 512 << 20


def _worker_init() -> None:
    build_worker_init()
    mjcache.set_capacity(ASSET_CACHE_BYTES)


@dataclass
class Validation:
    case_id: str
    problems: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.problems


def validate_case(case: dict) -> Validation:
    started = time.perf_counter()
    result = Validation(case["id"])
    try:
        found = built_case(case["id"])
    except Exception as exc:
        result.problems.append(str(exc))
        return result
    result.problems += _file_problems(case, found)
    try:
        # fresh: compiled at construction and reset on that model, so get_xml() below is this
        # scene's; one compile, no copy (vpro_assets.libero.physics)
        env = sim.physics_env(str(found["bddl"]), fresh=True)
    except Exception as exc:
        result.problems.append(f"LIBERO cannot build the env from {found['bddl'].name}: {type(exc).__name__}: {exc}")
        result.seconds = time.perf_counter() - started
        return result
    try:
        xml = sim.raw(env).sim.model.get_xml()
        fixture_problems = _fixture_problems(env, found["meta"])
        state_problems = _state_problems(env, case, found)
    finally:
        env.close()
    # compiled again once the env's model is gone: one scene model (210 MB with textures) at a time
    result.problems += _xml_problems(xml) + fixture_problems + state_problems
    result.seconds = time.perf_counter() - started
    return result


def _file_problems(case: dict, found: dict) -> list[str]:
    """The BDDL against the base task's; every generated object's MJCF compiles alone."""
    problems = []
    try:
        task = get_task(case["task"])
        base_bddl = bddl_doc.read_base(libero_bridge.bddl_path(task.suite, task.name))
        bddl_doc.check_variant(found["bddl"].read_text(), base_bddl, case["id"])
    except Exception as exc:
        problems.append(str(exc))
    for name in found["meta"].get("generated_objects", {}):
        try:
            mujoco.MjModel.from_xml_path(str(paths.objects_root() / name / f"{name}.xml"))
        except Exception as exc:
            problems.append(f"generated object {name} does not compile: {exc}")
    return problems


def _xml_problems(xml: str) -> list[str]:
    """The scene's MJCF as MuJoCo writes it back (`get_xml()`) compiles again without warnings."""
    try:
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        warnings = [mujoco.mjtWarning(i).name for i in range(len(data.warning)) if data.warning[i].number]
        if warnings:
            return [f"the scene MJCF compiles with MuJoCo warning(s) {', '.join(warnings)}"]
    except Exception as exc:
        return [f"the scene MJCF does not compile again in MuJoCo: {exc}"]
    return []


def _fixture_problems(env, meta: dict) -> list[str]:
    """Visual-only additions cannot collide."""
    problems = []
    m = sim.raw(env).sim.model._model
    for instance in meta.get("added", []):
        fixture = sim.raw(env).fixtures_dict.get(instance)
        if fixture is None:
            continue  # an added movable object (a distractor)
        root = sim.raw(env).sim.model.body_name2id(fixture.root_body)
        touching = [
            g
            for g in range(m.ngeom)
            if int(m.body_rootid[m.geom_bodyid[g]]) == root and (m.geom_contype[g] or m.geom_conaffinity[g])
        ]
        if touching:
            problems.append(f"visual-only {instance} has {len(touching)} geom(s) that can collide")
    return problems


def _state_problems(env, case: dict, found: dict) -> list[str]:
    """The frozen initial states: both files equal, the model's width, at rest under zero actions,
    no MuJoCo warning, goal not already satisfied."""
    problems = []
    m = sim.raw(env).sim.model._model
    states = read_init_states(found["init_states"])
    npz = np.load(found["init_states_npz"])["states"]
    if not np.array_equal(states, npz):
        problems.append("the .pruned_init and .npz initial states differ")
    movable = [name for name, obj in sim.raw(env).objects_dict.items() if obj.joints]
    width = 1 + m.nq + m.nv
    if states.shape != (len(case["trial_seeds"]), width):
        problems.append(f"initial states have shape {states.shape}, expected ({len(case['trial_seeds'])}, {width})")
        return problems
    for k, row in enumerate(states):
        sim.place_fixtures(env, case["trial_seeds"][k])  # as the rollout places them
        sim.load_state(env, row)
        moved = drift(env)
        warnings = sim.mujoco_warnings(env)
        if moved:
            problems.append(f"initial state {k}: not at rest under zero actions ({'; '.join(moved[:3])})")
        if warnings:
            problems.append(f"initial state {k}: MuJoCo warnings while stepping: {', '.join(warnings)}")
        if sim.raw(env)._check_success():
            problems.append(f"initial state {k}: the goal is already satisfied")
        problems += [f"initial state {k}: {p}" for p in stuck_objects(env, movable, row)]
    return problems


def _validate_group(cases: list[dict]) -> list[Validation]:
    out = []
    for case in cases:
        try:
            out.append(validate_case(case))
        except Exception as exc:  # a crash inside LIBERO/MuJoCo: report it against the case
            out.append(Validation(case["id"], [f"{type(exc).__name__}: {exc}"]))
    return out


def validate(cases: list[dict], jobs: int = 1, progress: bool = True) -> Iterator[Validation]:
    """Validate scene cases, `jobs` processes in parallel; results come as cases finish.

    Task by task (the catalog lists a setting's cases across tasks): consecutive compiles of one
    task's scenes find their meshes and textures in MuJoCo's asset cache (`ASSET_CACHE_BYTES`)."""
    cases = sorted(cases, key=lambda c: c["task"])  # stable: the catalog's order within a task
    with tqdm(total=len(cases), unit="case", desc="vpro validate", disable=not progress) as bar:
        if jobs <= 1:
            _worker_init()  # this process validates, as a worker would
            for case in cases:
                yield from _validate_group([case])
                bar.update(1)
            return
        with ProcessPoolExecutor(max_workers=jobs, initializer=_worker_init) as pool:
            for fut in as_completed([pool.submit(_validate_group, [c]) for c in cases]):
                bar.update(1)
                yield from fut.result()
