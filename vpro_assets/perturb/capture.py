"""Semantic masks of the exact scene the env drew, from a render of only the geoms that matter.

A segmentation render of the whole scene (the reference, `rendering.render_geom_ids`) costs
about as much as the env's own camera frame on llvmpipe. So, while the env renders a camera
(`RenderHook` calls `capture`), the scene entries of the entities and of the geoms that can cover
them (`occluders.relevant_geoms`) are copied from the very `MjvScene` the env just drew (same
state, same camera: the policy's frame and the mask cannot disagree), with the pixel window the
entities can occupy. Only when a mask is asked for are they drawn, in MuJoCo's segmentation mode,
into a scene of their own, through a frustum narrowed to that window (the same pixel centres, a
viewport of the window's size). The result equals the full-scene segmentation at every pixel of
the entities: depth tests between the geoms drawn are the same, and a geom that was left out
could not have drawn on those pixels.

Why not the depth of the env's colour pass (compared with an entity-only pass)? LIBERO renders
with 4x multisampling; the resolved depth is the depth at one sub-pixel sample (measured: offset
(-0.125, -0.375) px), while segmentation renders at pixel centres without multisampling. At
silhouettes and contacts the two disagree: over 240 frames of libero_spatial-00 the depth test
matched the segmentation with IoU 0.98 at the median and 0.90 at worst (docs/perturbations.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.perturb import scene_edits
from vpro_assets.perturb.occluders import GeomHulls, View, drawable_geoms, relevant_geoms

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
    geoms that can cover them, plus every non-geom entry the colour frame shows (few; they may
    cover anything), and the pixel window the entities can occupy."""
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
            if g.segid >= 0 and not scene_edits.invisible(g) and (g.objtype != _GEOM or keep[g.objid]):
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
