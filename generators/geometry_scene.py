"""Target Geometry Variation, the scene part: the task with its target replaced by the deformed
object of the geometry pipeline (`vpro_assets.objects.deformed`, which owns meshes, hulls and
exports). The target keeps its instance name, so the language and goal are unchanged; only its
category in the BDDL becomes the registered deformed object. Trials start from LIBERO's initial
state of the same index with the deformed target lowered onto the table at the same place.

Fit to an enclosed receptacle. Where the goal puts the target into a region of an openable fixture
(a drawer of a cabinet, a microwave: LIBERO's receptacles with a ceiling), the deformed target must
fit that region as the original does. The room is measured on the base scene as compiled
(`vpro_assets.scene.receptacle`: the height between the floor and the ceiling, and the horizontal
room about the region's centre where LIBERO's `In` and a policy put the object's body, an opened
drawer's mouth ending at the fixture's front over it), and so is the original target (its reach
from its vertical axis, its height, at rest in LIBERO's settled first state). The deformed target
may reach and stand at most
    allowed = max(original's, room - FIT_MARGIN_M)
along each, so it is never tighter than the original and never closer than FIT_MARGIN_M to the
receptacle where the original leaves more. Beyond that, the whole deformed mesh is scaled down
uniformly about the bottom of its axis (`fit_scale`, rounded down to a hundredth): the deformation
keeps its kind and severity (a multipeak-s3 bowl stays five-lobed with its 18% lobes, relative to
its radius), only its size goes. A fitted target is an object of its own (`..._fit81`), so every
other case keeps its object and bytes.

The deformed target is measured as the scene will hold it: the generated (unfitted) object itself,
its collision hulls (made from the visual mesh, about 3 mm wider than LIBERO's collision geoms of
the same bowl) at rest on a table (`receptacle.resting_size`, the same measure `object_size` takes
of the original in the scene). The scaling keeps the shape and the bottom, so reach and height
scale with it and the scale follows from that measure; the fitted object, as the build makes it
(coacd decomposes the scaled solid anew), is then measured the same way and taken a hundredth
smaller while it still oversteps. So the stated margin holds for the hulls the simulator collides.
Both sides of each comparison are collision geometry as MuJoCo has it at rest; `allowed` keeps the
original's own measure (LIBERO's collision geoms), so where it acts (a room the original leaves
less than FIT_MARGIN_M) the deformed target takes the room LIBERO's own collision bowl takes.
Every deformation keeps the height, so in LIBERO's receptacles the bound that acts is the reach:
libero_10-03's bottom drawer, opened, leaves 5.68 cm about its centre before the middle drawer's
front (LIBERO's bowl reaches 5.39 cm), so the bowls whose hulls reach farther than 5.43 cm
(multipeak, twist, asymmetric) are scaled to reach at most that (docs/geometry.md).

The fit is revision "fit2" of these generators for the cases it concerns (those whose goal puts the
target into an openable fixture, `fits_receptacle`): it enters their input hash, not their files
(fit1 measured the deformed target as LIBERO's collision bowl times the deformed solid's ratios,
which left the fitted bowls about 3 mm wider than stated).
"""

from __future__ import annotations

import math

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core import paths
from vpro_assets.libero.tasks import get_task
from vpro_assets.objects import deformed as tg
from vpro_assets.scene.context import GenContext
from vpro_assets.scene.plugins import register
from vpro_assets.scene.receptacle import Clearance, clearance, object_size, resting_size
from vpro_assets.scene.revisions import stuck_revision
from vpro_assets.scene.variant import GeneratedObject, Placement, SceneVariant

FIT_MARGIN_M = 0.0025  # the room a fitted target leaves where the original leaves more
# (LIBERO's black bowl in libero_10-03's bottom drawer: 2.9 mm of reach, 6.8 mm of height)
FIT_REVISION = "fit2"

Size = tuple[float, float]  # (reach from the vertical axis, height), metres


def _deformed(category: str, deformation: str, severity: int, fit_scale: float = 1.0) -> GeneratedObject:
    return GeneratedObject(
        name=tg.object_name(category, deformation, severity, fit_scale),
        # Returns the pipeline's record (xml_path, and per-stage timings the build adds up); a new
        # object is made in a child process, so what coacd leaves does not stay in the build worker.
        write=lambda root: tg.generate_deformed_object(
            category, deformation, severity, root, fit_scale=fit_scale, isolate=True
        ),
        template=category,
        shared=True,
    )


def fits_receptacle(case: dict) -> bool:
    """Whether the case's goal puts its target into a region of an openable fixture (the cases the
    fit concerns); from the task's BDDL alone."""
    task = get_task(case["task"])
    openable = {a.name for a in task.articulations if a.kind == "openable"}
    return task.placement_relation == "in" and task.receptacle in openable


def fit_revision(case: dict) -> str:
    return FIT_REVISION if fits_receptacle(case) else ""


def revision(case: dict) -> str:
    """The case's revisions: FIT_REVISION for a target fitted to an enclosed receptacle,
    STUCK_REVISION (`scene.revisions`) for one standing on a thin plate."""
    return " ".join(r for r in (fit_revision(case), stuck_revision(case)) if r)


def allowed(room: Clearance, original: Size) -> Size:
    """The most a deformed target may reach and stand in `room` (module doc)."""
    return max(original[0], room.radius - FIT_MARGIN_M), max(original[1], room.height - FIT_MARGIN_M)


def fits(room: Clearance, original: Size, size: Size) -> bool:
    reach, height = allowed(room, original)
    return size[0] <= reach and size[1] <= height


def fit_scale(room: Clearance, original: Size, deformed: Size) -> float:
    """The largest multiple of FIT_STEP (at most 1) that scales a deformed target of size `deformed`
    into what `room` allows (module doc)."""
    reach, height = allowed(room, original)
    scale = min(1.0, reach / deformed[0], height / deformed[1])
    return _steps(math.floor(scale / tg.FIT_STEP + 1e-9)) if scale < 1.0 else 1.0


def _steps(count: int) -> float:
    return round(count * tg.FIT_STEP, 6)  # 0.95, not 0.9500000000000001, in objects' keys and records


def _size_json(size: Size) -> dict:
    return {"reach": round(size[0], 4), "height": round(size[1], 4)}


def _fit(ctx: GenContext, category: str, deformation: str, severity: int) -> tuple[float, dict]:
    """The fit scale of the case's deformed target and what it was measured from."""
    task = ctx.task
    if not fits_receptacle(ctx.case):
        return 1.0, {}
    region = f"{task.receptacle}_{task.receptacle_region}"
    model, data = ctx.base.ray_scene
    room = clearance(model, data, region)
    if room is None:
        return 1.0, {}
    original = object_size(model, data, f"{task.target}_main")
    up = tg.up_axis(category)
    # The unfitted object: it is shared by the setting's other cases, so it is made (or found in
    # the cache) anyway.
    plain = tg.generate_deformed_object(category, deformation, severity, paths.objects_root(), isolate=True)
    deformed = resting_size(plain.xml_path, up)
    scale = fit_scale(room, original, deformed)
    fitted = deformed
    # The fitted object as the build will make it (found there in the cache), measured the same way.
    while scale < 1.0:
        made = tg.generate_deformed_object(
            category, deformation, severity, paths.objects_root(), fit_scale=scale, isolate=True
        )
        fitted = resting_size(made.xml_path, up)
        if fits(room, original, fitted) or tg.check_fit_scale(scale) == 1:
            break
        scale = _steps(tg.check_fit_scale(scale) - 1)
    return scale, {
        "room": {k: round(v, 4) if isinstance(v, float) else v for k, v in room.to_json().items()},
        "original": _size_json(original),
        "deformed": _size_json(deformed),
        "allowed": _size_json(allowed(room, original)),
        "fit_scale": scale,
        **({"fitted": _size_json(fitted)} if scale < 1.0 else {}),
    }


def _make(deformation: str, severity: int):
    def generate(ctx: GenContext) -> SceneVariant:
        target, category = ctx.task.target, ctx.task.target_category
        scale, fit = _fit(ctx, category, deformation, severity)
        obj = _deformed(category, deformation, severity, scale)
        objects = [(i, obj.name if i == target else c) for i, c in ctx.base.bddl.objects]
        fitted = f", scaled {scale:.2f} to fit {fit['room']['region']}" if scale < 1.0 else ""
        return SceneVariant(
            case_id=ctx.case_id,
            generator=f"target_geometry_variation/{deformation}-s{severity}",
            summary=f"{target} replaced by {obj.name} ({deformation}, severity {severity}{fitted})",
            objects=objects,
            fixtures=list(ctx.base.bddl.fixtures),
            init=ctx.init_with(),
            placements=[Placement(target, (0.0, 0.0), keep_xy=True)],
            generated_objects=[obj],
            details={"target": target, "deformed_object": obj.name, **({"fit": fit} if fit else {})},
        )

    generate.__doc__ = f"The target replaced by its {deformation} deformation at severity {severity}."
    return generate


for _deformation, (_param, _amounts) in tx.GEOMETRY_SEVERITY.items():
    for _severity in range(1, len(_amounts) + 1):
        register(f"target_geometry_variation/{_deformation}-s{_severity}", revision=revision)(
            _make(_deformation, _severity)
        )
