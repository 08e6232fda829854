"""A gallery of every built scene variant of a task: one labelled contact sheet (PNG)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vpro_assets.core.images import label, write_png
from vpro_assets.libero.env import libero_init_states, make_env
from vpro_assets.libero.init_states import read_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene.build import built_case


def _render(task, bddl: str | None, state: np.ndarray, resolution: int) -> np.ndarray:
    env = make_env(task, resolution, bddl_file=bddl)
    try:
        env.reset()
        obs = env.set_init_state(state)
        return np.ascontiguousarray(obs["agentview_image"][::-1])
    finally:
        env.close()


def write_gallery(catalog: dict, task_key: str, out: Path, resolution: int = 256, columns: int = 5) -> int:
    task = get_task(task_key)
    panels = [label(_render(task, None, libero_init_states(task)[0], resolution), "normal")]
    for case in catalog["cases"]:
        if case["task"] != task.key or case.get("level") != "scene":
            continue
        try:
            found = built_case(case["id"])
        except Exception:
            continue
        state = read_init_states(found["init_states"])[0]
        cat, name = case["setting"].removeprefix("vpro/").split("/", 1)
        name = f"{cat.split('_')[-1]}/{name.rsplit('-v', 1)[0]}"
        panels.append(label(_render(task, str(found["bddl"]), state, resolution), name))
    if len(panels) == 1:
        return 0
    rows = math.ceil(len(panels) / columns)
    blank = np.zeros_like(panels[0])
    grid = [
        np.concatenate((panels + [blank] * (rows * columns - len(panels)))[r * columns : (r + 1) * columns], axis=1)
        for r in range(rows)
    ]
    write_png(out, np.concatenate(grid, axis=0))
    return len(panels) - 1
