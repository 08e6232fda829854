"""Visual-only copies of LIBERO objects (Visual State Ambiguity): seen, never touched, never moved.

The copy keeps the source object's visual meshes and materials, drops every geometry that
collides, and marks what is left `contype=0 conaffinity=0 group=1`; it is placed as a fixture (no
joint, so it never moves) in the pose given (e.g. upside down). Its placement sites are
recomputed for that pose so LIBERO's fixture sampler puts its lowest point on the table.
"""

from __future__ import annotations

import hashlib
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from vpro_assets.core.errors import GeneratorError
from vpro_assets.core.mjgeom import axis_angle_quat, quat_matrix, quat_mul, world_aabb
from vpro_assets.objects.derived import copy_referenced_files, write_object_xml
from vpro_assets.scene.pool import object_file
from vpro_assets.scene.variant import GeneratedObject


def _child(node: ET.Element, path: str, src_xml: Path) -> ET.Element:
    found = node.find(path)
    if found is None:
        raise GeneratorError(f"LIBERO object file {src_xml} has no {path} (LIBERO's object layout)")
    return found


def _floats(text: str | None, default: str) -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


def _geom_defaults(root: ET.Element) -> dict[str, dict]:
    """MJCF default classes -> the geom attributes they set (nested defaults inherit)."""
    out: dict[str, dict] = {}

    def walk(node: ET.Element, inherited: dict) -> None:
        attrs = dict(inherited)
        geom = node.find("geom")
        if geom is not None:
            attrs.update(geom.attrib)
        out[node.get("class", "main")] = attrs
        for child in node.findall("default"):
            walk(child, attrs)

    for top in root.findall("default"):
        walk(top, {})
    return out


def _visual_geoms(root: ET.Element) -> None:
    """Keep only visual geoms (resolving default classes), marked visual-only explicitly."""
    defaults = _geom_defaults(root)

    def visit(node: ET.Element, childclass: str) -> None:
        childclass = node.get("childclass", childclass)
        for geom in list(node.findall("geom")):
            attrs = dict(defaults.get(geom.get("class", childclass), {}))
            attrs.update(geom.attrib)
            colliding = attrs.get("contype", "1") != "0" or attrs.get("conaffinity", "1") != "0"
            if colliding or attrs.get("group", "0") == "0":
                node.remove(geom)
            else:
                geom.set("contype", "0")
                geom.set("conaffinity", "0")
                geom.set("group", "1")
                for key in ("density", "mass", "solimp", "solref", "friction"):
                    geom.attrib.pop(key, None)
        for child in node.findall("body"):
            visit(child, childclass)

    for body in root.findall("./worldbody/body"):
        visit(body, "main")


def _extent(xml_text: str, directory: Path) -> tuple[np.ndarray, np.ndarray]:
    """World-frame box of the visual geoms of an object file (outer body at the origin)."""
    tmp = directory / ".probe.xml"
    tmp.write_text(xml_text)
    try:
        model = mujoco.MjModel.from_xml_path(str(tmp))
    finally:
        tmp.unlink()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return world_aabb(model, data, range(model.ngeom))


def ghost_name(source: str, label: str, quat, sink: float) -> str:
    key = hashlib.sha256(f"v3|{source}|{label}|{np.round(quat, 6).tolist()}|{sink:.5f}".encode()).hexdigest()[:8]
    return f"vpro_ghost_{source}_{label}_{key}"


def write_ghost(source: str, name: str, quat, sink: float, directory: Path) -> Path:
    """`sink`: how far below LIBERO's fixture reference height the table surface lies (m)."""
    src_xml = Path(object_file(source))
    root = ET.parse(src_xml).getroot()
    _visual_geoms(root)
    outer = _child(root, "./worldbody/body", src_xml)
    inner = _child(outer, "./body[@name='object']", src_xml)
    for site in outer.findall("site"):
        outer.remove(site)
    # robosuite keeps the `object` body's children but not its own pose: the turn goes one level in.
    turned = ET.Element("body", {"name": "ghost_part", "quat": " ".join(f"{v:.6f}" for v in quat)})
    offset = ET.SubElement(turned, "body", {"name": "ghost_mesh", "pos": inner.get("pos", "0 0 0")})
    for child in list(inner):
        inner.remove(child)
        offset.append(child)
    inner.attrib.pop("pos", None)
    inner.attrib.pop("quat", None)
    inner.append(turned)
    copy_referenced_files(root, src_xml, directory)
    lo, hi = _extent(ET.tostring(root, encoding="unicode"), directory)
    # Centre the visible geometry over the fixture's origin (LIBERO's meshes sit off their body).
    centre = (lo[:2] + hi[:2]) / 2
    turned.set("pos", f"{-centre[0]:.6f} {-centre[1]:.6f} 0")
    lo, hi = _extent(ET.tostring(root, encoding="unicode"), directory)
    radius = float(np.max(np.abs(np.concatenate([lo[:2], hi[:2]]))))
    for site_name, pos in (
        ("bottom_site", (0.0, 0.0, lo[2] - sink)),
        ("top_site", (0.0, 0.0, hi[2])),
        ("horizontal_radius_site", (radius, radius, 0.0)),
    ):
        ET.SubElement(
            outer,
            "site",
            {"name": site_name, "pos": " ".join(f"{v:.5f}" for v in pos), "size": "0.005", "rgba": "0 0 0 0"},
        )
    return write_object_xml(root, name, directory)


def ghost_object(source: str, label: str, quat, sink: float) -> GeneratedObject:
    name = ghost_name(source, label, quat, sink)
    return GeneratedObject(
        name=name, write=lambda directory: write_ghost(source, name, quat, sink, directory), template=None
    )


def _rotate_about(body: ET.Element, joint: ET.Element, angle: float) -> None:
    """Turn `body` (and what it carries) by `angle` about its hinge `joint` (axis through its pos)."""
    axis = _floats(joint.get("axis"), "0 0 1")
    jp = _floats(joint.get("pos"), "0 0 0")
    pos = _floats(body.get("pos"), "0 0 0")
    quat = _floats(body.get("quat"), "1 0 0 0")
    turn = axis_angle_quat(axis, angle)
    new_pos = pos + quat_matrix(quat) @ (jp - quat_matrix(turn) @ jp)
    body.set("pos", " ".join(f"{v:.6f}" for v in new_pos))
    body.set("quat", " ".join(f"{v:.6f}" for v in quat_mul(quat, turn)))


def write_articulation_ghost(source: str, name: str, joint_name: str, value: float, directory: Path) -> Path:
    """A visual-only copy of the part of `source` that `joint_name` moves, set to `value` (the
    other state), with the source's placement sites, so placed at the source's spot it shows that
    part in the other state over the real one."""
    src_xml = Path(object_file(source))
    root = ET.parse(src_xml).getroot()
    inner = _child(root, "./worldbody/body/body[@name='object']", src_xml)
    moving = next((b for b in inner.iter("body") if b.find(f"joint[@name='{joint_name}']") is not None), None)
    if moving is None:
        raise GeneratorError(f"{src_xml.name} has no body moved by joint {joint_name!r}")
    joint = _child(moving, f"joint[@name='{joint_name}']", src_xml)
    kept = {id(e) for e in moving.iter()}
    for parent in inner.iter():
        for child in list(parent):
            if child.tag in ("joint", "site", "inertial") or (child.tag == "geom" and id(child) not in kept):
                parent.remove(child)
    _visual_geoms(root)
    if joint.get("type", "hinge") == "slide":
        pos = _floats(moving.get("pos"), "0 0 0") + _floats(joint.get("axis"), "0 0 1") * value
        moving.set("pos", " ".join(f"{v:.6f}" for v in pos))
    else:
        _rotate_about(moving, joint, value)
    copy_referenced_files(root, src_xml, directory)
    return write_object_xml(root, name, directory)


def articulation_ghost(source: str, joint_name: str, value: float, label: str) -> GeneratedObject:
    key = hashlib.sha256(f"v2|{source}|{joint_name}|{value:.6f}".encode()).hexdigest()[:8]
    name = f"vpro_ghost_{source}_{label}_{key}"
    return GeneratedObject(
        name=name,
        write=lambda directory: write_articulation_ghost(source, name, joint_name, value, directory),
        template=None,
    )
