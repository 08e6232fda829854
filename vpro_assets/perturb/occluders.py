"""Which geoms can cover an entity in a camera, and the pixel window it can occupy.

Which geom is frontmost at an entity's pixel depends only on the entity's geoms and on the geoms
that can cover them: those whose bounds, projected into the camera, overlap the entity's footprint
and are not entirely behind it. Bounds: the geom's box (`geom_aabb`) clipped to the near plane,
tightened by its convex-hull points where it lies wholly in front; planes are always kept.
`relevant_geoms` gives those geoms and the pixel window of the footprint; `capture` copies them
from the scene the env drew.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError

_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
_EDGES = np.array([(a, b) for a in range(8) for b in range(a + 1, 8) if np.sum(_SIGNS[a] != _SIGNS[b]) == 1])


def drawable_geoms(model, vopt) -> np.ndarray:
    """Ids of the geoms `mjv_updateScene` may draw with these options (their group is shown)."""
    groups = np.clip(model.geom_group, 0, len(vopt.geomgroup) - 1)
    return np.flatnonzero(np.asarray(vopt.geomgroup)[groups] != 0)


def _image_boxes(model, data, geoms: np.ndarray, camera_id: int, near: float):
    """Per geom: its bounding box (`geom_aabb`, in the geom's frame) clipped to the camera's near
    plane and projected to the normalised image plane (u = x/z, v = y/z; MuJoCo cameras look along
    their frame's -z): (u_lo, u_hi, v_lo, v_hi, z_lo, z_hi, in_front). The clipped box is convex,
    so its projection is bounded by its corners in front of the plane and the points where its
    edges cross the plane."""
    aabb = model.geom_aabb[geoms]
    corners = aabb[:, None, :3] + aabb[:, None, 3:] * _SIGNS[None]  # (n, 8, 3), geom frame
    world = data.geom_xpos[geoms, None, :] + np.einsum("gij,gkj->gki", data.geom_xmat[geoms].reshape(-1, 3, 3), corners)
    cam = (world - data.cam_xpos[camera_id]) @ data.cam_xmat[camera_id].reshape(3, 3)
    x, y, z = cam[..., 0], cam[..., 1], -cam[..., 2]
    a, b = _EDGES[:, 0], _EDGES[:, 1]
    za, zb = z[:, a], z[:, b]
    crosses = (za < near) != (zb < near)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crosses, (near - za) / (zb - za), 0.0)
    xe, ye = x[:, a] + t * (x[:, b] - x[:, a]), y[:, a] + t * (y[:, b] - y[:, a])
    front = z >= near
    zc = np.where(front, z, 1.0)
    us = np.concatenate([np.where(front, x / zc, np.nan), np.where(crosses, xe / near, np.nan)], axis=1)
    vs = np.concatenate([np.where(front, y / zc, np.nan), np.where(crosses, ye / near, np.nan)], axis=1)
    zs = np.concatenate([np.where(front, z, np.nan), np.where(crosses, near, np.nan)], axis=1)
    in_front = front.any(axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: geoms wholly behind the camera
        return (
            np.nanmin(us, 1),
            np.nanmax(us, 1),
            np.nanmin(vs, 1),
            np.nanmax(vs, 1),
            np.nanmin(zs, 1),
            np.nanmax(zs, 1),
            in_front,
        )


class GeomHulls:
    """Points in each geom's frame whose convex hull contains the geom: a mesh's convex-hull
    vertices (scipy), the box corners of `geom_aabb` otherwise. The masks bound what can cover an
    entity with them, the oracle measures what it grasps (a deformed can's convex pieces are
    about a centimetre narrower than their boxes). Cached by mesh name and size, so
    a rebuilt sim (robosuite's hard reset) reuses them."""

    def __init__(self):
        self._mesh: dict[tuple[str, int], np.ndarray] = {}
        self._geom: dict[int, np.ndarray] = {}
        self._model = None

    def points(self, model, geom: int) -> np.ndarray:
        if model is not self._model:  # a rebuilt sim: geom ids may have changed
            self._model, self._geom = model, {}
        if geom not in self._geom:
            self._geom[geom] = self._points(model, geom)
        return self._geom[geom]

    def _points(self, model, geom: int) -> np.ndarray:
        box = model.geom_aabb[geom, :3] + model.geom_aabb[geom, 3:] * _SIGNS
        mesh = int(model.geom_dataid[geom])
        if model.geom_type[geom] != mujoco.mjtGeom.mjGEOM_MESH or mesh < 0:
            return box
        key = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MESH, mesh) or str(mesh), int(model.mesh_vertnum[mesh]))
        if key not in self._mesh:
            adr, n = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            verts = np.asarray(model.mesh_vert[adr : adr + n], dtype=np.float64)
            try:
                self._mesh[key] = verts[ConvexHull(verts).vertices]
            except QhullError:  # flat or degenerate: its box still bounds it
                self._mesh[key] = box
        return self._mesh[key]

    def world(self, model, data, geoms) -> list[np.ndarray]:
        """Each geom's hull points carried to the world by its pose in `data`."""
        return [self.points(model, g) @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g] for g in geoms]


def _hull_boxes(model, data, geoms: np.ndarray, hulls: GeomHulls, camera_id: int, near: float):
    """Like `_image_boxes` from the geoms' hull points, tighter for round shapes; `ok` is False
    where a point lies before the near plane (those geoms keep their clipped-box bounds)."""
    cam_mat, cam_pos = data.cam_xmat[camera_id].reshape(3, 3), data.cam_xpos[camera_id]
    out = np.empty((7, len(geoms)))
    for k, g in enumerate(geoms):
        # camera-frame points: (R_g p + x_g - c) expressed in the camera's axes
        rot = data.geom_xmat[g].reshape(3, 3).T @ cam_mat
        cam = hulls.points(model, int(g)) @ rot + (data.geom_xpos[g] - cam_pos) @ cam_mat
        z = -cam[:, 2]
        zmin = z.min()
        zs = np.maximum(z, near)
        u, v = cam[:, 0] / zs, cam[:, 1] / zs
        out[:, k] = (u.min(), u.max(), v.min(), v.max(), zmin, z.max(), zmin >= near)
    return (*out[:6], out[6].astype(bool))


@dataclass(frozen=True)
class View:
    """A camera's frustum at its near plane and its image size."""

    near: float
    left: float
    right: float
    bottom: float
    top: float
    width: int
    height: int

    @classmethod
    def of(cls, cam: dict, width: int, height: int) -> View:
        b, t = cam["frustum_bottom"], cam["frustum_top"]
        hw = cam["frustum_width"] or 0.5 * width / height * (t - b)  # as mjr_render's setView
        c = cam["frustum_center"]
        return cls(cam["frustum_near"], c - hw, c + hw, b, t, width, height)

    def pixel_window(self, u0: float, u1: float, v0: float, v1: float) -> tuple[int, int, int, int] | None:
        """Pixel columns [x0, x1) and rows [y0, y1) (raw, bottom-up) covering the image-plane box
        (u = x/z, v = y/z) with a pixel of margin, clipped to the image; None if outside it."""
        pw, ph = (self.right - self.left) / self.width, (self.top - self.bottom) / self.height
        x0 = max(int(np.floor((u0 * self.near - self.left) / pw)) - 1, 0)
        x1 = min(int(np.ceil((u1 * self.near - self.left) / pw)) + 1, self.width)
        y0 = max(int(np.floor((v0 * self.near - self.bottom) / ph)) - 1, 0)
        y1 = min(int(np.ceil((v1 * self.near - self.bottom) / ph)) + 1, self.height)
        return (x0, y0, x1, y1) if x0 < x1 and y0 < y1 else None


def relevant_geoms(
    model,
    data,
    camera_id: int,
    entity_geoms: np.ndarray,
    candidates: np.ndarray,
    view: View,
    hulls: GeomHulls,
    groups: dict[str, np.ndarray] | None = None,
):
    """Boolean per model geom: an entity geom, or one of `candidates` (the geoms the scene may
    draw) that can cover one in this camera (its projected bounds overlap the entities' footprint
    and it is not wholly behind them; planes always), and the pixel window of the footprint (None:
    the entities are out of view, nothing to draw), and the window of each group of `groups`
    (label -> geoms) on its own."""
    out = np.zeros(model.ngeom, dtype=bool)
    groups = groups or {}
    none = dict.fromkeys(groups)
    entity_geoms = np.intersect1d(entity_geoms, candidates)  # geoms the scene does not draw leave no pixel
    if not len(entity_geoms):
        return out, None, none
    out[entity_geoms] = True
    out |= model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE
    geoms = candidates
    u0, u1, v0, v1, z0, z1, front = _image_boxes(model, data, geoms, camera_id, view.near)
    e = np.isin(geoms, entity_geoms) & front
    if not e.any():
        return out, None, none

    def refine(idx: np.ndarray) -> None:  # hull bounds where every hull point is before the camera
        hu0, hu1, hv0, hv1, hz0, hz1, ok = _hull_boxes(model, data, geoms[idx], hulls, camera_id, view.near)
        for arr, h in ((u0, hu0), (u1, hu1), (v0, hv0), (v1, hv1), (z0, hz0), (z1, hz1)):
            arr[idx[ok]] = h[ok]

    refine(np.flatnonzero(e))
    window = view.pixel_window(u0[e].min(), u1[e].max(), v0[e].min(), v1[e].max())
    label_windows = {}
    for label, members in groups.items():
        g = e & np.isin(geoms, members)
        label_windows[label] = (
            view.pixel_window(u0[g].min(), u1[g].max(), v0[g].min(), v1[g].max()) if g.any() else None
        )
    if window is None:
        return out, None, none
    # the window back on the image plane: what lies outside it cannot draw on the entities' pixels
    x0, y0, x1, y1 = window
    pw, ph = (view.right - view.left) / view.width, (view.top - view.bottom) / view.height
    wu0, wu1 = (view.left + x0 * pw) / view.near, (view.left + x1 * pw) / view.near
    wv0, wv1 = (view.bottom + y0 * ph) / view.near, (view.bottom + y1 * ph) / view.near
    far = z1[e].max()

    def overlapping() -> np.ndarray:
        return front & (u0 <= wu1) & (u1 >= wu0) & (v0 <= wv1) & (v1 >= wv0) & (z0 <= far)

    refine(np.flatnonzero(overlapping() & ~e))  # boxes first (cheap), hulls for what they keep
    out[geoms[overlapping()]] = True
    return out, window, label_windows


def windows_may_meet(a: tuple[int, int, int, int] | None, b: tuple[int, int, int, int] | None, radius: int) -> bool:
    """False when no pixel can lie within `radius` of both windows' contents (so the contact
    region of two entities inside them is empty without drawing them)."""
    if a is None or b is None:
        return False
    return (
        a[0] - radius < b[2] + radius
        and b[0] - radius < a[2] + radius
        and a[1] - radius < b[3] + radius
        and b[1] - radius < a[3] + radius
    )
