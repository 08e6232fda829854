"""`vpro_assets.wrap(env, case)`: a case's observation perturbations inside a fork's own loop.

The same code a pack ships (`fork_runtime.ForkEnv`, `vpro_libero_fork.wrap` in a pack); here a
case may also be given by id or as a catalog record, and its task record is taken from the
catalog's `tasks` table. Nothing is written and LIBERO's config is neither read nor written: the
fork's env is used as it was built.

    env = vpro_assets.wrap(OffScreenRenderEnv(**env_args), case)   # case id, catalog record, or a pack's case JSON
    for episode in range(num_trials):
        env.reset()
        obs = env.set_init_state(initial_states[episode])           # trial = episode, automatically
        ...
        obs, reward, done, info = env.step(action)
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.packs import fork_runtime
from vpro_assets.packs.fork_runtime import ForkEnv


def with_task_record(case: Mapping, catalog: Mapping) -> dict:
    """The case with its task's record (`task_record`), as packs carry it."""
    case = dict(case)
    if "task_record" not in case:
        case["task_record"] = next(t for t in catalog["tasks"] if t["key"] == case["task"])
    return case


def resolve_case(case: Mapping | str | os.PathLike) -> dict:
    """A case dict with its task record, from a case id, a catalog record or a pack's case JSON."""
    if isinstance(case, Mapping) or str(case).endswith(".json"):
        loaded = fork_runtime.load_case(case)
        if "task_record" in loaded:
            return loaded
        return with_task_record(loaded, load_catalog(paths.catalog_path()))
    catalog = load_catalog(paths.catalog_path())
    return with_task_record(find_case(catalog, str(case)), catalog)


def wrap(env, case: Mapping | str | os.PathLike) -> ForkEnv:
    """Wrap a fork's LIBERO env so its observations follow `case` (an observation-level case)."""
    return fork_runtime.wrap(env, resolve_case(case))
