"""Writing a LIBERO-compatible MJCF object: visual meshes, convex collision hulls, mass, sites.

The layout is LIBERO's own (`<worldbody><body><body name="object">` holding the geoms, the
placement sites `bottom_site`, `top_site`, `horizontal_radius_site` on the outer body), so the
file registers with `vpro_assets.objects.registry` and loads through robosuite's
`MujocoXMLObject`. Visual geoms (group 1) never collide and carry no mass; collision hulls
(group 0, the only group robosuite counts for inertia) share the object's mass through one
density, and an explicit `<inertial>` states the same mass with the inertia of the solid.
Attributes are written in a fixed order at fixed precision, so equal inputs give equal bytes.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import trimesh

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.geometry.meshes import MeshError, quantize
from vpro_assets.objects.derived import referenced_files

VISUAL_GROUP, COLLISION_GROUP = "1", "0"
COLLISION_RGBA = "0.8 0.8 0.8 0.3"


@dataclass(frozen=True)
class VisualMesh:
    mesh_file: str  # relative to the object's XML
    material: dict[str, str] = field(default_factory=dict)  # MJCF material attributes
    texture_file: str | None = None  # relative to the object's XML
    texture_attrs: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Inertial:
    mass: float  # kg
    com: np.ndarray  # (3,) metres, object body frame
    inertia: np.ndarray  # (3, 3) about the com, kg m^2

    def fullinertia(self) -> str:
        i = self.inertia
        return fmt_sci([i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]])


def fmt_fixed(values, decimals: int = 6) -> str:
    return " ".join(f"{v:.{decimals}f}" for v in quantize(np.atleast_1d(values), decimals))


def fmt_sci(values) -> str:
    return " ".join(f"{float(v):.6e}" for v in np.atleast_1d(values))


def solid_inertial(mass: float, vertices: np.ndarray, faces: np.ndarray) -> Inertial:
    """Mass properties of a closed solid (vertices, faces) at the uniform density giving `mass`."""
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    volume = float(mesh.volume)
    mesh.density = mass / volume
    return Inertial(mass, np.asarray(mesh.center_mass, np.float64), np.asarray(mesh.moment_inertia, np.float64))


def object_xml(
    name: str,
    visuals: list[VisualMesh],
    hull_files: list[str],
    hull_density: float,
    inertial: Inertial,
    collision_attrs: dict[str, str],
    sites: list[dict[str, str]],
    body_pos: str | None = None,
) -> bytes:
    """The MJCF object file as canonical bytes."""
    root = ET.Element("mujoco", {"model": name})
    _assets(ET.SubElement(root, "asset"), name, visuals, hull_files)
    worldbody = ET.SubElement(root, "worldbody")
    outer = ET.SubElement(worldbody, "body")
    body = ET.SubElement(outer, "body", {"name": "object", **({"pos": body_pos} if body_pos else {})})
    ET.SubElement(
        body,
        "inertial",
        {"pos": fmt_fixed(inertial.com), "mass": fmt_sci(inertial.mass), "fullinertia": inertial.fullinertia()},
    )
    for i in range(len(visuals)):
        visual = {"name": f"{name}_vis{i}", "type": "mesh", "mesh": f"{name}_vis{i}", "material": f"{name}_mat{i}"}
        ET.SubElement(body, "geom", {**visual, "group": VISUAL_GROUP, "contype": "0", "conaffinity": "0", "mass": "0"})
    contact = dict(sorted(collision_attrs.items()))
    for k in range(len(hull_files)):
        hull = {"name": f"{name}_hull{k:02d}", "type": "mesh", "mesh": f"{name}_hull{k:02d}", "group": COLLISION_GROUP}
        ET.SubElement(body, "geom", {**hull, "density": fmt_sci(hull_density), **contact, "rgba": COLLISION_RGBA})
    for site in sites:
        ET.SubElement(outer, "site", dict(site))
    ET.indent(root, space="  ")
    return (ET.tostring(root, encoding="unicode") + "\n").encode("utf-8")


def _assets(asset: ET.Element, name: str, visuals: list[VisualMesh], hull_files: list[str]) -> None:
    """Textures, materials and meshes of the visual parts, then the hull meshes."""
    for i, visual in enumerate(visuals):
        if visual.texture_file is not None:
            texture = {"name": f"{name}_tex{i}", "file": visual.texture_file}
            ET.SubElement(asset, "texture", {**texture, **dict(sorted({"type": "2d", **visual.texture_attrs}.items()))})
        attrs = dict(sorted(visual.material.items()))
        if visual.texture_file is not None:
            attrs["texture"] = f"{name}_tex{i}"
        ET.SubElement(asset, "material", {"name": f"{name}_mat{i}", **attrs})
        ET.SubElement(asset, "mesh", {"name": f"{name}_vis{i}", "file": visual.mesh_file})
    for k, hull_file in enumerate(hull_files):
        ET.SubElement(asset, "mesh", {"name": f"{name}_hull{k:02d}", "file": hull_file})


def drop_test_xml(object_xml_path, pos=(0.0, 0.0, 0.05), quat=(1.0, 0.0, 0.0, 0.0)) -> str:
    """A world with robosuite's compiler settings: a table-top box (top face at z = 0, as LIBERO's
    tables are boxes) and the object on a free joint.

    File paths are made absolute, so the world compiles from a string anywhere.
    """
    path = Path(object_xml_path).resolve()
    src = ET.parse(path).getroot()
    src_asset, src_body = src.find("asset"), src.find("./worldbody/body/body[@name='object']")
    if src_asset is None or src_body is None:
        raise MeshError(f"{path}: no <asset> or no <worldbody><body><body name='object'> (LIBERO's object layout)")
    files = {id(element): rel for element, rel in referenced_files(src)}
    world = ET.Element("mujoco", {"model": "drop_test"})
    ET.SubElement(world, "compiler", {"angle": "radian", "inertiagrouprange": "0 0", "autolimits": "true"})
    ET.SubElement(world, "option", {"timestep": "0.002"})
    asset = ET.SubElement(world, "asset")
    for element in src_asset:
        copy = ET.fromstring(ET.tostring(element))
        if id(element) in files:
            copy.set("file", str((path.parent / files[id(element)]).resolve()))
        asset.append(copy)
    worldbody = ET.SubElement(world, "worldbody")
    ET.SubElement(worldbody, "geom", {"name": "table", "type": "box", "size": "0.5 0.5 0.05", "pos": "0 0 -0.05"})
    body = ET.fromstring(ET.tostring(src_body))
    body.set("pos", fmt_fixed(pos))
    body.set("quat", fmt_fixed(quat))
    body.insert(0, ET.Element("freejoint", {"name": "object_free"}))
    worldbody.append(body)
    return ET.tostring(world, encoding="unicode")


@dataclass(frozen=True)
class DropResult:
    """How an object dropped on a plane came to rest (angles in degrees, lengths in metres)."""

    warnings: dict  # MuJoCo warning kind -> count (empty when clean)
    tilt: float  # angle between the object's up axis and the world's, at the end
    drift: float  # displacement of the body over the last `window` seconds
    turn: float  # rotation of the body over the last `window` seconds
    speed: float  # largest linear speed of the body during the last `window` seconds, m/s
    height: float  # body height at the end
    mass: float

    def rests(self, max_tilt: float = 5.0, max_drift: float = 0.001, max_turn: float = 1.0) -> bool:
        return not self.warnings and self.tilt <= max_tilt and self.drift <= max_drift and self.turn <= max_turn


def dropped_world(object_xml_path, up_axis: str = "+z", clearance: float = 0.003) -> tuple:
    """(MjModel, MjData) of the drop-test world (`drop_test_xml`) with the object upright (its
    `up_axis` turned to the world's +z, as LIBERO places it), its lowest collision point `clearance`
    above the table top: the state set, not yet stepped; the object's body is `object`."""
    rotate = {"+z": (1.0, 0.0, 0.0, 0.0), "+y": (np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0)}
    if up_axis not in rotate:
        raise InvalidParameterError(f"up axis {up_axis!r} not supported by the drop test")
    quat = np.array(rotate[up_axis])
    model = mujoco.MjModel.from_xml_string(drop_test_xml(object_xml_path, (0.0, 0.0, 1.0), quat))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = model.body("object").id
    lowest = min(
        float(data.geom_xpos[g][2] - _geom_depth(model, data, g))
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == body and model.geom_group[g] == 0
    )
    data.qpos[2] = 1.0 - lowest + clearance
    return model, data


def drop_test(
    object_xml_path, up_axis: str = "+z", clearance: float = 0.003, seconds: float = 2.0, window: float = 0.5
) -> DropResult:
    """Drop the object (upright, `clearance` above the table top) and measure how it rests."""
    model, data = dropped_world(object_xml_path, up_axis, clearance)
    body = model.body("object").id
    steps, window_steps = int(seconds / model.opt.timestep), int(window / model.opt.timestep)
    if not 0 < window_steps <= steps:
        raise InvalidParameterError(f"drop test window {window} s outside (0, {seconds}] s")
    speed, start = 0.0, (data.qpos[:3].copy(), data.qpos[3:7].copy())
    for step in range(steps):
        mujoco.mj_step(model, data)
        if step == steps - window_steps:
            start = (data.qpos[:3].copy(), data.qpos[3:7].copy())
        if step >= steps - window_steps:
            speed = max(speed, float(np.linalg.norm(data.qvel[:3])))
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, data.qpos[3:7])
    object_up = {"+z": np.array([0, 0, 1.0]), "+y": np.array([0, 1.0, 0])}[up_axis]
    world_up = rotation.reshape(3, 3) @ object_up
    tilt = float(np.degrees(np.arccos(np.clip(world_up[2], -1, 1))))
    dq = np.zeros(3)
    mujoco.mju_subQuat(dq, data.qpos[3:7], start[1])
    return DropResult(
        warnings={
            str(mujoco.mjtWarning(i)).split(".")[-1]: int(w.number) for i, w in enumerate(data.warning) if w.number
        },
        tilt=tilt,
        drift=float(np.linalg.norm(data.qpos[:3] - start[0])),
        turn=float(np.degrees(np.linalg.norm(dq))),
        speed=speed,
        height=float(data.qpos[2]),
        mass=float(model.body_subtreemass[body]),
    )


def _geom_depth(model, data, geom: int) -> float:
    """How far the geom reaches below its centre (exact for meshes: their lowest vertex)."""
    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        vertices = model.mesh_vert[start : start + count] @ data.geom_xmat[geom].reshape(3, 3).T
        return float(-vertices[:, 2].min())
    return float(model.geom_rbound[geom])
