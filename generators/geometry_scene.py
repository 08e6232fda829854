"""Target Geometry Variation, the scene part: the task with its target replaced by the deformed
object of the geometry pipeline (`vpro_assets.objects.deformed`, which owns meshes, hulls and
exports). The target keeps its instance name, so the language and goal are unchanged; only its
category in the BDDL becomes the registered deformed object. Trials start from LIBERO's initial
state of the same index with the deformed target lowered onto the table at the same place."""

from __future__ import annotations

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.objects import deformed as tg
from vpro_assets.scene.context import GenContext
from vpro_assets.scene.plugins import register
from vpro_assets.scene.variant import GeneratedObject, Placement, SceneVariant


def _deformed(category: str, deformation: str, severity: int) -> GeneratedObject:
    return GeneratedObject(
        name=tg.object_name(category, deformation, severity),
        # Returns the pipeline's record (xml_path, and per-stage timings the build adds up).
        write=lambda root: tg.generate_deformed_object(category, deformation, severity, root),
        template=category,
        shared=True,
    )


def _make(deformation: str, severity: int):
    def generate(ctx: GenContext) -> SceneVariant:
        target, category = ctx.task.target, ctx.task.target_category
        obj = _deformed(category, deformation, severity)
        objects = [(i, obj.name if i == target else c) for i, c in ctx.base.bddl.objects]
        return SceneVariant(
            case_id=ctx.case_id,
            generator=f"target_geometry_variation/{deformation}-s{severity}",
            summary=f"{target} replaced by {obj.name} ({deformation}, severity {severity})",
            objects=objects,
            fixtures=list(ctx.base.bddl.fixtures),
            init=ctx.init_with(),
            placements=[Placement(target, (0.0, 0.0), keep_xy=True)],
            generated_objects=[obj],
            details={"target": target, "deformed_object": obj.name},
        )

    generate.__doc__ = f"The target replaced by its {deformation} deformation at severity {severity}."
    return generate


for _deformation, (_param, _amounts) in tx.GEOMETRY_SEVERITY.items():
    for _severity in range(1, len(_amounts) + 1):
        register(f"target_geometry_variation/{_deformation}-s{_severity}")(_make(_deformation, _severity))
