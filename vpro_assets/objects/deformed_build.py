"""The build stages of `vpro_assets.objects.deformed`, one object into a staging folder:

1. `repair_solid`: the original solid, a closed 2-manifold, refined, and its upright frame;
2. `deform`: solid and visual meshes deformed by one map;
3. `convex_hulls`: convex decomposition of the (simplified) deformed solid;
4. `mesh_files`, `object_files`: every file's bytes (meshes, MJCF, URDF, USD), and
5. `object_record`, `write_files`: the record (measures, every file's sha256), then the files,
   the record last (both in `vpro_assets.objects.deformed_files`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import manifold3d
import mujoco
import numpy as np
import trimesh

from vpro_assets.benchmark.taxonomy import Setting
from vpro_assets.geometry import deform as deform_mod
from vpro_assets.geometry.convex import CoacdParams, decompose, split_support_hulls
from vpro_assets.geometry.meshes import MeshError, load_libero_object
from vpro_assets.geometry.refine import refine_soup
from vpro_assets.geometry.solid import check_closed_manifold, manifold_arrays, repair_part, union
from vpro_assets.objects.deformed_files import mesh_files, object_files, object_record, write_files
from vpro_assets.objects.deformed_record import Deformed, GeneratedObject, Original
from vpro_assets.objects.mjcf import drop_test_xml

log = logging.getLogger(__name__)

REFINE_FRACTION = 1.0 / 20.0  # meshes refined to edges under this fraction of the object's size
COACD_SIMPLIFY_FRACTION = 1.0 / 250.0  # the solid given to coacd is simplified within this


def libero_mass(xml_path: Path) -> float:
    """The object's mass as LIBERO simulates it: robosuite counts only group-0 geoms."""
    model = mujoco.MjModel.from_xml_string(drop_test_xml(xml_path))
    return float(model.body_subtreemass[model.body("object").id])


def repair_solid(category: str, xml_path: Path, up: str) -> Original:
    source = load_libero_object(category, xml_path)
    repaired, reports = [], []
    for part in source.parts:
        manifold, report = repair_part(f"{category}/{part.name}", part.corners)
        repaired.append(manifold)
        reports.append(report)
    solid = union(repaired)
    v0, f0 = manifold_arrays(solid)
    extent = float((v0.max(axis=0) - v0.min(axis=0)).max())
    max_edge = extent * REFINE_FRACTION
    solid = solid.refine_to_length(max_edge)
    v0, f0 = manifold_arrays(solid)
    frame = deform_mod.upright_frame(up, v0, _centroid(v0, f0))
    return Original(source, solid, v0, f0, reports, extent, max_edge, frame)


def deform(
    original: Original, deformation: str, amount: float, what: str, fit_scale: float = 1.0, **extra: float
) -> Deformed:
    """Solid and visual meshes through the deformation's map, then (`fit_scale` < 1) scaled uniformly
    about the bottom point of the up axis: the fit of a target to an enclosed receptacle
    (`vpro_assets.objects.deformed`), which keeps the deformation's shape and its bottom plane."""
    warp = deform_mod.deformation_map(deformation, amount, original.frame, **extra)
    if fit_scale != 1.0:
        warp = deform_mod.scaled(warp, fit_scale, original.frame.origin)
    solid = original.solid.warp_batch(lambda points: warp(np.asarray(points)))
    if solid.status() != manifold3d.Error.NoError or solid.volume() <= 0:
        raise MeshError(f"{what} broke the solid ({solid.status()})")
    v1, f1 = manifold_arrays(solid)
    visual_parts = []
    for part in original.source.parts:
        corners, uv, normals = refine_soup(part.corners, part.uv, original.max_edge, part.normals)
        flat = corners.reshape(-1, 3)
        if normals is not None:
            normals = deform_mod.transform_normals(flat, normals.reshape(-1, 3), warp).reshape(-1, 3, 3)
        visual_parts.append((part, warp(flat).reshape(-1, 3, 3), uv, normals))
    return Deformed(warp, solid, v1, f1, visual_parts, fit_scale)


def convex_hulls(original: Original, deformed: Deformed, coacd_params: CoacdParams, what: str) -> list[trimesh.Trimesh]:
    v_simple, f_simple = manifold_arrays(deformed.solid.simplify(original.extent * COACD_SIMPLIFY_FRACTION))
    hulls = decompose(v_simple, f_simple, coacd_params, what)
    rotation = original.frame.rotation
    return split_support_hulls(hulls, rotation[2], (rotation[0], rotation[1]), what)


def build_object(
    *,
    name: str,
    category: str,
    deformation: str,
    severity: int,
    setting: Setting,
    xml_path: Path,
    up: str,
    coacd_params: CoacdParams,
    key: dict,
    staging: Path,
    out_dir: Path,
    fit_scale: float = 1.0,
) -> GeneratedObject:
    """Run the stages for one object; its folder goes to `staging`, shared textures to `out_dir`."""
    timings: dict[str, float] = {}
    with _timed(timings, "manifold_repair"):
        original = repair_solid(category, xml_path, up)
        amount = deform_mod.amount_of(deformation, setting.param_dict)
        extra = deform_mod.extra_params_of(deformation, setting.param_dict)
    with _timed(timings, "deformation"):
        what = f"{category}: {deformation} severity {severity}"
        deformed = deform(original, deformation, amount, what, fit_scale, **extra)
    with _timed(timings, "coacd"):
        hulls = convex_hulls(original, deformed, coacd_params, f"{category} {deformation} s{severity}")
    with _timed(timings, "write"):
        out = mesh_files(name, deformed, hulls)
        mass = libero_mass(xml_path)
        object_files(name, original, deformed, out, mass)
        check_closed_manifold(*_quantized_arrays(out.solid_bytes), f"{name} solid mesh as written")
        header = {"name": name, "category": category, "deformation": deformation, "severity": severity}
        header |= {"setting": setting.id, "amount": amount, "up_axis": up, "input_key": key}
        if fit_scale != 1.0:
            header["fit_scale"] = fit_scale
        record = object_record(header, original, deformed, len(hulls), out, mass)
        files = write_files(name, out, record, staging, out_dir)
    log.info("%s (%d hulls): %s", name, len(hulls), ", ".join(f"{k} {v:.1f}s" for k, v in timings.items()))
    return GeneratedObject(
        name, category, deformation, severity, setting.id, out_dir, tuple(files), record, timings=timings
    )


@contextmanager
def _timed(timings: dict[str, float], stage: str) -> Iterator[None]:
    """Add the seconds the block takes to `timings[stage]`."""
    start = time.perf_counter()
    yield
    timings[stage] = time.perf_counter() - start


def _centroid(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    return np.asarray(trimesh.Trimesh(vertices, faces, process=False).center_mass, np.float64)


def _quantized_arrays(obj_data: bytes) -> tuple[np.ndarray, np.ndarray]:
    lines = obj_data.decode().splitlines()
    vertices = np.array([[float(x) for x in ln.split()[1:4]] for ln in lines if ln.startswith("v ")])
    faces = np.array([[int(x) - 1 for x in ln.split()[1:4]] for ln in lines if ln.startswith("f ")])
    return vertices, faces
