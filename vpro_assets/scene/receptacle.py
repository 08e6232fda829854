"""The room an enclosed receptacle leaves an object, measured on a compiled scene: a drawer of a
cabinet, a microwave, any region of a fixture with a ceiling over it.

`clearance(model, data, region)` reads the fixture's collision geoms (MuJoCo's own boxes of them,
`core.mjgeom`) in the scene's state (a drawer as LIBERO's initial state leaves it, open or closed):

- floor: the top of the highest geom of the region's moving part (the drawer; the whole fixture
  when the region does not move) under the region's centre;
- ceiling: the bottom of the lowest geom of the fixture, outside the moving part, over the
  region's box with the part closed (a slide joint at 0: the drawer pushed home), above the
  floor. No such geom: the region is open above, not enclosed (None);
- radius: the horizontal room about the region's centre, the distance to the nearest of the
  part's walls (its geoms standing over the floor) and of the ceiling's geoms (those within
  CEILING_BAND_M of the ceiling's bottom) over the part as it stands: the mouth of an opened drawer
  ends at the fixture's front over it. An object whose body position is at the region's centre
  (where LIBERO's `In` and a policy aim it) fits when it reaches no further from its vertical axis.

`object_size(model, data, body)` is the same measure of an object: its collision geoms' points
(mesh vertices, box corners) as reach from the body's vertical axis and height. `resting_size(xml,
up_axis)` takes it of an object file not in the scene, standing at rest on a table as objects stand
in the settled scenes where the room and the original are measured. Upright is not at rest: the
asymmetric-s1 bowl rests 0.7 degrees off its mesh's axis, reaching 5.72 cm and standing 5.18 cm as
in its built libero_10-03 scene, where upright it would reach 5.66 and stand 5.26.

libero_10-03 (the bottom drawer of the white cabinet, opened): floor 0.926, ceiling 0.983 (the
cabinet's shelf under the middle drawer), radius 5.7 cm (to the middle drawer's front, the drawer
open 14.6 cm); LIBERO's black bowl reaches 5.4 cm and stands 5.2 cm.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from vpro_assets.core.mjgeom import colliding, geom_corners, subtree
from vpro_assets.objects.mjcf import dropped_world

CEILING_BAND_M = 0.02  # geoms whose bottom is this close to the ceiling's are part of it (its front panels)
WALL_MIN_M = 0.01  # a geom of the part rising this far over the floor is a wall
REST_SECONDS = 1.0  # an object dropped 3 mm onto a table is still within 0.5 s (its measure to 0.1 mm)


@dataclass(frozen=True)
class Clearance:
    region: str
    floor: float  # z of the floor's top
    ceiling: float  # z of the ceiling's bottom, the part closed
    radius: float  # horizontal room about the region's centre

    @property
    def height(self) -> float:
        return self.ceiling - self.floor

    def to_json(self) -> dict:
        return {"region": self.region, "floor": self.floor, "ceiling": self.ceiling, "radius": self.radius}


def _boxes(model, data, geoms: list[int]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    out = {}
    for g in geoms:
        c = geom_corners(model, data, [g])
        out[g] = (c.min(0), c.max(0))
    return out


def _gap(lo: np.ndarray, hi: np.ndarray, xy: np.ndarray) -> float:
    """Horizontal distance from `xy` to a box (0 inside it)."""
    d = np.maximum(0.0, np.maximum(lo[:2] - xy, xy - hi[:2]))
    return float(np.linalg.norm(d))


def _overlaps(lo: np.ndarray, hi: np.ndarray, rlo: np.ndarray, rhi: np.ndarray) -> bool:
    return bool(np.all(lo[:2] < rhi[:2]) and np.all(rlo[:2] < hi[:2]))


def clearance(model, data, region: str) -> Clearance | None:
    """The room of a fixture's region with a ceiling (see the module doc); None when the region is
    open above or is not a site of the scene."""
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, region)
    if site < 0:
        return None
    body = int(model.site_bodyid[site])
    root = int(model.body_rootid[body])
    fixture = colliding(model, [g for g in range(model.ngeom) if int(model.body_rootid[model.geom_bodyid[g]]) == root])
    # The moving part: the subtree of the nearest body up from the site that a joint moves.
    part_body, joint = body, -1
    while part_body != root and joint < 0:
        joints = [j for j in range(model.njnt) if model.jnt_bodyid[j] == part_body]
        joint = joints[0] if joints else -1
        part_body = part_body if joint >= 0 else int(model.body_parentid[part_body])
    part = (
        set(fixture)
        if joint < 0
        else set(colliding(model, [g for g in fixture if model.geom_bodyid[g] in set(subtree(model, part_body))]))
    )
    center = data.site_xpos[site].copy()
    half = np.abs(data.site_xmat[site].reshape(3, 3)) @ model.site_size[site]
    boxes = _boxes(model, data, fixture)
    under = [
        hi[2] for g, (lo, hi) in boxes.items() if g in part and _gap(lo, hi, center[:2]) == 0 and hi[2] <= center[2]
    ]
    if not under:
        return None
    floor = float(max(under))
    # With the part closed: a slide joint at 0 (LIBERO's drawers are closed there).
    shift = np.zeros(3)
    if joint >= 0 and model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_SLIDE:
        shift = -data.xaxis[joint] * float(data.qpos[model.jnt_qposadr[joint]])
    rlo, rhi = center - half + shift, center + half + shift
    others = {g: b for g, b in boxes.items() if g not in part}
    over = [lo[2] for lo, hi in others.values() if lo[2] > floor and _overlaps(lo, hi, rlo, rhi)]
    if not over:
        return None
    ceiling = float(min(over))
    # The room about the centre as the part stands: its walls, and the ceiling's geoms over it.
    plo, phi = center - half, center + half
    walls = [
        _gap(lo, hi, center[:2])
        for g, (lo, hi) in boxes.items()
        if g in part and hi[2] > floor + WALL_MIN_M and lo[2] < center[2] and _gap(lo, hi, center[:2]) > 0
    ]
    covers = [
        _gap(lo, hi, center[:2])
        for lo, hi in others.values()
        if floor < lo[2] <= ceiling + CEILING_BAND_M and _overlaps(lo, hi, plo - [0.1, 0.1, 0], phi + [0.1, 0.1, 0])
    ]
    room = [d for d in walls + covers if d > 0]
    radius = float(min(room)) if room else float(np.linalg.norm(half[:2]))
    return Clearance(region, floor, ceiling, radius)


def object_size(model, data, body: str) -> tuple[float, float]:
    """(reach, height) of an object: the farthest its collision geoms' points lie from the vertical
    line through the body's position, and their vertical extent."""
    root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
    if root < 0:
        raise ValueError(f"no body {body!r} in the scene")
    bodies = set(subtree(model, root))
    geoms = colliding(model, [g for g in range(model.ngeom) if model.geom_bodyid[g] in bodies])
    pts = []
    for g in geoms:
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            verts = model.mesh_vert[start : start + count]
            pts.append(verts @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g])
        else:
            pts.append(geom_corners(model, data, [g]))
    p = np.concatenate(pts)
    reach = float(np.linalg.norm(p[:, :2] - data.xpos[root][:2], axis=1).max())
    return reach, float(p[:, 2].max() - p[:, 2].min())


def resting_size(xml_path: Path | str, up_axis: str) -> tuple[float, float]:
    """`object_size` of the object of `xml_path` (LIBERO's object layout) dropped upright (its
    `up_axis` up, as LIBERO places it) onto a table, after REST_SECONDS."""
    model, data = dropped_world(xml_path, up_axis)
    for _ in range(round(REST_SECONDS / model.opt.timestep)):
        mujoco.mj_step(model, data)
    return object_size(model, data, "object")
