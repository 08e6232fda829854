"""Reading LIBERO's object meshes and writing meshes as canonical, content-addressed bytes.

LIBERO's objects keep their visual meshes in MuJoCo's legacy binary `.msh` format (vertex,
normal, texture-coordinate and face arrays, one vertex per face corner). `load_libero_object`
reads an object's MJCF file and returns every visual mesh part in the object body's frame, with
its texture coordinates and material. Writers here emit OBJ text at a fixed precision, so the
same mesh always gives the same bytes and the same sha256 (never trimesh's cache hash, which
depends on what is installed).
"""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from vpro_assets.core.errors import VProError
from vpro_assets.core.hashing import sha256_bytes
from vpro_assets.core.mjgeom import quat_matrix

POSITION_DECIMALS = 6  # metres: 1 micrometre
UV_DECIMALS = 6
NORMAL_DECIMALS = 5


class MeshError(VProError):
    """A mesh that cannot be read, repaired or used (named with its file and the reason)."""


@dataclass
class MeshPart:
    """One visual mesh of an object, as a triangle soup in the object body's frame."""

    name: str
    corners: np.ndarray  # (F, 3, 3) float64 corner positions, metres
    uv: np.ndarray | None  # (F, 3, 2) corner texture coordinates (OBJ convention: v up), or None
    material: dict[str, str] = field(default_factory=dict)  # MJCF material attributes (no name/texture)
    texture_file: Path | None = None  # absolute path of the material's texture, if any
    texture_attrs: dict[str, str] = field(default_factory=dict)  # MJCF texture attributes (no name/file)
    source_file: Path | None = None
    normals: np.ndarray | None = None  # (F, 3, 3) corner unit normals, or None

    @property
    def n_faces(self) -> int:
        return int(self.corners.shape[0])


@dataclass
class LiberoObjectSource:
    """A LIBERO object's MJCF file read into parts, sites and collision-geom attributes."""

    category: str
    xml_path: Path
    parts: list[MeshPart]
    object_body_pos: str | None
    sites: list[dict[str, str]]  # attributes of the outer body's sites (bottom/top/horizontal_radius)
    collision_attrs: dict[str, str]  # contact attributes of the original collision geoms


def read_msh(path: Path | str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """MuJoCo's legacy binary mesh: int32 counts (nvert, nnormal, ntexcoord, nface), then arrays."""
    path = Path(path)
    data = path.read_bytes()
    if len(data) < 16:
        raise MeshError(f"{path}: {len(data)} bytes, too short for a MuJoCo .msh header")
    nv, nn, nt, nf = (int(x) for x in np.frombuffer(data[:16], dtype="<i4"))
    expected = 16 + 12 * nv + 12 * nn + 8 * nt + 12 * nf
    if min(nv, nn, nt, nf) < 0 or expected != len(data):
        raise MeshError(f"{path}: header counts {nv, nn, nt, nf} do not match its {len(data)} bytes")
    offset = 16
    vertices = np.frombuffer(data, "<f4", 3 * nv, offset).reshape(-1, 3).astype(np.float64)
    offset += 12 * nv
    normals = np.frombuffer(data, "<f4", 3 * nn, offset).reshape(-1, 3).astype(np.float64)
    offset += 12 * nn
    texcoords = np.frombuffer(data, "<f4", 2 * nt, offset).reshape(-1, 2).astype(np.float64)
    offset += 8 * nt
    faces = np.frombuffer(data, "<i4", 3 * nf, offset).reshape(-1, 3).astype(np.int64)
    if nf == 0 or faces.min() < 0 or faces.max() >= nv:
        raise MeshError(f"{path}: {nf} faces, indices outside 0..{nv - 1}")
    return vertices, normals, texcoords, faces


def read_obj_soup(path: Path | str) -> tuple[np.ndarray, np.ndarray | None]:
    """A plain OBJ (v, vt, f) as a triangle soup: corners (F,3,3) and uv (F,3,2) or None."""
    mesh = trimesh.load(str(path), force="mesh", process=False)
    if not isinstance(mesh, trimesh.Trimesh):
        raise MeshError(f"{path}: not a triangle mesh ({type(mesh).__name__})")
    corners = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)]
    uv = getattr(mesh.visual, "uv", None)
    return corners, (None if uv is None else np.asarray(uv, np.float64)[np.asarray(mesh.faces)])


def _floats(text: str | None, default: tuple[float, ...]) -> np.ndarray:
    return np.array([float(x) for x in text.split()], dtype=np.float64) if text else np.array(default, np.float64)


def _load_mesh_file(path: Path, scale: np.ndarray):
    """(corners, uv, normals) of a mesh file, scaled; uv in OBJ's convention (v up)."""
    if not path.is_file():
        raise MeshError(f"mesh file {path} does not exist")
    if path.suffix.lower() == ".msh":
        vertices, normals, texcoords, faces = read_msh(path)
        corners = vertices[faces] * scale
        uv = None
        if len(texcoords) == len(vertices):
            # .msh stores texture coordinates as MuJoCo uses them (v flipped from OBJ's convention);
            # MuJoCo flips v again when it reads an OBJ, so they go back to OBJ's convention here.
            uv = texcoords[faces] * np.array([1.0, -1.0]) + np.array([0.0, 1.0])
        corner_normals = None
        if len(normals) == len(vertices):
            corner_normals = normals[faces] / np.where(scale == 0, 1.0, scale)  # normals transform by S^-1
            corner_normals /= np.maximum(np.linalg.norm(corner_normals, axis=2, keepdims=True), 1e-12)
        return corners, uv, corner_normals
    corners, uv = read_obj_soup(path)
    return corners * scale, uv, None


def load_libero_object(category: str, xml_path: Path) -> LiberoObjectSource:
    """Read the visual mesh parts (group 1 mesh geoms) of a LIBERO object's MJCF file."""
    xml_path = Path(xml_path)
    try:
        root = ET.parse(xml_path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise MeshError(f"{category}: cannot read its MJCF file {xml_path}: {exc}") from exc
    outer = root.find("./worldbody/body")
    body = None if outer is None else outer.find("./body[@name='object']")
    if outer is None or body is None:
        raise MeshError(f"{category}: {xml_path} has no <body name='object'>")
    assets = root.find("asset")
    meshes = {m.get("name"): m for m in (assets.findall("mesh") if assets is not None else [])}
    materials = {m.get("name"): m for m in (assets.findall("material") if assets is not None else [])}
    textures = {t.get("name"): t for t in (assets.findall("texture") if assets is not None else [])}
    parts: list[MeshPart] = []
    collision_attrs: dict[str, str] = {}
    for geom in body.iter("geom"):
        group = geom.get("group", "0")
        if group == "0" and not collision_attrs:
            collision_attrs = {k: v for k in ("solimp", "solref", "friction") if (v := geom.get(k)) is not None}
        if geom.get("type") != "mesh" or group != "1":
            continue
        mesh_el = meshes.get(geom.get("mesh"))
        if mesh_el is None:
            raise MeshError(f"{category}: geom uses mesh {geom.get('mesh')!r}, not defined in {xml_path}")
        if mesh_el.get("refpos") or mesh_el.get("refquat"):
            raise MeshError(f"{category}: mesh {mesh_el.get('name')!r} uses refpos/refquat, not supported")
        corners, uv, normals = _load_mesh_file(
            xml_path.parent / mesh_el.get("file", ""), _floats(mesh_el.get("scale"), (1, 1, 1))
        )
        rotation = quat_matrix(_floats(geom.get("quat"), (1, 0, 0, 0)))
        corners = corners @ rotation.T + _floats(geom.get("pos"), (0, 0, 0))
        normals = None if normals is None else normals @ rotation.T
        material, texture_file, texture_attrs = {}, None, {}
        mat_el = materials.get(geom.get("material"))
        if mat_el is not None:
            material = {k: v for k, v in mat_el.attrib.items() if k not in ("name", "texture")}
            tex_el = textures.get(mat_el.get("texture"))
            if tex_el is not None and (tex_file := tex_el.get("file")):
                texture_file = (xml_path.parent / tex_file).resolve()
                texture_attrs = {k: v for k, v in tex_el.attrib.items() if k not in ("name", "file")}
        elif rgba := geom.get("rgba"):
            material = {"rgba": rgba}
        parts.append(
            MeshPart(
                mesh_el.get("name", ""),
                corners,
                uv if texture_file is not None else None,
                material,
                texture_file,
                texture_attrs,
                xml_path.parent / mesh_el.get("file", ""),
                normals,
            )
        )
    if not parts:
        raise MeshError(f"{category}: {xml_path} has no visual mesh geom (group 1) in its object body")
    sites = [dict(s.attrib) for s in outer.findall("./site")]
    return LiberoObjectSource(category, xml_path, parts, body.get("pos"), sites, collision_attrs)


# --- canonical writing -----------------------------------------------------------------------


def quantize(values: np.ndarray, decimals: int = POSITION_DECIMALS) -> np.ndarray:
    """Round to the written precision (and turn -0.0 into 0.0) so bytes do not depend on noise."""
    out = np.round(np.asarray(values, dtype=np.float64), decimals)
    out[out == 0.0] = 0.0
    return out


def _format_rows(prefix: str, rows: np.ndarray, decimals: int) -> str:
    if len(rows) == 0:
        return ""
    fmt = " ".join([f"%.{decimals}f"] * rows.shape[1])
    buffer = io.StringIO()
    np.savetxt(buffer, quantize(rows, decimals), fmt=f"{prefix} {fmt}")
    return buffer.getvalue()


def obj_bytes(
    vertices: np.ndarray,
    faces: np.ndarray,
    uv: np.ndarray | None = None,
    uv_faces: np.ndarray | None = None,
    header: str = "",
    normals: np.ndarray | None = None,
    normal_faces: np.ndarray | None = None,
) -> bytes:
    """OBJ text: `v` at 6 decimals, optional `vt` and `vn`, 1-based faces (`f v/vt/vn`)."""
    columns = [np.asarray(faces, dtype=np.int64) + 1]
    text = [f"# {header}\n" if header else "", _format_rows("v", np.asarray(vertices), POSITION_DECIMALS)]
    if uv is not None:
        text.append(_format_rows("vt", np.asarray(uv), UV_DECIMALS))
        columns.append(np.asarray(uv_faces, dtype=np.int64) + 1)
    if normals is not None:
        text.append(_format_rows("vn", np.asarray(normals), NORMAL_DECIMALS))
        columns.append(np.asarray(normal_faces, dtype=np.int64) + 1)
    corner = {1: "%d", 2: "%d/%d", 3: "%d/%d/%d"}[len(columns)]
    if normals is not None and uv is None:
        corner = "%d//%d"
    table = np.stack(columns, axis=-1).reshape(len(columns[0]), 3 * len(columns))
    buffer = io.StringIO()
    np.savetxt(buffer, table, fmt="f " + " ".join([corner] * 3))
    text.append(buffer.getvalue())
    return "".join(text).encode("ascii")


def _unique_rows(values: np.ndarray, decimals: int) -> tuple[np.ndarray, np.ndarray]:
    unique, inverse = np.unique(quantize(values.reshape(-1, values.shape[-1]), decimals), axis=0, return_inverse=True)
    return unique, inverse.reshape(-1, 3)


def soup_to_indexed(corners: np.ndarray, uv: np.ndarray | None):
    """Triangle soup -> (vertices, faces, uv, uv_faces), merging corners equal at written precision."""
    vertices, faces = _unique_rows(corners, POSITION_DECIMALS)
    if uv is None:
        return vertices, faces, None, None
    uv_unique, uv_faces = _unique_rows(uv, UV_DECIMALS)
    return vertices, faces, uv_unique, uv_faces


def normals_to_indexed(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corner normals (F, 3, 3) -> (unique normals, normal_faces) at written precision."""
    return _unique_rows(normals, NORMAL_DECIMALS)


def content_name(stem: str, data: bytes, suffix: str, digits: int = 16) -> str:
    """`stem_<first digits of sha256>.suffix`: the file name carries its content."""
    return f"{stem}_{sha256_bytes(data)[:digits]}{suffix}"
