"""The build stages of `vpro_assets.objects.deformed`, one object into a staging folder:

1. `repair_solid`: the original solid, a closed 2-manifold, refined, and its upright frame;
2. `deform`: solid and visual meshes deformed by one map;
3. `convex_hulls`: convex decomposition of the (simplified) deformed solid;
4. `mesh_files`, `object_files`: every file's bytes (meshes, MJCF, URDF, USD);
5. `object_record`, `write_files`: the record (measures, every file's sha256), then the files,
   the record last.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import manifold3d
import mujoco
import numpy as np
import trimesh

from vpro_assets.benchmark.taxonomy import Setting
from vpro_assets.core.atomic import write_bytes_atomic
from vpro_assets.core.hashing import canonical_json, sha256_bytes
from vpro_assets.geometry import deform as deform_mod
from vpro_assets.geometry.convex import CoacdParams, decompose, split_support_hulls
from vpro_assets.geometry.meshes import (
    LiberoObjectSource,
    MeshError,
    MeshPart,
    content_name,
    load_libero_object,
    normals_to_indexed,
    obj_bytes,
    soup_to_indexed,
)
from vpro_assets.geometry.refine import refine_soup
from vpro_assets.geometry.solid import RepairReport, check_closed_manifold, manifold_arrays, repair_part, union
from vpro_assets.objects.deformed_record import GeneratedFile, GeneratedObject
from vpro_assets.objects.exporters import ExportMesh, urdf_text, usd_text
from vpro_assets.objects.mjcf import Inertial, VisualMesh, drop_test_xml, object_xml, solid_inertial

log = logging.getLogger(__name__)

REFINE_FRACTION = 1.0 / 20.0  # meshes refined to edges under this fraction of the object's size
COACD_SIMPLIFY_FRACTION = 1.0 / 250.0  # the solid given to coacd is simplified within this


@dataclass
class Original:
    """Stage 1: the source object and its solid, refined to edges under `max_edge`."""

    source: LiberoObjectSource
    solid: manifold3d.Manifold
    vertices: np.ndarray
    faces: np.ndarray
    reports: list[RepairReport]
    extent: float  # largest extent of the solid, m
    max_edge: float
    frame: deform_mod.UprightFrame


@dataclass
class Deformed:
    """Stage 2: the deformed solid and visual parts (part, corners, uv, normals)."""

    warp: Callable[[np.ndarray], np.ndarray]
    solid: manifold3d.Manifold
    vertices: np.ndarray
    faces: np.ndarray
    visual_parts: list[tuple[MeshPart, np.ndarray, np.ndarray | None, np.ndarray | None]]


@dataclass
class Files:
    """Stage 4: bytes of every file of the object folder, and the shared textures it uses."""

    files: dict[str, tuple[bytes, str]] = field(default_factory=dict)  # folder-relative path -> (bytes, role)
    textures: dict[str, tuple[Path, str]] = field(default_factory=dict)  # out_dir-relative path -> (source, sha)
    visuals: list[VisualMesh] = field(default_factory=list)
    export_visuals: list[ExportMesh] = field(default_factory=list)
    hull_files: list[str] = field(default_factory=list)
    export_hulls: list[ExportMesh] = field(default_factory=list)
    hull_volume: float = 0.0
    solid_bytes: bytes = b""


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


def deform(original: Original, deformation: str, amount: float, what: str) -> Deformed:
    warp = deform_mod.deformation_map(deformation, amount, original.frame)
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
    return Deformed(warp, solid, v1, f1, visual_parts)


def convex_hulls(original: Original, deformed: Deformed, coacd_params: CoacdParams, what: str) -> list[trimesh.Trimesh]:
    v_simple, f_simple = manifold_arrays(deformed.solid.simplify(original.extent * COACD_SIMPLIFY_FRACTION))
    hulls = decompose(v_simple, f_simple, coacd_params, what)
    rotation = original.frame.rotation
    return split_support_hulls(hulls, rotation[2], (rotation[0], rotation[1]), what)


def mesh_files(name: str, deformed: Deformed, hulls: list[trimesh.Trimesh]) -> Files:
    """Visual meshes (with their textures), the solid and the hulls as content-named OBJ files."""
    out = Files()
    for i, (part, corners, uv, normals) in enumerate(deformed.visual_parts):
        vertices, faces, uv_vals, uv_faces = soup_to_indexed(corners, uv)
        normal_vals, normal_faces = (None, None) if normals is None else normals_to_indexed(normals)
        data = obj_bytes(
            vertices,
            faces,
            uv_vals,
            uv_faces,
            header=f"{name} visual {i}: {part.name} deformed",
            normals=normal_vals,
            normal_faces=normal_faces,
        )
        mesh_file = f"meshes/{content_name(f'visual{i}', data, '.obj')}"
        out.files[mesh_file] = (data, "visual_mesh")
        texture_rel = None
        if part.texture_file is not None:
            tex_bytes = part.texture_file.read_bytes()
            tex_name = content_name(part.texture_file.stem, tex_bytes, part.texture_file.suffix.lower())
            out.textures[f"textures/{tex_name}"] = (part.texture_file, sha256_bytes(tex_bytes))
            texture_rel = f"../textures/{tex_name}"
        out.visuals.append(VisualMesh(mesh_file, part.material, texture_rel, part.texture_attrs))
        out.export_visuals.append(
            ExportMesh(f"visual{i}", mesh_file, vertices, faces, uv_vals, uv_faces, _rgba(part.material), texture_rel)
        )
    out.solid_bytes = obj_bytes(deformed.vertices, deformed.faces, header=f"{name} closed solid (manifold3d), metres")
    out.files[f"meshes/{content_name('solid', out.solid_bytes, '.obj')}"] = (out.solid_bytes, "solid_mesh")
    for k, hull in enumerate(hulls):
        data = obj_bytes(np.asarray(hull.vertices), np.asarray(hull.faces), header=f"{name} convex hull")
        hull_file = f"meshes/{content_name('hull', data, '.obj')}"
        out.files[hull_file] = (data, "hull_mesh")
        out.hull_files.append(hull_file)
        out.export_hulls.append(
            ExportMesh(f"hull{k:02d}", hull_file, np.asarray(hull.vertices), np.asarray(hull.faces))
        )
        out.hull_volume += float(hull.volume)
    return out


def _rgba(material: dict[str, str]) -> tuple[float, float, float, float] | None:
    if "rgba" not in material:
        return None
    r, g, b, a = (float(x) for x in material["rgba"].split())
    return r, g, b, a


def object_files(name: str, original: Original, deformed: Deformed, out: Files, mass: float) -> Inertial:
    """Add the MJCF object (sites scaled with the deformed radius), URDF and USD; return the inertial."""
    inertial = solid_inertial(mass, deformed.vertices, deformed.faces)
    radius_ratio = _radius_ratio(original, deformed)
    sites = []
    for site in original.source.sites:
        site = dict(site)
        if site.get("name") == "horizontal_radius_site" and "pos" in site:
            pos = [float(x) for x in site["pos"].split()]
            site["pos"] = " ".join(f"{x:.6f}" for x in (pos[0] * radius_ratio, pos[1] * radius_ratio, pos[2]))
        sites.append(site)
    source = original.source
    out.files[f"{name}.xml"] = (
        object_xml(
            name,
            out.visuals,
            out.hull_files,
            mass / out.hull_volume,
            inertial,
            source.collision_attrs,
            sites,
            source.object_body_pos,
        ),
        "mjcf",
    )
    out.files[f"{name}.urdf"] = (urdf_text(name, out.export_visuals, out.export_hulls, inertial).encode(), "urdf")
    out.files[f"{name}.usda"] = (usd_text(name, out.export_visuals, out.export_hulls, inertial).encode(), "usd")
    return inertial


def object_record(
    header: dict[str, Any], original: Original, deformed: Deformed, hull_count: int, out: Files, mass: float
) -> dict:
    """The object's record: `header` (names, setting, input key), repairs, measures (no file list yet)."""
    frame, solid0, solid = original.frame, original.solid, deformed.solid
    ext0, ext1 = _upright_extents(frame, original.vertices), _upright_extents(frame, deformed.vertices)
    return {
        **header,
        "repair": [r.__dict__ for r in original.reports],
        "measures": {
            "original_volume_m3": _r(solid0.volume()),
            "volume_m3": _r(solid.volume()),
            "volume_ratio": _r(solid.volume() / solid0.volume()),
            "original_extents_m": [_r(x) for x in ext0],
            "extents_m": [_r(x) for x in ext1],
            "extent_ratios": [_r(x) for x in ext1 / ext0],
            "max_radius_ratio": _r(_radius_ratio(original, deformed)),
            "mean_displacement": _r(
                deform_mod.displacement_measure(original.vertices, deformed.warp, float(np.linalg.norm(ext0)))
            ),
            "hull_count": hull_count,
            "hull_volume_ratio": _r(out.hull_volume / solid.volume()),
            "mass_kg": _r(mass),
            "solid_faces": int(len(deformed.faces)),
            "visual_faces": int(sum(len(c) for _p, c, _u, _n in deformed.visual_parts)),
        },
    }


def write_files(name: str, out: Files, record: dict, staging: Path, out_dir: Path) -> list[GeneratedFile]:
    """Write the object folder into `staging` (the record last: it marks the object complete) and
    the shared textures into `out_dir`; return every file with its sha256."""
    file_list = [
        GeneratedFile(f"{name}/{path}", sha256_bytes(data), role) for path, (data, role) in sorted(out.files.items())
    ]
    file_list += [GeneratedFile(path, sha, "texture") for path, (_src, sha) in sorted(out.textures.items())]
    record["files"] = [f.__dict__ for f in file_list]
    record_bytes = canonical_json(record).encode()
    for path, (data, _role) in out.files.items():
        write_bytes_atomic(staging / path, data)
    for path, (src, sha) in out.textures.items():
        target = out_dir / path
        if not target.is_file() or sha256_bytes(target.read_bytes()) != sha:
            write_bytes_atomic(target, src.read_bytes())
    write_bytes_atomic(staging / "record.json", record_bytes)
    file_list.append(GeneratedFile(f"{name}/record.json", sha256_bytes(record_bytes), "record"))
    return file_list


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
) -> GeneratedObject:
    """Run the stages for one object; its folder goes to `staging`, shared textures to `out_dir`."""
    what = f"{category} {deformation} s{severity}"
    timings: dict[str, float] = {}
    t = time.perf_counter()
    original = repair_solid(category, xml_path, up)
    amount = deform_mod.amount_of(deformation, setting.param_dict)
    timings["manifold_repair"], t = time.perf_counter() - t, time.perf_counter()
    deformed = deform(original, deformation, amount, f"{category}: {deformation} severity {severity}")
    timings["deformation"], t = time.perf_counter() - t, time.perf_counter()
    hulls = convex_hulls(original, deformed, coacd_params, what)
    timings["coacd"], t = time.perf_counter() - t, time.perf_counter()
    out = mesh_files(name, deformed, hulls)
    mass = libero_mass(xml_path)
    object_files(name, original, deformed, out, mass)
    check_closed_manifold(*_quantized_arrays(out.solid_bytes), f"{name} solid mesh as written")
    header = {
        "name": name,
        "category": category,
        "deformation": deformation,
        "severity": severity,
        "setting": setting.id,
        "amount": amount,
        "up_axis": up,
        "input_key": key,
    }
    record = object_record(header, original, deformed, len(hulls), out, mass)
    file_list = write_files(name, out, record, staging, out_dir)
    timings["write"] = time.perf_counter() - t
    log.info(
        "%s: repair %.1fs, deformation %.1fs, coacd %.1fs (%d hulls), write %.1fs",
        name,
        timings["manifold_repair"],
        timings["deformation"],
        timings["coacd"],
        len(hulls),
        timings["write"],
    )
    return GeneratedObject(
        name,
        category,
        deformation,
        severity,
        setting.id,
        out_dir,
        tuple(file_list),
        record,
        cached=False,
        timings=timings,
    )


def _upright_extents(frame: deform_mod.UprightFrame, vertices: np.ndarray) -> np.ndarray:
    p = frame.to_upright(vertices)
    return p.max(axis=0) - p.min(axis=0)


def _max_radius(frame: deform_mod.UprightFrame, vertices: np.ndarray) -> float:
    p = frame.to_upright(vertices)
    return float(np.linalg.norm(p[:, :2], axis=1).max())


def _radius_ratio(original: Original, deformed: Deformed) -> float:
    """Largest distance from the up axis, deformed over original."""
    return _max_radius(original.frame, deformed.vertices) / _max_radius(original.frame, original.vertices)


def _r(x: float) -> float:
    return float(f"{float(x):.6g}")


def _centroid(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    return np.asarray(trimesh.Trimesh(vertices, faces, process=False).center_mass, np.float64)


def _quantized_arrays(obj_data: bytes) -> tuple[np.ndarray, np.ndarray]:
    lines = obj_data.decode().splitlines()
    vertices = np.array([[float(x) for x in ln.split()[1:4]] for ln in lines if ln.startswith("v ")])
    faces = np.array([[int(x) - 1 for x in ln.split()[1:4]] for ln in lines if ln.startswith("f ")])
    return vertices, faces
