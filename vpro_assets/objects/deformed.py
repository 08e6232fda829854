"""Target Geometry Variation: a LIBERO target object, deformed, as a LIBERO object with exports.

`generate_deformed_object(category, deformation, severity, out_dir)` is a pure function of its
arguments and LIBERO's asset files:

1. load the object's visual meshes from its MJCF file in LIBERO's assets (`vpro_assets.geometry.meshes`);
2. make the solid: each part a closed 2-manifold through manifold3d (`vpro_assets.geometry.solid`, which
   reports how: merge, hole filling or level-set remesh), parts joined by boolean union;
3. deform solid and visual meshes with the same map (`vpro_assets.geometry.deform`: taper, multipeak,
   twist, asymmetric; magnitudes from the taxonomy's GEOMETRY_SEVERITY) about the object's up
   axis in LIBERO's scenes (UP_AXES, measured by `scripts/measure_up_axes.py`);
4. decompose the deformed solid into convex hulls with coacd (`vpro_assets.geometry.convex`, fixed seed);
5. write the MJCF object (visual meshes with the original textures, hulls, the original object's
   mass as LIBERO computes it, the inertia of the deformed solid, LIBERO's placement sites), a
   USD stage and a URDF; every file at fixed precision, named by its content, written atomically.

Output layout under `out_dir` (every path below is listed with its sha256 in the result):
    <name>/<name>.xml, <name>/<name>.urdf, <name>/<name>.usda, <name>/record.json
    <name>/meshes/visual<i>_<sha>.obj, solid_<sha>.obj, hull_<sha>.obj
    textures/<texture stem>_<sha>.png          (shared by every object made from one texture)
with `<name>` = `vpro_<category>_<deformation>_s<severity>_v<setting version>` (the taxonomy's
GEOMETRY_VERSIONS: a deformation whose map changes gets a new version, the others keep their names).
A target fitted to an enclosed receptacle (`fit_scale` < 1, a multiple of FIT_STEP chosen by the
scene generator, `generators/geometry_scene.py`) is the same deformation with the whole mesh then
scaled uniformly about the bottom of its up axis: an object of its own, `<name>_fit<scale in
hundredths>`, with `fit_scale` in its input key (unfitted objects keep their names, keys and bytes).

Visual meshes keep the original texture coordinates and carry their normals through the map
(n' = J^-T n); the collision hulls, the solid and the exports are built from the deformed solid.

An object whose inputs (the source files' bytes, the parameters, the pipeline's output version
(`PIPELINE_ID`) and the versions of trimesh, manifold3d, coacd, numpy, usd-core and mujoco) are unchanged
is not regenerated: `record.json` keeps the key of its inputs and the sha256 of every file, and is
written last. Errors (`MeshError`, `InvalidParameterError`, `UnknownIdError`, all `VProError`)
name the object and leave nothing behind in `out_dir` but files of other objects.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import shutil
from collections.abc import Mapping
from importlib.metadata import version
from pathlib import Path

from vpro_assets.benchmark import taxonomy
from vpro_assets.benchmark.taxonomy import Setting
from vpro_assets.core import mjlog
from vpro_assets.core.atomic import publish_dir
from vpro_assets.core.errors import InvalidParameterError, UnknownIdError
from vpro_assets.core.hashing import sha256_file
from vpro_assets.core.lifetime import call_in_child
from vpro_assets.core.memory import peak_rss_mb
from vpro_assets.core.seeding import derive_seed
from vpro_assets.geometry.convex import CoacdParams
from vpro_assets.geometry.meshes import MeshError
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.objects.deformed_build import COACD_SIMPLIFY_FRACTION, REFINE_FRACTION, build_object
from vpro_assets.objects.deformed_record import GeneratedFile, GeneratedObject
from vpro_assets.objects.registry import content_sha256, register_mjcf_object

log = logging.getLogger(__name__)

GENERATOR = "target_geometry"
GENERATOR_VERSION = 1
# The pipeline's output version, part of every object's input key (field `code_sha256`), so a
# changed pipeline regenerates its objects. Until the package was split into layers it was computed
# from the pipeline's source files, which made every refactor (a moved module, a reformatted line)
# change every object's record.json and so its recorded tree hash. It is now this constant: the
# sha256 those sources had when it was frozen, so the objects in the lock keep their bytes. When an
# edit changes what the pipeline writes, replace it with a new value (the lock's hashes catch a
# forgotten change: `vpro build` + `vpro catalog verify --artifacts`).
PIPELINE_ID = "77fb18ff7455813316b98e65742d527946b10dca51682a70b3832d2b17b6dcf0"
SEVERITIES = (1, 2, 3)
FIT_STEP = 0.01  # a fit scale is a multiple of this (rounded down by the scene generator)
# The object's up axis in its own mesh frame once LIBERO places it (measured from LIBERO's scenes
# with scripts/measure_up_axes.py: every target category of a geometry case).
UP_AXES: Mapping[str, str] = {
    "akita_black_bowl": "+z",
    "alphabet_soup": "+y",
    "bbq_sauce": "+z",
    "black_book": "+z",
    "butter": "+z",
    "chocolate_pudding": "+z",
    "cream_cheese": "+z",
    "ketchup": "+y",
    "milk": "+y",
    "moka_pot": "+z",
    "orange_juice": "+y",
    "plate": "+z",
    "porcelain_mug": "+z",
    "salad_dressing": "+y",
    "tomato_sauce": "+y",
    "white_yellow_mug": "+z",
    "wine_bottle": "+z",
}


def object_name(category: str, deformation: str, severity: int, fit_scale: float = 1.0) -> str:
    # The setting's version, so a changed deformation (twist v2) renames only its own objects; a
    # fitted object (fit_scale < 1) is another object, named with its scale in hundredths.
    name = f"vpro_{category}_{deformation}_s{severity}_v{geometry_setting(deformation, severity).version}"
    return name if fit_scale == 1.0 else f"{name}_fit{check_fit_scale(fit_scale)}"


def check_fit_scale(fit_scale: float) -> int:
    """The fit scale in hundredths; it must be a multiple of FIT_STEP in (0, 1]."""
    steps = (
        round(fit_scale / FIT_STEP) if isinstance(fit_scale, (int, float)) and not isinstance(fit_scale, bool) else 0
    )
    if not (0 < steps <= round(1 / FIT_STEP) and abs(steps * FIT_STEP - fit_scale) < 1e-9):
        raise InvalidParameterError(f"fit scale {fit_scale!r} is not a multiple of {FIT_STEP} in (0, 1]")
    return steps


def geometry_setting(deformation: str, severity: int) -> Setting:
    """The taxonomy's setting for (deformation, severity)."""
    for setting in taxonomy.settings_of("target_geometry_variation"):
        params = setting.param_dict
        if params.get("deformation") == deformation and params.get("severity") == severity:
            return setting
    known = sorted({str(s.param_dict["deformation"]) for s in taxonomy.settings_of("target_geometry_variation")})
    if deformation not in known:
        raise InvalidParameterError(f"deformation {deformation!r} is not one of {', '.join(known)}")
    raise InvalidParameterError(f"severity {severity!r} is not one of {SEVERITIES}")


def libero_object_xml(category: str) -> Path:
    """The MJCF file of LIBERO's object `category` (through LIBERO's own object class)."""
    objects = libero_bridge.libero_envs().OBJECTS_DICT
    if category not in objects:
        raise UnknownIdError("LIBERO object", category, objects)
    return Path(objects[category]().file)


def up_axis(category: str) -> str:
    if category not in UP_AXES:
        raise InvalidParameterError(
            f"object {category!r} has no measured up axis; add it to UP_AXES after running scripts/measure_up_axes.py"
        )
    return UP_AXES[category]


def _versions() -> dict[str, str]:
    return {pkg: version(pkg) for pkg in ("trimesh", "manifold3d", "coacd", "numpy", "usd-core", "mujoco")}


def input_key(
    category: str, deformation: str, severity: int, coacd_params: CoacdParams, xml_path: Path, fit_scale: float = 1.0
) -> dict:
    setting = geometry_setting(deformation, severity)
    fit = {} if fit_scale == 1.0 else {"fit_scale": fit_scale}  # unfitted objects keep their keys
    return {
        "generator": GENERATOR,
        "generator_version": GENERATOR_VERSION,
        "category": category,
        "setting": setting.id,
        "params": setting.param_dict,
        "up_axis": up_axis(category),
        "source_xml": xml_path.name,
        "source_sha256": content_sha256(xml_path),
        "coacd": coacd_params.to_json(),
        "refine_fraction": REFINE_FRACTION,
        "coacd_simplify_fraction": COACD_SIMPLIFY_FRACTION,
        "versions": _versions(),
        "code_sha256": PIPELINE_ID,
        **fit,
    }


def default_coacd_params(category: str, deformation: str, severity: int, **overrides) -> CoacdParams:
    seed = derive_seed(GENERATOR, category, deformation, severity, "coacd")
    return CoacdParams(**{**overrides, "seed": overrides.get("seed", seed)})


def generate_deformed_object(
    category: str,
    deformation: str,
    severity: int,
    out_dir: Path | str,
    *,
    coacd_params: CoacdParams | None = None,
    force: bool = False,
    fit_scale: float = 1.0,
    isolate: bool = False,
) -> GeneratedObject:
    """Generate (or reuse, when its inputs are unchanged) the deformed object, scaled by `fit_scale`
    (a multiple of FIT_STEP, 1: not fitted); see the module doc. `isolate`: generate in a child
    process (`_generate_in_child`); the check for a current object stays in this one."""
    out_dir = Path(out_dir)
    setting = geometry_setting(deformation, severity)
    xml_path = libero_object_xml(category)
    coacd_params = coacd_params or default_coacd_params(category, deformation, severity)
    key = input_key(category, deformation, severity, coacd_params, xml_path, fit_scale)
    name = object_name(category, deformation, severity, fit_scale)
    if not force:
        cached = load_generated(out_dir, name, key)
        if cached is not None:
            return cached
    if isolate:
        return _generate_in_child(category, deformation, severity, out_dir, coacd_params, fit_scale)
    staging = out_dir / f".staging-{name}-{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    try:
        result = build_object(
            name=name,
            category=category,
            deformation=deformation,
            severity=severity,
            setting=setting,
            xml_path=xml_path,
            up=up_axis(category),
            coacd_params=coacd_params,
            key=key,
            staging=staging,
            out_dir=out_dir,
            fit_scale=fit_scale,
        )
        publish_dir(staging, out_dir / name)
    except MeshError as exc:
        shutil.rmtree(staging, ignore_errors=True)
        raise MeshError(f"{name}: {exc}") from exc
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return result


def _generate_in_child(
    category: str, deformation: str, severity: int, out_dir: Path, coacd_params: CoacdParams, fit_scale: float
) -> GeneratedObject:
    """Generate in a fresh process, which exits when done. coacd, manifold3d and USD keep about
    230 MB in a process that ran them (shared libraries' pages, malloc arenas, threads' stacks:
    docs/benchmarks.md, "Memory of a build worker"), which a scene-build worker would otherwise
    carry through every case after its first deformed object. Spawned, not forked: the worker
    holds MuJoCo models and threads a fork would copy. The child dies with the worker (a killed
    build leaves no coacd running: `core.lifetime`). The child imports `vpro_assets` first, so
    its numpy kernels are pinned as this process's are (the bytes are the same: tested)."""
    return call_in_child(
        _generate_measured,
        category,
        deformation,
        severity,
        out_dir,
        coacd_params=coacd_params,
        force=True,  # the caller found no current object
        fit_scale=fit_scale,
    )


def _generate_measured(*args, **kwargs) -> GeneratedObject:
    """`generate_deformed_object` with this (child) process's peak memory in the result."""
    mjlog.route_warnings()
    return dataclasses.replace(generate_deformed_object(*args, **kwargs), peak_rss_mb=peak_rss_mb())


def load_generated(out_dir: Path | str, name: str, key: dict | None = None) -> GeneratedObject | None:
    """The object recorded in `out_dir/name/record.json` if its files are intact (and its input key
    equals `key`, when given); None otherwise."""
    out_dir = Path(out_dir)
    record_path = out_dir / name / "record.json"
    if not record_path.is_file():
        return None
    try:
        record = json.loads(record_path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if key is not None and record.get("input_key") != json.loads(json.dumps(key)):
        return None
    files = [GeneratedFile(**f) for f in record["files"]]
    for f in files:
        path = out_dir / f.path
        if not path.is_file() or sha256_file(path) != f.sha256:
            log.info("%s: %s is missing or changed; regenerating", name, f.path)
            return None
    files.append(GeneratedFile(f"{name}/record.json", sha256_file(record_path), "record"))
    return GeneratedObject(
        name,
        record["category"],
        record["deformation"],
        record["severity"],
        record["setting"],
        out_dir,
        tuple(files),
        record,
        cached=True,
    )


def register_generated(obj: GeneratedObject) -> type:
    """Register the object with LIBERO under its name, placed like the object it deforms."""
    return register_mjcf_object(obj.name, obj.xml_path, template=obj.category)
