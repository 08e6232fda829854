"""Measure each geometry target's up axis in its own mesh frame, as LIBERO places it.

For every target category of a Target Geometry Variation case, builds the first task whose target
has that category, resets it, and maps the world's up direction into the object's frame through
the body's orientation. Prints the `UP_AXES` table of `vpro_assets/objects/deformed.py`.

    .venv/bin/python scripts/measure_up_axes.py
"""

from __future__ import annotations

import json

import numpy as np


def main() -> None:
    import mujoco

    from vpro_assets.core import paths
    from vpro_assets.libero import bridge as libero_bridge
    from vpro_assets.libero.tasks import get_task

    catalog = json.loads(paths.catalog_path().read_text())
    tasks = {}
    for case in catalog["cases"]:
        if case["category"] == "target_geometry_variation":
            task = get_task(case["task"])
            tasks.setdefault(task.target_category, task)
    envs = libero_bridge.libero_envs()
    table = {}
    for category, task in sorted(tasks.items()):
        env = envs.OffScreenRenderEnv(
            bddl_file_name=str(libero_bridge.bddl_path(task.suite, task.name)),
            has_renderer=False,
            has_offscreen_renderer=False,
            use_camera_obs=False,
        )
        try:
            env.reset()
            quat = env.sim.data.body_xquat[env.sim.model.body_name2id(f"{task.target}_main")]
            rotation = np.zeros(9)
            mujoco.mju_quat2Mat(rotation, quat)
            up = rotation.reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])
        finally:
            env.close()
        axis = int(np.argmax(np.abs(up)))
        note = "" if abs(up[axis]) >= 0.99 else f"  # tilted: {np.round(up, 3).tolist()}"
        table[category] = (("+" if up[axis] > 0 else "-") + "xyz"[axis], note)
    print("UP_AXES = {")
    for category, (axis, note) in table.items():
        print(f'    "{category}": "{axis}",{note}')
    print("}")


if __name__ == "__main__":
    main()
