"""Exports of a generated object for other simulators: USD (usd-core) and URDF.

Both reference the same files the MJCF object uses (visual OBJ meshes, convex hull OBJ meshes,
textures), by paths relative to the exported file, and state the same mass, centre of mass and
inertia. The USD stage is written as `.usda` text from the root layer (no creation stamp), with
UsdPhysics rigid-body, mass and convex-hull collision schemas; the URDF has one link and carries a
`<mujoco><compiler .../></mujoco>` block so MuJoCo compiles it directly. usd-core is imported only
here, when an export is asked for.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from vpro_assets.core.errors import LiberoSetupError
from vpro_assets.geometry.meshes import quantize
from vpro_assets.objects.mjcf import Inertial, fmt_fixed, fmt_sci


@dataclass(frozen=True)
class ExportMesh:
    """A mesh as the exporters need it: indexed positions, optional indexed uv, its file."""

    name: str
    file: str  # relative to the exported file
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None = None
    uv_faces: np.ndarray | None = None
    rgba: tuple[float, float, float, float] | None = None
    texture_file: str | None = None  # relative to the exported file


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt
    except ImportError as exc:  # pragma: no cover - usd-core is a declared dependency
        raise LiberoSetupError("USD export needs usd-core (pip install usd-core)") from exc
    return Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt


def usd_text(name: str, visuals: list[ExportMesh], hulls: list[ExportMesh], inertial: Inertial) -> str:
    """The object as a USD stage (usda text): Z up, metres, one rigid body."""
    Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt = _pxr()
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, f"/{name}")
    stage.SetDefaultPrim(root.GetPrim())
    UsdPhysics.RigidBodyAPI.Apply(root.GetPrim())
    mass_api = UsdPhysics.MassAPI.Apply(root.GetPrim())
    mass_api.CreateMassAttr(float(inertial.mass))
    mass_api.CreateCenterOfMassAttr(Gf.Vec3f(*map(float, quantize(inertial.com))))
    eigenvalues, eigenvectors = np.linalg.eigh(inertial.inertia)
    if np.linalg.det(eigenvectors) < 0:
        eigenvectors[:, 2] *= -1
    mass_api.CreateDiagonalInertiaAttr(Gf.Vec3f(*map(float, eigenvalues)))
    # USD matrices act on row vectors: the rows of this matrix are the principal axes.
    rotation = Gf.Matrix3d(*eigenvectors.T.flatten().tolist())
    quat = Gf.Matrix4d().SetRotate(rotation).ExtractRotationQuat()
    mass_api.CreatePrincipalAxesAttr(Gf.Quatf(float(quat.GetReal()), *map(float, quat.GetImaginary())))

    for scope in ("Looks", "visual", "collision"):
        UsdGeom.Scope.Define(stage, f"/{name}/{scope}")
    for i, mesh in enumerate(visuals):
        prim = _mesh_prim(stage, f"/{name}/visual/{mesh.name}", mesh)
        material = UsdShade.Material.Define(stage, f"/{name}/Looks/material_{i}")
        shader = UsdShade.Shader.Define(stage, f"/{name}/Looks/material_{i}/surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        if mesh.texture_file is not None and mesh.uv is not None:
            reader = UsdShade.Shader.Define(stage, f"/{name}/Looks/material_{i}/st_reader")
            reader.CreateIdAttr("UsdPrimvarReader_float2")
            reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
            texture = UsdShade.Shader.Define(stage, f"/{name}/Looks/material_{i}/texture")
            texture.CreateIdAttr("UsdUVTexture")
            texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(mesh.texture_file)
            texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
            texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
            shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
                texture.ConnectableAPI(), "rgb"
            )
        else:
            rgba = mesh.rgba or (0.8, 0.8, 0.8, 1.0)
            shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, rgba[:3])))
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(material)
    for mesh in hulls:
        prim = _mesh_prim(stage, f"/{name}/collision/{mesh.name}", mesh)
        prim.CreatePurposeAttr(UsdGeom.Tokens.guide)
        UsdPhysics.CollisionAPI.Apply(prim.GetPrim())
        UsdPhysics.MeshCollisionAPI.Apply(prim.GetPrim()).CreateApproximationAttr(UsdPhysics.Tokens.convexHull)
    return stage.GetRootLayer().ExportToString()


def _mesh_prim(stage, path: str, mesh: ExportMesh):
    Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt = _pxr()
    prim = UsdGeom.Mesh.Define(stage, path)
    points = quantize(mesh.vertices).astype(np.float32)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, dtype=np.int32)))
    prim.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(mesh.faces, np.int32).reshape(-1)))
    prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    lo, hi = points.min(axis=0), points.max(axis=0)
    prim.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([lo, hi])))
    if mesh.uv is not None:
        st = UsdGeom.PrimvarsAPI(prim.GetPrim()).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying
        )
        st.Set(Vt.Vec2fArray.FromNumpy(quantize(mesh.uv).astype(np.float32)))
        st.SetIndices(Vt.IntArray.FromNumpy(np.asarray(mesh.uv_faces, np.int32).reshape(-1)))
    return prim


def urdf_text(name: str, visuals: list[ExportMesh], hulls: list[ExportMesh], inertial: Inertial) -> str:
    """One-link URDF (yourdfpy loads it; MuJoCo compiles it, reading meshes from their folder)."""
    robot = ET.Element("robot", {"name": name})
    ET.SubElement(
        ET.SubElement(robot, "mujoco"),
        "compiler",
        {"strippath": "false", "discardvisual": "true", "balanceinertia": "false", "fusestatic": "false"},
    )
    link = ET.SubElement(robot, "link", {"name": name})
    inertial_el = ET.SubElement(link, "inertial")
    ET.SubElement(inertial_el, "origin", {"xyz": fmt_fixed(inertial.com), "rpy": "0 0 0"})
    ET.SubElement(inertial_el, "mass", {"value": fmt_sci(inertial.mass)})
    i = inertial.inertia
    ET.SubElement(
        inertial_el,
        "inertia",
        {
            "ixx": fmt_sci(i[0, 0]),
            "ixy": fmt_sci(i[0, 1]),
            "ixz": fmt_sci(i[0, 2]),
            "iyy": fmt_sci(i[1, 1]),
            "iyz": fmt_sci(i[1, 2]),
            "izz": fmt_sci(i[2, 2]),
        },
    )
    for mesh in visuals:
        visual = ET.SubElement(link, "visual", {"name": mesh.name})
        ET.SubElement(ET.SubElement(visual, "geometry"), "mesh", {"filename": mesh.file})
        rgba = mesh.rgba or (0.8, 0.8, 0.8, 1.0)
        material = ET.SubElement(visual, "material", {"name": f"{mesh.name}_material"})
        ET.SubElement(material, "color", {"rgba": fmt_fixed(rgba, 4)})
    for mesh in hulls:
        collision = ET.SubElement(link, "collision", {"name": mesh.name})
        ET.SubElement(ET.SubElement(collision, "geometry"), "mesh", {"filename": mesh.file})
    ET.indent(robot, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"
