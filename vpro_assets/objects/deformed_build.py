"""The build steps of `vpro_assets.objects.deformed` (one object, into a staging folder)."""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from vpro_assets.objects.deformed import COACD_SIMPLIFY_FRACTION
from vpro_assets.objects.deformed import REFINE_FRACTION
from vpro_assets.objects.deformed import GeneratedFile
from vpro_assets.objects.deformed import GeneratedObject
from vpro_assets.geometry import deform as deform_mod
from vpro_assets.core.hashing import canonical_json
from vpro_assets.core.atomic import write_bytes_atomic
from vpro_assets.geometry.convex import CoacdParams
from vpro_assets.geometry.convex import decompose
from vpro_assets.geometry.convex import split_support_hulls
from vpro_assets.objects.exporters import ExportMesh
from vpro_assets.objects.exporters import urdf_text
from vpro_assets.objects.exporters import usd_text
from vpro_assets.geometry.meshes import MeshError
from vpro_assets.geometry.meshes import content_name
from vpro_assets.geometry.meshes import load_libero_object
from vpro_assets.geometry.meshes import normals_to_indexed
from vpro_assets.geometry.meshes import obj_bytes
from vpro_assets.geometry.meshes import sha256_bytes
from vpro_assets.geometry.meshes import soup_to_indexed
from vpro_assets.objects.mjcf import VisualMesh
from vpro_assets.objects.mjcf import drop_test_xml
from vpro_assets.objects.mjcf import object_xml
from vpro_assets.objects.mjcf import solid_inertial
from vpro_assets.geometry.refine import refine_soup
from vpro_assets.geometry.solid import check_closed_manifold
from vpro_assets.geometry.solid import manifold_arrays
from vpro_assets.geometry.solid import repair_part
from vpro_assets.geometry.solid import union

log = logging.getLogger(__name__)


def libero_mass(xml_path: Path) -> float:
    """The object's mass as LIBERO simulates it: robosuite counts only group-0 geoms."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(drop_test_xml(xml_path))
    return float(model.body_subtreemass[model.body("object").id])


def _upright_extents(frame: deform_mod.UprightFrame, vertices: np.ndarray) -> np.ndarray:
    p = frame.to_upright(vertices)
    return p.max(axis=0) - p.min(axis=0)


def _max_radius(frame: deform_mod.UprightFrame, vertices: np.ndarray) -> float:
    p = frame.to_upright(vertices)
    return float(np.linalg.norm(p[:, :2], axis=1).max())


def build_object(*, name, category, deformation, severity, setting, xml_path: Path, up: str,
                 coacd_params: CoacdParams, key: dict, staging: Path, out_dir: Path):
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    source = load_libero_object(category, xml_path)
    amount = deform_mod.amount_of(deformation, setting.param_dict)

    # 1. the original solid, closed 2-manifold
    repaired, reports = [], []
    for part in source.parts:
        manifold, report = repair_part(f"{category}/{part.name}", part.corners)
        repaired.append(manifold)
        reports.append(report)
    solid0 = union(repaired)
    v0, f0 = manifold_arrays(solid0)
    extent = float((v0.max(axis=0) - v0.min(axis=0)).max())
    max_edge = extent * REFINE_FRACTION
    solid0 = solid0.refine_to_length(max_edge)
    v0, f0 = manifold_arrays(solid0)
    centroid = _centroid(v0, f0)
    frame = deform_mod.upright_frame(up, v0, centroid)
    timings["manifold_repair"] = time.perf_counter() - t0

    # 2. deformation of solid and visual meshes by one map
    t1 = time.perf_counter()
    warp = deform_mod.deformation_map(deformation, amount, frame)
    solid = solid0.warp_batch(lambda points: warp(np.asarray(points)))
    import manifold3d

    if solid.status() != manifold3d.Error.NoError or solid.volume() <= 0:
        raise MeshError(f"{category}: {deformation} severity {severity} broke the solid ({solid.status()})")
    v1, f1 = manifold_arrays(solid)
    visual_parts = []
    for part in source.parts:
        corners, uv, normals = refine_soup(part.corners, part.uv, max_edge, part.normals)
        flat = corners.reshape(-1, 3)
        if normals is not None:
            normals = deform_mod.transform_normals(flat, normals.reshape(-1, 3), warp).reshape(-1, 3, 3)
        visual_parts.append((part, warp(flat).reshape(-1, 3, 3), uv, normals))
    timings["deformation"] = time.perf_counter() - t1

    # 3. convex decomposition of the (simplified) deformed solid
    t2 = time.perf_counter()
    v_simple, f_simple = manifold_arrays(solid.simplify(extent * COACD_SIMPLIFY_FRACTION))
    hulls = decompose(v_simple, f_simple, coacd_params, f"{category} {deformation} s{severity}")
    hulls = split_support_hulls(hulls, frame.rotation[2], (frame.rotation[0], frame.rotation[1]),
                                f"{category} {deformation} s{severity}")
    timings["coacd"] = time.perf_counter() - t2

    # 4. files
    t3 = time.perf_counter()
    obj_dir = staging
    files: dict[str, tuple[bytes, str]] = {}  # path relative to the object folder -> (bytes, role)
    textures: dict[str, tuple[Path, str]] = {}  # out_dir-relative path -> (source, sha)
    visuals, export_visuals = [], []
    for i, (part, corners, uv, normals) in enumerate(visual_parts):
        vertices, faces, uv_vals, uv_faces = soup_to_indexed(corners, uv)
        normal_vals, normal_faces = (None, None) if normals is None else normals_to_indexed(normals)
        data = obj_bytes(vertices, faces, uv_vals, uv_faces, header=f"{name} visual {i}: {part.name} deformed",
                         normals=normal_vals, normal_faces=normal_faces)
        mesh_file = f"meshes/{content_name(f'visual{i}', data, '.obj')}"
        files[mesh_file] = (data, "visual_mesh")
        texture_rel = None
        if part.texture_file is not None:
            tex_bytes = part.texture_file.read_bytes()
            tex_name = content_name(part.texture_file.stem, tex_bytes, part.texture_file.suffix.lower())
            textures[f"textures/{tex_name}"] = (part.texture_file, sha256_bytes(tex_bytes))
            texture_rel = f"../textures/{tex_name}"
        visuals.append(VisualMesh(mesh_file, part.material, texture_rel, part.texture_attrs))
        rgba = tuple(float(x) for x in part.material["rgba"].split()) if "rgba" in part.material else None
        export_visuals.append(ExportMesh(f"visual{i}", mesh_file, vertices, faces, uv_vals, uv_faces, rgba, texture_rel))
    solid_bytes = obj_bytes(v1, f1, header=f"{name} closed solid (manifold3d), metres")
    files[f"meshes/{content_name('solid', solid_bytes, '.obj')}"] = (solid_bytes, "solid_mesh")
    hull_files, export_hulls, hull_volume = [], [], 0.0
    for k, hull in enumerate(hulls):
        data = obj_bytes(np.asarray(hull.vertices), np.asarray(hull.faces), header=f"{name} convex hull")
        hull_file = f"meshes/{content_name('hull', data, '.obj')}"
        files[hull_file] = (data, "hull_mesh")
        hull_files.append(hull_file)
        export_hulls.append(ExportMesh(f"hull{k:02d}", hull_file, np.asarray(hull.vertices), np.asarray(hull.faces)))
        hull_volume += float(hull.volume)

    mass = libero_mass(xml_path)
    inertial = solid_inertial(mass, v1, f1)
    radius_ratio = _max_radius(frame, v1) / _max_radius(frame, v0)
    sites = []
    for site in source.sites:
        site = dict(site)
        if site.get("name") == "horizontal_radius_site" and "pos" in site:
            pos = [float(x) for x in site["pos"].split()]
            site["pos"] = " ".join(f"{x:.6f}" for x in (pos[0] * radius_ratio, pos[1] * radius_ratio, pos[2]))
        sites.append(site)
    files[f"{name}.xml"] = (object_xml(name, visuals, hull_files, mass / hull_volume, inertial,
                                       source.collision_attrs, sites, source.object_body_pos), "mjcf")
    files[f"{name}.urdf"] = (urdf_text(name, export_visuals, export_hulls, inertial).encode(), "urdf")
    files[f"{name}.usda"] = (usd_text(name, export_visuals, export_hulls, inertial).encode(), "usd")

    check_closed_manifold(*_quantized_arrays(solid_bytes), f"{name} solid mesh as written")
    ext0, ext1 = _upright_extents(frame, v0), _upright_extents(frame, v1)
    record = {
        "name": name, "category": category, "deformation": deformation, "severity": severity,
        "setting": setting.id, "amount": amount, "up_axis": up, "input_key": key,
        "repair": [r.__dict__ for r in reports],
        "measures": {
            "original_volume_m3": _r(solid0.volume()), "volume_m3": _r(solid.volume()),
            "volume_ratio": _r(solid.volume() / solid0.volume()),
            "original_extents_m": [_r(x) for x in ext0], "extents_m": [_r(x) for x in ext1],
            "extent_ratios": [_r(x) for x in ext1 / ext0],
            "max_radius_ratio": _r(radius_ratio),
            "mean_displacement": _r(deform_mod.displacement_measure(v0, warp, float(np.linalg.norm(ext0)))),
            "hull_count": len(hulls), "hull_volume_ratio": _r(hull_volume / solid.volume()),
            "mass_kg": _r(mass), "solid_faces": int(len(f1)),
            "visual_faces": int(sum(len(c) for _p, c, _u, _n in visual_parts)),
        },
    }
    file_list = [GeneratedFile(f"{name}/{path}", sha256_bytes(data), role) for path, (data, role) in sorted(files.items())]
    file_list += [GeneratedFile(path, sha, "texture") for path, (_src, sha) in sorted(textures.items())]
    record["files"] = [f.__dict__ for f in file_list]
    record_bytes = canonical_json(record).encode()
    for path, (data, _role) in files.items():
        write_bytes_atomic(obj_dir / path, data)
    for path, (src, sha) in textures.items():
        target = out_dir / path
        if not target.is_file() or sha256_bytes(target.read_bytes()) != sha:
            write_bytes_atomic(target, src.read_bytes())
    write_bytes_atomic(obj_dir / "record.json", record_bytes)  # written last: marks the object complete
    timings["write"] = time.perf_counter() - t3
    log.info("%s: repair %.1fs, deformation %.1fs, coacd %.1fs (%d hulls), write %.1fs", name,
             timings["manifold_repair"], timings["deformation"], timings["coacd"], len(hulls), timings["write"])
    file_list.append(GeneratedFile(f"{name}/record.json", sha256_bytes(record_bytes), "record"))
    return GeneratedObject(name, category, deformation, severity, setting.id, out_dir, tuple(file_list), record,
                           cached=False, timings=timings)


def _r(x: float) -> float:
    return float(f"{float(x):.6g}")


def _centroid(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    import trimesh

    return np.asarray(trimesh.Trimesh(vertices, faces, process=False).center_mass, np.float64)


def _quantized_arrays(obj_data: bytes) -> tuple[np.ndarray, np.ndarray]:
    lines = obj_data.decode().splitlines()
    vertices = np.array([[float(x) for x in ln.split()[1:4]] for ln in lines if ln.startswith("v ")])
    faces = np.array([[int(x) - 1 for x in ln.split()[1:4]] for ln in lines if ln.startswith("f ")])
    return vertices, faces
