"""Shared fixtures. Tests never touch the user's home: LIBERO's config goes to a temp dir."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile

import pytest

# Before anything imports LIBERO: config in a per-run folder, quiet robosuite.
os.environ.setdefault("VPRO_LIBERO_CONFIG_DIR", tempfile.mkdtemp(prefix="vpro-libero-config-"))

# Before any test module imports numpy: the toolkit's import pins numpy's kernels (the lock's bytes).
import vpro_assets  # noqa: E402, F401

# Files that run for minutes start first: `make test` spreads files over two workers (pytest-xdist,
# --dist loadfile), and a long file dealt last would run alone at the end (the fork's environment
# alone takes minutes to set up). The rest keep pytest's order.
LONGEST_FIRST = (
    "packs/test_fork_import.py",
    "integrations/test_vla_eval.py",
    "perturb/test_position_contradiction.py",
    "rollout/test_resume.py",
)


def pytest_collection_modifyitems(config, items):
    tests_dir = os.path.dirname(__file__)
    rank = {os.path.join(tests_dir, name): i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(str(item.path), len(rank)))  # stable: pytest's order otherwise


@pytest.fixture(scope="session")
def tasks():
    from vpro_assets.libero.tasks import load_tasks

    return load_tasks()


@pytest.fixture(scope="session")
def built_catalog():
    from vpro_assets.benchmark.catalog import build_catalog

    return build_catalog()


# A scene case both the scene-build tests and the rollout end-to-end test use: a recoloured
# distractor on libero_spatial-00 (registers a generated object; no long mesh work).
BUILT_SCENE_CASE = "libero_spatial-00/task_relevant_distractors/same_color-v1"


def scene_variant(cid: str):
    """(GenContext, SceneVariant) of a scene case, from its generator (nothing built)."""
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.scene import plugins
    from vpro_assets.scene.base_scene import base_scene
    from vpro_assets.scene.context import GenContext

    case = find_case(load_catalog(paths.catalog_path()), cid)
    ctx = GenContext(case=case, base=base_scene(case["task"]))
    return ctx, plugins.generator_for(case).fn(ctx)


@contextlib.contextmanager
def variant_env(cid: str, folder):
    """(ctx, variant, env): the case's variant BDDL written into `folder` and LIBERO's render-free
    env of it, as the build makes them; the env is closed on leaving."""
    from vpro_assets.scene import build, sim

    ctx, variant = scene_variant(cid)
    bddl = folder / build._bddl_name(ctx.base.task)
    bddl.write_text(build.variant_bddl(ctx.case, "test", ctx.base, variant))
    env = sim.physics_env(str(bddl))
    try:
        yield ctx, variant, env
    finally:
        env.close()


def start_trial(env, ctx, variant, trial: int) -> None:
    """Put `env` in the build's accepted start of `trial` (`init_gen.trial_state`)."""
    from vpro_assets.scene.init_gen import trial_state

    base = ctx.base
    row = base.rows[base.trial_rows[trial]]
    trial_state(env, variant, row, base.slots, trial, base.layouts[trial], ctx.case["trial_seeds"][trial])


@pytest.fixture(scope="session")
def scene_out(tmp_path_factory):
    """An out/ folder (VPRO_OUT) shared by the session, with BUILT_SCENE_CASE built in it."""
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths
    from vpro_assets.scene import build

    d = tmp_path_factory.mktemp("vpro-out")
    case = find_case(load_catalog(paths.catalog_path()), BUILT_SCENE_CASE)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VPRO_OUT", str(d))
        assert build.build_case(case).status == "built"
    return d


@pytest.fixture
def eval_on_server(tmp_path):
    """`run(case, port, settings, trials=1, retries=0, **options)`: `vpro eval`'s runner, inline, with
    the openpi policy at 127.0.0.1:port, into a fresh results file; returns the run's episode rows
    (the openpi and world-action-model tests)."""
    from vpro_assets.rollout.runner import run_eval
    from vpro_assets.rollout.store import ResultsStore

    def run(case, port: int, settings, *, trials: int = 1, retries: int = 0, **options) -> list[dict]:
        db = tmp_path / "r.sqlite"
        summary = run_eval(
            [case],
            results=db,
            policy_spec=f"openpi:127.0.0.1:{port}",
            settings=settings,
            trials=trials,
            backend="inline",
            retries=retries,
            retry_delay=0,
            **options,
        )
        return ResultsStore(db).episodes(summary.run_id)

    return run


def catalog_case(case_id: str) -> dict:
    """A case's record in the committed catalog."""
    from vpro_assets.benchmark.catalog import find_case, load_catalog
    from vpro_assets.core import paths

    return find_case(load_catalog(paths.catalog_path()), case_id)


def build_scene_case(case_id: str) -> None:
    """`vpro build --select CASE` (a no-op when the case is current), for the slow tests of built cases."""
    subprocess.run([sys.executable, "-m", "vpro_assets.cli", "build", "--select", case_id], check=True)


def oracle_episode(case_id: str, trial: int, *, build: bool = False) -> dict:
    """One render-free oracle episode of a case at a trial: its episode row (success, steps, final state)."""
    from vpro_assets.rollout.episode import EpisodeSettings, run_episode
    from vpro_assets.rollout.policies.oracle.policy import OraclePolicy

    if build:
        build_scene_case(case_id)
    return run_episode(catalog_case(case_id), trial, OraclePolicy(), EpisodeSettings(render=False))


class OracleScene:
    """A render-free env of one case at one trial's initial state, after LIBERO's wait steps: what the
    oracle's skill tests start from."""

    def __init__(self, case_id: str, trial: int = 0):
        from vpro_assets.rollout.case_env import env_for_case
        from vpro_assets.rollout.policies.oracle.policy import libero_holds
        from vpro_assets.rollout.policies.oracle.world import World

        self.case = catalog_case(case_id)
        self.cenv = env_for_case(self.case, trial, render=False, reuse=False)
        self.cenv.reset()
        self.wait(10)
        self.holds = libero_holds(self.cenv.env)
        self.world = World(self.cenv.sim, self.cenv.task, self.holds)

    def wait(self, steps: int) -> None:
        from vpro_assets.libero.env import NOOP_ACTION

        for _ in range(steps):
            self.cenv.step(NOOP_ACTION)

    def run(self, actions, limit: int) -> int:
        """Step the skill's actions to its end (at most `limit`); the steps taken."""
        for n, action in enumerate(actions, 1):
            self.cenv.step(action)
            assert n < limit, f"skill still running after {limit} steps"
        return n

    def set_joint(self, joint: int, q: float) -> None:
        """Set a drawer's or door's joint (a closed start, as the precondition cases give it) and settle."""
        self.cenv.sim.data.qpos[self.world.m.jnt_qposadr[joint]] = q
        self.cenv.sim.forward()
        self.wait(5)

    def set_pose(self, instance: str, pos, mat) -> None:
        """Place `instance`'s free body at `pos` with rotation matrix `mat`, everything at rest, and
        let it settle 20 steps (an object_pose case's start, made in another case's scene)."""
        import mujoco
        import numpy as np

        w = self.world
        body = w.entity(instance).root
        adr = int(w.m.jnt_qposadr[w.m.body_jntadr[body]])
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.asarray(mat, dtype=np.float64).flatten())
        qpos = self.cenv.sim.data.qpos
        qpos[adr : adr + 3] = pos
        qpos[adr + 3 : adr + 7] = quat
        self.cenv.sim.data.qvel[:] = 0.0
        self.cenv.sim.forward()
        self.wait(20)

    def plan(self) -> list[str]:
        """The oracle's plan from LIBERO's goal and the current state, one string per step."""
        from vpro_assets.rollout.policies.oracle.plan import plan
        from vpro_assets.rollout.policies.oracle.policy import OracleController

        goal = OracleController(self.cenv.env, self.cenv.task).goal
        return [str(step) for step in plan(self.world, goal, self.holds)]

    def oracle_until_success(self, limit: int) -> bool:
        """Run the oracle (plan, skills, replans) from the current state until LIBERO's success."""
        from vpro_assets.rollout.policies.oracle.policy import OracleController

        controller = OracleController(self.cenv.env, self.cenv.task)
        for _ in range(limit):
            self.cenv.step(controller.action())
            if self.cenv.success():
                return True
        return False

    def close(self) -> None:
        self.cenv.close()


@pytest.fixture
def scene():
    """`scene(case_id, trial=0)`: an OracleScene, closed after the test."""
    made: list[OracleScene] = []

    def make(case_id: str, trial: int = 0) -> OracleScene:
        made.append(OracleScene(case_id, trial))
        return made[-1]

    yield make
    for s in made:
        s.close()
