"""Edits of a MuJoCo `MjvScene` between `mjv_updateScene` and `mjr_render`.

The scene is the per-frame list of geoms a camera draws; editing it changes one camera's picture
and nothing else (the model, the data and the physics are untouched, the next `mjv_updateScene`
rebuilds the list from the simulation). Operations: find the scene entries of some geoms, move or
rotate them rigidly, remove them, and append copies (snapshots) of them.
"""

from __future__ import annotations

from collections.abc import Iterable

import mujoco
import numpy as np

_ARRAY_FIELDS = ("size", "pos", "mat", "rgba")
_SCALAR_FIELDS = (
    "type",
    "dataid",
    "objtype",
    "objid",
    "category",
    "matid",
    "texcoord",
    "segid",
    "emission",
    "specular",
    "shininess",
    "reflectance",
    "label",
    "transparent",
    "camdist",
    "modelrbound",
)
_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


def snapshot(geom) -> dict:
    """The fields of one scene geom, detached from the scene."""
    out = {f: getattr(geom, f).copy() for f in _ARRAY_FIELDS}
    out.update({f: getattr(geom, f) for f in _SCALAR_FIELDS})
    return out


def write(geom, snap: dict) -> None:
    for f in _ARRAY_FIELDS:
        getattr(geom, f)[...] = snap[f]
    for f in _SCALAR_FIELDS:
        setattr(geom, f, snap[f])


def find(scn: mujoco.MjvScene, geom_ids: Iterable[int]) -> list[int]:
    """Scene indices of the entries drawing any of `geom_ids`."""
    wanted = {int(g) for g in geom_ids}
    return [i for i in range(scn.ngeom) if scn.geoms[i].objtype == _GEOM and scn.geoms[i].objid in wanted]


def remove(scn: mujoco.MjvScene, indices: Iterable[int]) -> None:
    """Delete entries, keeping the order of the others (the draw order of transparent geoms)."""
    drop = set(indices)
    if not drop:
        return
    keep = [snapshot(scn.geoms[i]) for i in range(scn.ngeom) if i not in drop]
    first = min(drop)
    tail = keep[first:]
    for offset, snap in enumerate(tail):
        write(scn.geoms[first + offset], snap)
    scn.ngeom = len(keep)


def invisible(geom) -> bool:
    """An entry the colour pass does not show: robosuite hides its visualisation sites (the grip
    site's 10 m cylinder, a stove's burner disc) by negating their alpha, which draws nothing in
    colour but an opaque patch in MuJoCo's segmentation mode."""
    return bool(geom.rgba[3] <= 0)


def remove_invisible(scn: mujoco.MjvScene) -> None:
    """Delete the entries the colour pass does not show, so a segmentation render shows what the
    camera's frame shows."""
    remove(scn, [i for i in range(scn.ngeom) if invisible(scn.geoms[i])])


def visual_center(scn: mujoco.MjvScene, indices: list[int], model: mujoco.MjModel) -> np.ndarray:
    """World centre of the bounding boxes of some entries (geom AABBs from the model)."""
    centers = []
    for i in indices:
        g = scn.geoms[i]
        local = model.geom_aabb[g.objid][:3] if 0 <= g.objid < model.ngeom else np.zeros(3)
        centers.append(g.pos + g.mat.reshape(3, 3) @ local)
    return np.mean(centers, axis=0)


def transform(
    scn: mujoco.MjvScene,
    indices: list[int],
    rotation: np.ndarray | None = None,
    center: np.ndarray | None = None,
    offset: np.ndarray | None = None,
) -> None:
    """Rigidly move entries: rotate by `rotation` about `center`, then translate by `offset`."""
    for i in indices:
        g = scn.geoms[i]
        pos, mat = g.pos.copy(), g.mat.reshape(3, 3).copy()
        if rotation is not None:
            pos = center + rotation @ (pos - center)
            mat = rotation @ mat
        if offset is not None:
            pos = pos + offset
        g.pos[...] = pos
        g.mat[...] = mat.reshape(g.mat.shape)


def set_poses(scn: mujoco.MjvScene, indices: list[int], xpos: np.ndarray, xmat: np.ndarray) -> None:
    """Place entries at the geom poses of another kinematic state (geom_xpos, geom_xmat rows)."""
    for i in indices:
        g = scn.geoms[i]
        g.pos[...] = xpos[g.objid]
        g.mat[...] = xmat[g.objid].reshape(g.mat.shape)


def append(scn: mujoco.MjvScene, snaps: list[dict], offset: np.ndarray | None = None) -> None:
    """Add copies of snapshot entries (translated by `offset`) at the end of the scene."""
    if scn.ngeom + len(snaps) > scn.maxgeom:
        return  # MuJoCo's own behaviour when the scene is full: extra geoms are not drawn
    for snap in snaps:
        g = scn.geoms[scn.ngeom]
        write(g, snap)
        if offset is not None:
            g.pos[...] = g.pos + offset
        g.segid = scn.ngeom  # unique segmentation id, as mjv_updateScene assigns them
        scn.ngeom += 1
