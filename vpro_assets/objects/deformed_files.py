"""Stages 4 and 5 of the deformed-object build (`vpro_assets.objects.deformed_build`): every
file's bytes (content-named OBJ meshes, the MJCF object, URDF and USD exports), the record with the
object's measures, then the files written, the record last (it marks the object complete).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from vpro_assets.core.atomic import write_bytes_atomic
from vpro_assets.core.hashing import canonical_json, sha256_bytes
from vpro_assets.geometry import deform as deform_mod
from vpro_assets.geometry.meshes import content_name, normals_to_indexed, obj_bytes, soup_to_indexed
from vpro_assets.objects.deformed_record import Deformed, GeneratedFile, Original
from vpro_assets.objects.exporters import ExportMesh, urdf_text, usd_text
from vpro_assets.objects.mjcf import Inertial, VisualMesh, object_xml, solid_inertial


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
    """Add the MJCF object (sites scaled with the deformed radius, a fit included; LIBERO's bottom and
    top sites, which only offset its placement samplers, are kept), URDF and USD; return the inertial."""
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
