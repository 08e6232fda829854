"""Measure the deformed targets of the cases the receptacle fit concerns, as built.

For every built Target Geometry Variation case whose goal puts the target into an openable fixture's
region (`generators.geometry_scene.fits_receptacle`): the rule's own figures from the case's
meta.json (the room, the original target, the unfitted deformed target at rest, what is allowed,
the fit scale, the fitted target at rest) beside the room and the target measured in the built
scene itself (`receptacle.clearance`, and `receptacle.object_size` of the target's collision geoms,
in the case's first initial state, as the trials start) and the room that leaves. Prints the table
of docs/geometry.md, "Fit to an enclosed receptacle" (lengths in cm, the room left in mm).

    VPRO_OUT=... .venv/bin/python scripts/measure_fits.py
"""

from __future__ import annotations

import json


def main() -> None:
    from generators import geometry_scene as gs
    from vpro_assets.core import paths
    from vpro_assets.libero.init_states import read_init_states
    from vpro_assets.libero.tasks import get_task
    from vpro_assets.scene import sim
    from vpro_assets.scene.build import built_case
    from vpro_assets.scene.receptacle import clearance, object_size

    catalog = json.loads(paths.catalog_path().read_text())
    cases = sorted(
        (c for c in catalog["cases"] if c["category"] == "target_geometry_variation" and gs.fits_receptacle(c)),
        key=lambda c: c["task"],
    )

    def cm(size: dict) -> str:
        return f"{100 * size['reach']:.2f} / {100 * size['height']:.2f}"

    print(
        "| case | deformed, unfitted (cm) | allowed (cm) | fit scale | fitted (cm) "
        "| built: room, radius / height (cm) | built: target, reach / height (cm) | room left (mm) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for case in cases:
        found = built_case(case["id"])
        fit = found["meta"]["details"]["fit"]
        env = sim.physics_env(str(found["bddl"]))
        try:
            sim.load_state(env, read_init_states(found["init_states"])[0])
            raw = sim.raw(env)
            model, data = raw.sim.model._model, raw.sim.data._data
            room = clearance(model, data, fit["room"]["region"])
            reach, height = object_size(model, data, f"{get_task(case['task']).target}_main")
        finally:
            env.close()
        scale = fit["fit_scale"]
        print(
            f"| {case['id']} | {cm(fit['deformed'])} | {cm(fit['allowed'])} "
            f"| {'**' if scale < 1 else ''}{scale:.2f}{'**' if scale < 1 else ''} "
            f"| {cm(fit.get('fitted', fit['deformed']))} | {100 * room.radius:.2f} / {100 * room.height:.2f} "
            f"| {100 * reach:.2f} / {100 * height:.2f} "
            f"| {1000 * (room.radius - reach):.1f} / {1000 * (room.height - height):.1f} |"
        )


if __name__ == "__main__":
    main()
