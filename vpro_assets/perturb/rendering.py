"""One camera frame from robosuite's offscreen render context, with an optional scene edit.

robosuite's `MjRenderContext.render` runs `mjv_updateScene` then `mjr_render`; the frames of the
policy's cameras come from it. `render_frame` does the same steps on the same context (same
scene options, same buffers, so an unedited frame is byte-identical to robosuite's) and lets a
caller edit the `MjvScene` in between: that is how one camera can be shown a contradicted scene
while the simulation, and every other camera, stay untouched. Segmentation frames use MuJoCo's
own segmentation mode and decode to geom ids (-1 for background and non-geom objects).
`render_geom_ids` (a full-scene segmentation render) is the reference for masks; the pipeline
draws masks from the scene the env itself drew (`capture`), which gives the same ids at the
entities' pixels for a fraction of the cost.

`RenderHook` replaces the context's `render` method (on the instance only) so that robosuite's
own camera sensors go through `render_frame` with the edit of their camera; robosuite re-creates
the context on every hard reset, so the hook is installed again after each reset. When masks are
needed it also copies, from each camera's scene, the entries of the entities and of what can
cover them (`capture.capture`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping

import mujoco
import numpy as np

from vpro_assets.core.errors import VProError
from vpro_assets.perturb import scene_edits
from vpro_assets.perturb.capture import Capture, capture, decode_ids
from vpro_assets.perturb.occluders import GeomHulls, drawable_geoms

log = logging.getLogger(__name__)

SceneEdit = Callable[[mujoco.MjvScene], None]


def render_context(sim):
    ctx = getattr(sim, "_render_context_offscreen", None)
    if ctx is None:
        raise VProError("the env has no offscreen render context; build it with has_offscreen_renderer=True")
    return ctx


def _prepare(ctx, width: int, height: int, camera_id: int | None) -> mujoco.MjrRect:
    if width > ctx.con.offWidth or height > ctx.con.offHeight:
        ctx.update_offscreen_size(
            max(width, ctx.model.vis.global_.offwidth), max(height, ctx.model.vis.global_.offheight)
        )
    if camera_id is not None:
        ctx.cam.type = mujoco.mjtCamera.mjCAMERA_FREE if camera_id == -1 else mujoco.mjtCamera.mjCAMERA_FIXED
        ctx.cam.fixedcamid = camera_id
    mujoco.mjv_updateScene(
        ctx.model._model, ctx.data._data, ctx.vopt, ctx.pert, ctx.cam, mujoco.mjtCatBit.mjCAT_ALL, ctx.scn
    )
    return mujoco.MjrRect(0, 0, width, height)


def draw(
    ctx, width: int, height: int, camera_id: int | None, edit: SceneEdit | None = None, segmentation: bool = False
) -> None:
    """Update the scene for a camera, apply `edit`, and draw into the offscreen buffer."""
    viewport = _prepare(ctx, width, height, camera_id)
    if edit is not None:
        edit(ctx.scn)
    if segmentation:
        ctx.scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
        ctx.scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
    try:
        mujoco.mjr_render(viewport=viewport, scn=ctx.scn, con=ctx.con)
    finally:
        if segmentation:
            ctx.scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 0
            ctx.scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 0


def render_rgb(sim, camera: str, width: int, height: int, edit: SceneEdit | None = None) -> np.ndarray:
    """A raw (bottom-up) RGB frame of `camera`, as robosuite's camera sensor would return it."""
    ctx = render_context(sim)
    draw(ctx, width, height, sim.model.camera_name2id(camera), edit)
    rgb = np.empty((height, width, 3), dtype=np.uint8)
    mujoco.mjr_readPixels(rgb=rgb, depth=None, viewport=mujoco.MjrRect(0, 0, width, height), con=ctx.con)
    return rgb


def render_geom_ids(sim, camera: str, width: int, height: int, edit: SceneEdit | None = None) -> np.ndarray:
    """Raw (bottom-up) int32 image of the geom id seen at each pixel, -1 where no geom is; entries
    the colour frame does not show (hidden sites) are left out, so ids are what the camera shows."""
    ctx = render_context(sim)

    def shown(scn: mujoco.MjvScene) -> None:
        if edit is not None:
            edit(scn)
        scene_edits.remove_invisible(scn)

    draw(ctx, width, height, sim.model.camera_name2id(camera), shown, segmentation=True)
    rgb = np.empty((height, width, 3), dtype=np.uint8)
    mujoco.mjr_readPixels(rgb=rgb, depth=None, viewport=mujoco.MjrRect(0, 0, width, height), con=ctx.con)
    return decode_ids(rgb, ctx.scn)


class RenderHook:
    """Route robosuite's renders through `draw`, editing the scene for some cameras only, and
    capturing the entities' part of the scene each camera drew (`capture_geoms`, for masks).

    `edits` maps camera names to scene edits; renders of other cameras (and segmentation
    renders) are exactly robosuite's. `install(sim)` must follow every hard reset. `take()` hands
    out the captures made since the previous call (camera name -> `capture.Capture`).
    """

    def __init__(self, edits: Mapping[str, SceneEdit], capture_geoms: np.ndarray | None = None):
        self.edits = dict(edits)
        self.capture_geoms = capture_geoms
        self.capture_groups: dict[str, np.ndarray] | None = None  # label -> geoms, for per-entity windows
        self._ctx = None
        self._by_id: dict[int, SceneEdit] = {}
        self._names: dict[int, str] = {}
        self._captures: dict[str, Capture] = {}
        self._hulls = GeomHulls()
        self.generation = 0
        self.edit_seconds = 0.0  # time spent in scene edits (for the cost benchmark)
        self.capture_seconds = 0.0  # time spent copying scene entries (for the cost benchmark)

    def install(self, sim) -> None:
        self.uninstall()
        ctx = render_context(sim)
        model, data = sim.model._model, sim.data._data
        self._by_id = {sim.model.camera_name2id(cam): edit for cam, edit in self.edits.items()}
        self._names = {i: mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)}
        self._captures = {}
        drawable = drawable_geoms(model, ctx.vopt)

        def hooked_render(width, height, camera_id=None, segmentation=False):
            edit = None if segmentation else self._by_id.get(camera_id)
            draw(ctx, width, height, camera_id, self._timed(edit) if edit else None, segmentation)
            if self.capture_geoms is not None and not segmentation and camera_id is not None and camera_id >= 0:
                t0 = time.perf_counter()
                self._captures[self._names[camera_id]] = capture(
                    ctx,
                    model,
                    data,
                    camera_id,
                    width,
                    height,
                    self.capture_geoms,
                    self.generation,
                    drawable,
                    self._hulls,
                    self.capture_groups,
                )
                self.capture_seconds += time.perf_counter() - t0

        ctx.render = hooked_render  # instance attribute shadows the class method
        self._ctx = ctx

    def take(self) -> dict[str, Capture]:
        """The captures of the renders since the last call (the frames of the current observation)."""
        out, self._captures = self._captures, {}
        self.generation += 1
        return out

    def _timed(self, edit: SceneEdit) -> SceneEdit:
        def timed(scn):
            t0 = time.perf_counter()
            try:
                edit(scn)
            finally:
                self.edit_seconds += time.perf_counter() - t0

        return timed

    def uninstall(self) -> None:
        if self._ctx is not None and "render" in vars(self._ctx):
            del self._ctx.render
        self._ctx = None
        self._captures = {}

    @property
    def installed(self) -> bool:
        return self._ctx is not None
