"""Semantic masks of the exact scene the env drew, from a render of only the geoms that matter.

A segmentation render of the whole scene (the reference, `rendering.render_geom_ids`) costs
about as much as the env's own camera frame on llvmpipe. Which geom is frontmost at an entity's
pixel depends only on the entity's geoms and on the geoms that can cover them: those whose
bounds, projected into the camera, overlap the entity's footprint and are not entirely behind it
(bounds: the geom's box clipped to the near plane, tightened by its convex-hull points where it
lies wholly in front; planes are always kept). So, while the env renders a camera (`RenderHook`
calls `capture`), the scene entries of the entities and of those possible occluders are copied
from the very `MjvScene` the env just drew (same state, same camera: the policy's frame and the
mask cannot disagree), with the pixel window the entities can occupy. Only when a mask is asked
for are they drawn, in MuJoCo's segmentation mode, into a scene of their own, through a frustum
narrowed to that window (the same pixel centres, a viewport of the window's size). The result
equals the full-scene segmentation at every pixel of the entities: depth tests between the geoms
drawn are the same, and a geom that was left out could not have drawn on those pixels.

Why not the depth of the env's colour pass (compared with an entity-only pass)? LIBERO renders
with 4x multisampling; the resolved depth is the depth at one sub-pixel sample (measured: offset
(-0.125, -0.375) px), while segmentation renders at pixel centres without multisampling. At
silhouettes and contacts the two disagree: over 240 frames of libero_spatial-00 the depth test
matched the segmentation with IoU 0.98 at the median and 0.90 at worst (docs/perturbations.md).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from vpro_assets.perturb import scene_edits

_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)
_CAMERA_FIELDS = (
    "pos",
    "forward",
    "up",
    "frustum_center",
    "frustum_width",
    "frustum_bottom",
    "frustum_top",
    "frustum_near",
    "frustum_far",
    "orthographic",
)


@dataclass
class Capture:
    """What `draw_ids` needs to draw one camera's entities and their possible occluders."""

    camera_id: int
    width: int
    height: int
    entries: list[dict]  # scene_edits snapshots, in the scene's draw order
    cameras: tuple[dict, ...]  # the scene's two GL cameras (stereo halves; equal in mono)
    generation: int  # RenderHook's capture counter when taken
    window: tuple[int, int, int, int] | None = None  # pixels (x0, y0, x1, y1) to draw; None: nothing
    label_windows: dict[str, tuple[int, int, int, int] | None] | None = None  # per entity, same bounds

    def key(self) -> bytes:
        """Everything the segmentation render depends on: equal keys draw equal pixels."""
        parts = [
            np.array([self.camera_id, self.width, self.height, *(self.window or (-1,) * 4)], dtype=np.int64).tobytes()
        ]
        for cam in self.cameras:
            parts += [np.asarray(v, dtype=np.float64).tobytes() for v in cam.values()]
        for e in self.entries:
            parts += [
                e["pos"].tobytes(),
                e["mat"].tobytes(),
                e["size"].tobytes(),
                np.array([e["type"], e["dataid"], e["segid"], e["objtype"], e["objid"]], dtype=np.int64).tobytes(),
            ]
        return b"".join(parts)


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
    vertices (scipy), the box corners of `geom_aabb` otherwise. Cached by mesh name and size, so
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


def capture(
    ctx,
    model,
    data,
    camera_id: int,
    width: int,
    height: int,
    entity_geoms: np.ndarray,
    generation: int,
    candidates: np.ndarray | None = None,
    hulls: GeomHulls | None = None,
    groups: dict[str, np.ndarray] | None = None,
) -> Capture:
    """Copy, from the scene the env just drew (`ctx.scn`), the entries of the entities and of the
    geoms that can cover them, plus every non-geom entry (few; they may cover anything), and the
    pixel window the entities can occupy."""
    scn = ctx.scn
    cams = tuple(
        {f: (getattr(c, f).copy() if isinstance(getattr(c, f), np.ndarray) else getattr(c, f)) for f in _CAMERA_FIELDS}
        for c in (scn.camera[0], scn.camera[1])
    )
    if candidates is None:
        candidates = drawable_geoms(model, ctx.vopt)
    keep, window, label_windows = relevant_geoms(
        model,
        data,
        camera_id,
        np.asarray(entity_geoms),
        candidates,
        View.of(cams[0], width, height),
        hulls or GeomHulls(),
        groups,
    )
    entries = []
    if window is not None:
        for i in range(scn.ngeom):
            g = scn.geoms[i]
            if g.segid >= 0 and (g.objtype != _GEOM or keep[g.objid]):
                entries.append(scene_edits.snapshot(g))
    return Capture(camera_id, width, height, entries, cams, generation, window, label_windows)


class CaptureRenderer:
    """Draws captures in segmentation mode into a scene of its own (the env's scene is untouched).

    A camera whose captured entries and view did not change since its last draw (a fixed camera
    while the entities and what can cover them stand still) gets the previous ids again: the same
    inputs draw the same pixels. `draws` and `reuses` count both cases."""

    def __init__(self, model):
        self.scn = mujoco.MjvScene(model, maxgeom=1000)
        self._last: dict[int, tuple[bytes, np.ndarray]] = {}
        self.draws = self.reuses = 0

    def draw_ids(self, ctx, cap: Capture) -> np.ndarray:
        """Raw (bottom-up) int32 geom id per pixel, -1 for background and non-geom entries; exact
        at the captured entities' pixels, and wherever a drawn geom is frontmost in the full scene."""
        key = cap.key()
        last = self._last.get(cap.camera_id)
        if last is not None and last[0] == key:
            self.reuses += 1
            return last[1]
        ids = self._draw(ctx, cap)
        ids.flags.writeable = False  # shared with later steps
        self._last[cap.camera_id] = (key, ids)
        self.draws += 1
        return ids

    def _draw(self, ctx, cap: Capture) -> np.ndarray:
        ids = np.full((cap.height, cap.width), -1, dtype=np.int32)
        if cap.window is None:
            return ids
        x0, y0, x1, y1 = cap.window
        scn = self.scn
        if len(cap.entries) > scn.maxgeom:
            self.scn = scn = mujoco.MjvScene(ctx.model._model, maxgeom=len(cap.entries))
        for j, snap in enumerate(cap.entries):
            scene_edits.write(scn.geoms[j], snap)
        scn.ngeom = len(cap.entries)
        view = View.of(cap.cameras[0], cap.width, cap.height)
        pw, ph = (view.right - view.left) / view.width, (view.top - view.bottom) / view.height
        for c, values in zip((scn.camera[0], scn.camera[1]), cap.cameras):
            for f, v in values.items():
                if isinstance(v, np.ndarray):
                    getattr(c, f)[...] = v
                else:
                    setattr(c, f, v)
            if (x0, y0, x1, y1) == (0, 0, cap.width, cap.height):
                continue  # the whole image: the env's own frustum
            # the frustum of the window only: the same pixel centres, a viewport of the window's size
            c.frustum_center = view.left + (x0 + x1) / 2 * pw
            c.frustum_width = (x1 - x0) / 2 * pw
            c.frustum_bottom, c.frustum_top = view.bottom + y0 * ph, view.bottom + y1 * ph
        scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
        scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        w, h = x1 - x0, y1 - y0
        if w > ctx.con.offWidth or h > ctx.con.offHeight:
            ctx.update_offscreen_size(max(w, ctx.model.vis.global_.offwidth), max(h, ctx.model.vis.global_.offheight))
        viewport = mujoco.MjrRect(0, 0, w, h)
        mujoco.mjr_render(viewport=viewport, scn=scn, con=ctx.con)
        rgb = np.empty((h, w, 3), dtype=np.uint8)
        mujoco.mjr_readPixels(rgb=rgb, depth=None, viewport=viewport, con=ctx.con)
        ids[y0:y1, x0:x1] = decode_ids(rgb, scn)
        return ids


def decode_ids(rgb: np.ndarray, scn: mujoco.MjvScene) -> np.ndarray:
    """Geom ids of a segmentation frame (pixel value = segid + 1, 0 = background)."""
    seg = rgb[..., 0].astype(np.int32) | (rgb[..., 1].astype(np.int32) << 8) | (rgb[..., 2].astype(np.int32) << 16)
    segids, objids = [], []
    for i in range(scn.ngeom):
        g = scn.geoms[i]
        if g.segid >= 0 and g.objtype == _GEOM:
            segids.append(g.segid)
            objids.append(g.objid)
    lut = np.full(max(segids, default=0) + 2, -1, dtype=np.int32)
    lut[np.asarray(segids, dtype=np.int64) + 1] = objids
    seg[seg >= len(lut)] = 0
    return lut[seg]


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
