"""Where a position contradiction draws the target: elsewhere, and in view, in one camera.

A fixed shift in the world (10 cm in version 1) carries the drawn target out of the wrist
camera's field of view on most steps of an episode (the camera rides on the hand, a few
centimetres above the target), and the contradiction turns into an existence contradiction.
Here the shift is chosen per camera and step in the camera's image:

- candidates: horizontal directions (the trial's drawn direction first, then `DIRECTIONS`
  evenly spaced ones around it), each at the smallest world distance on a grid that moves the
  target's projected centre by `shift` of the image height; shifts are tried in the caller's
  order (the contradiction: the target's own projected size, then its `min_shift`);
- each candidate is scored by the share of the target's silhouette the camera would show there,
  found by casting rays as a renderer would: `GRID` x `GRID` rays through the box around the
  target's projection there (parts outside the image included), each first against the target
  alone (`TargetShape`, a model of its visual geoms only), which gives the silhouette and the
  nearest surface on each ray, then, for the rays that meet the target inside the image (within
  `MARGIN` of it), from the camera to that surface against the geoms the camera draws (one
  `mujoco.mj_multiRay` call each, past the near clipping distance and past the target's own geoms,
  which are not drawn where the target really is). The share is the rays that meet the target
  unhidden and in view over the rays that meet it;
- the first candidate whose share reaches the real target's own share (same measure, at its
  real place; within one ray of the grid) wins, the direction of the previous step first (so the
  drawn target does not jump between directions while it stays valid); if none does, the
  candidates within `REFINE_BAND` of the largest share are scored again on a `REFINE_GRID` grid
  and the largest wins (the maximum of noisy scores favours the most over-estimated one).

Versions 2 and 3 scored a place from points on the target's surface weighted by the image area
each covers; that counts every layer of a surface facing the camera, so targets that overlap
themselves (libero_10-05's book: 3 to 10 layers of pages on a line of sight) were scored up to
0.11 from their render, and the largest of 32 such scores chose places rendered 0.10 less visible
than the best (libero_spatial-04, libero_10-05; docs/perturbations.md).

Projection: MuJoCo's camera looks along its frame's -z with +y up, `fovy` is the vertical field
of view, and LIBERO's frames are square (aspect 1).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass

import mujoco
import numpy as np

DIRECTIONS = 16  # candidate directions around the horizontal circle
MARGIN = 0.01  # of the image size on each side: points there count as out of view
DISTANCES_M = np.geomspace(0.005, 0.6, 96)  # world shifts tried along a direction
MAX_SHIFT = 0.5  # of the image height: the largest shift tried (a close-up target wider than this
# cannot be moved by its own size and stay in view)
SAMPLE_POINTS = 4096  # points on the target's surface: its projected centre, size and box
SAMPLE_SEED = 0  # the surface sampling's stream: the same points in every episode
GRID = 24  # rays per side of the box around the target's projection, per candidate place
REFINE_GRID = 48  # per side, for the places scored again when none is as visible as the real target
REFINE_BAND = 0.06  # places scored within this of the best are scored again
NEAR_M = 0.01  # closer than this to the camera plane counts as out of view
SURFACE_M = 1e-6  # a hit this close to the target's surface is the surface itself (rounding only: the rays
# leave out the target's body or pass its geoms, so anything they hit in front of it hides it; 1 mm let a
# bowl drawn sunk 0.5 mm into libero_goal-01's plate count as seen where the plate covers 8% of it)
PASS_M = 1e-4  # a ray passing a geom it looks past restarts this far beyond the hit
MAX_PASSES = 16  # geoms a ray may look past before the point counts as hidden


@dataclass(frozen=True)
class Camera:
    """A camera's pose and vertical field of view in one state."""

    position: np.ndarray  # (3,) world
    rotation: np.ndarray  # (3, 3) camera -> world (columns: x right, y up, z backwards)
    tan_half_fovy: float

    @classmethod
    def of(cls, model, data, camera_id: int) -> Camera:
        return cls(
            data.cam_xpos[camera_id].copy(),
            data.cam_xmat[camera_id].reshape(3, 3).copy(),
            float(np.tan(np.radians(model.cam_fovy[camera_id]) / 2)),
        )

    def rays(self, xy: np.ndarray) -> np.ndarray:
        """Unit world directions of the rays through image coordinates `xy` (..., 2) (as `project`)."""
        local = np.concatenate([(2.0 * xy - 1.0) * self.tan_half_fovy, -np.ones(xy.shape[:-1] + (1,))], axis=-1)
        world = local @ self.rotation.T
        return world / np.linalg.norm(world, axis=-1, keepdims=True)

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image coordinates in [0, 1] (x right, y up; any value outside is outside the image) and
        depth in front of the camera (metres), of world points (..., 3)."""
        local = (points - self.position) @ self.rotation
        depth = -local[..., 2]
        safe = np.where(depth > NEAR_M, depth, np.nan)
        xy = local[..., :2] / (safe[..., None] * self.tan_half_fovy)
        return (xy + 1.0) / 2.0, depth


@dataclass(frozen=True)
class Samples:
    """Points on the drawn target's surface, in their geoms' frames: its projected centre, size and
    extent in a camera."""

    geoms: np.ndarray  # (N,) geom of each point
    points: np.ndarray  # (N, 3)

    def world(self, data) -> np.ndarray:
        """World points in the current state."""
        rot = data.geom_xmat[self.geoms].reshape(-1, 3, 3)
        return np.einsum("nij,nj->ni", rot, self.points) + data.geom_xpos[self.geoms]


# The 12 triangles of the box [-1, 1]^3 (corner k has coordinates -1/+1 by the bits of k: x 4, y 2, z 1),
# in trimesh.creation.box's order, so the samples are the ones trimesh drew before this module shipped.
_BOX_FACES = np.array(
    [[1, 3, 0], [4, 1, 0], [0, 3, 2], [2, 4, 0], [1, 7, 3], [5, 1, 4],
     [5, 7, 1], [3, 7, 2], [6, 4, 2], [2, 7, 6], [6, 5, 4], [7, 5, 6]]
)  # fmt: skip
_BOX_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def _triangles(model, g: int) -> np.ndarray:
    """(F, 3, 3): the triangles of geom g in its frame (its mesh, or its bounding box)."""
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        return np.asarray(model.mesh_vert[v0 : v0 + nv], dtype=np.float64)[model.mesh_face[f0 : f0 + nf]]
    corners = _BOX_CORNERS * model.geom_aabb[g][3:] + model.geom_aabb[g][:3]
    return corners[_BOX_FACES]


def _sample_triangles(tris: np.ndarray, count: int) -> np.ndarray:
    """`count` area-weighted points on the triangles, drawn as trimesh's
    `sample.sample_surface(mesh, count, seed=SAMPLE_SEED)` draws them (the same stream, the same
    points). Written out with numpy because this module ships in packs, whose LIBERO forks have
    numpy and mujoco but not trimesh."""
    rng = np.random.default_rng(SAMPLE_SEED)
    origins, vectors = tris[:, 0], tris[:, 1:] - tris[:, :1]
    cum = np.cumsum(0.5 * np.linalg.norm(np.cross(vectors[:, 0], vectors[:, 1]), axis=1))
    face = np.searchsorted(cum, rng.random(count) * cum[-1])
    lengths = rng.random((count, 2, 1))
    lengths[lengths.sum(axis=1).reshape(-1) > 1.0] -= 1.0  # folded back into the triangle
    return (vectors[face] * np.abs(lengths)).sum(axis=1) + origins[face]


def target_samples(model, geoms: tuple[int, ...], count: int = SAMPLE_POINTS) -> Samples:
    """`count` area-weighted points on the target's visual meshes (boxes for other geom types), each
    geom's share by its area."""
    tris = [(g, _triangles(model, g)) for g in geoms]
    areas = [float(0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()) for _, t in tris]
    total = sum(areas)
    geom_ids, points = [], []
    for (g, t), area in zip(tris, areas):
        take = max(1, round(count * area / total)) if total > 0 else 1
        geom_ids.append(np.full(take, g))
        points.append(_sample_triangles(t, take))
    return Samples(np.concatenate(geom_ids), np.concatenate(points))


class TargetShape:
    """The target's visual geoms alone, as a model of their own (`mujoco.MjSpec`), posed like the
    target in the scene: rays cast against it find the target's silhouette and its nearest surface
    without the rest of the scene."""

    def __init__(self, model, geoms: tuple[int, ...]):
        self.geoms = np.asarray(geoms, dtype=np.int32)
        spec = mujoco.MjSpec()
        for i, g in enumerate(self.geoms):
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                mesh = model.geom_dataid[g]
                v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
                f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
                spec.add_mesh(
                    name=f"m{i}",
                    uservert=model.mesh_vert[v0 : v0 + nv].ravel().tolist(),
                    userface=model.mesh_face[f0 : f0 + nf].ravel().tolist(),
                    inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL,  # visual meshes need not be closed
                )
                spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{i}")
            else:
                spec.worldbody.add_geom(type=mujoco.mjtGeom(int(model.geom_type[g])), size=model.geom_size[g].tolist())
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        # The compiler re-centres each mesh in its own frame: the geom's pose in the original geom's.
        self._pos = self.model.geom_pos.copy()
        self._mat = np.stack([_quat_mat(q) for q in self.model.geom_quat])

    def place(self, data) -> None:
        """Pose the shape's geoms like the target's geoms in the scene's `data`."""
        rot = data.geom_xmat[self.geoms].reshape(-1, 3, 3)
        self.data.geom_xpos[:] = np.einsum("nij,nj->ni", rot, self._pos) + data.geom_xpos[self.geoms]
        self.data.geom_xmat[:] = (rot @ self._mat).reshape(-1, 9)


def _quat_mat(quat: np.ndarray) -> np.ndarray:
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, quat)
    return mat.reshape(3, 3)


class Visibility:
    """How much of the target a camera would show with the target drawn shifted by some offset."""

    def __init__(
        self, model, data, camera: Camera, geomgroup: np.ndarray, target_geoms: tuple[int, ...], shape: TargetShape
    ):
        self.model, self.data, self.camera, self.shape = model, data, camera, shape
        self.geomgroup = np.asarray(geomgroup, dtype=np.uint8)
        self.target = np.asarray(target_geoms, dtype=np.int32)
        # A target of one body is left out of the rays altogether: passing its own surfaces one hit
        # at a time runs out of passes inside a mesh of many layers (libero_10-05's book: its pages
        # took all 16 passes, so 28% of its points counted as hidden while the camera shows all).
        bodies = np.unique(model.geom_bodyid[self.target])
        self.exclude = int(bodies[0]) if len(bodies) == 1 else -1
        self.near = float(model.vis.map.znear * model.stat.extent)  # MuJoCo's near clipping distance
        shape.place(data)

    def share(self, points: np.ndarray, offset: np.ndarray, grid: int = GRID) -> float:
        """The share of the target's silhouette the camera would show with the target drawn shifted
        by `offset` (world `points` on its surface at its real place): rays on a `grid` x `grid`
        lattice over the box around the shifted points' projection meet the target (its
        silhouette); of those, the ones inside the image margins whose path to the target's surface
        is clear through the rest of the scene are seen. Out-of-frame parts count as unseen, like
        parts hidden behind the gripper or a fixture."""
        xy, _ = self.camera.project(points + offset)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if not len(xy):
            return 0.0
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        cell = float((hi - lo).max()) / grid
        centre = (lo + hi) / 2
        ticks = (np.arange(grid) - (grid - 1) / 2) * cell
        pixels = np.stack(np.meshgrid(centre[0] + ticks, centre[1] + ticks), axis=-1).reshape(-1, 2)
        units = self.camera.rays(pixels)
        # The shifted target seen from the camera is the real one seen from the camera less the offset.
        geom, dist = every_geom_multi_ray(
            self.shape.model, self.shape.data, self.camera.position - offset, units, np.ones(6, np.uint8), -1
        )
        met = geom >= 0
        if not met.any():
            return 0.0
        inside = met & np.all((pixels >= MARGIN) & (pixels <= 1 - MARGIN), axis=-1)
        inside &= dist * (units @ -self.camera.rotation[:, 2]) > NEAR_M  # depth of the surface met
        idx = np.flatnonzero(inside)
        if len(idx):
            inside[idx] = self._clear(self.camera.position + units[idx] * dist[idx, None])
        return float(inside.sum() / met.sum())

    def _clear(self, points: np.ndarray) -> np.ndarray:
        """On a clear line of sight against the geoms the camera draws, past what is nearer than the
        camera's near clipping distance (drawing clips it: the wrist camera sits inside the hand's
        meshes) and past the target's own geoms (not drawn where the target really is). All rays in
        one `every_geom_multi_ray`; the few whose first hit is nearer than the near plane or on the
        target (a target of several bodies) go on one `mj_ray` at a time. Only hits nearer than the
        farthest point matter, so the geoms wholly beyond it are set aside for both
        (`beyond_set_aside`: the same answer on every ray; on agentview, the robot's 33k-face
        pedestal behind the target took most of the rays' time)."""
        vec = points - self.camera.position
        lengths = np.linalg.norm(vec, axis=1)
        unit = vec / lengths[:, None]
        with beyond_set_aside(self.model, self.data, self.camera.position, self.geomgroup, lengths.max()) as group:
            geom, dist = every_geom_multi_ray(self.model, self.data, self.camera.position, unit, group, self.exclude)
            clear = (geom < 0) | (dist >= lengths - SURFACE_M)
            passed = ~clear & ((dist < self.near) | np.isin(geom, self.target))
            for i in np.flatnonzero(passed):
                clear[i] = self._clear_ray(unit[i], float(lengths[i]), group)
        return clear

    def _clear_ray(self, unit: np.ndarray, length: float, geomgroup: np.ndarray) -> bool:
        travelled, hit = 0.0, np.zeros(1, dtype=np.int32)
        for _ in range(MAX_PASSES):
            start = self.camera.position + unit * travelled
            d = mujoco.mj_ray(self.model, self.data, start, unit, geomgroup, 1, self.exclude, hit)
            if hit[0] < 0 or travelled + d >= length - SURFACE_M:
                return True
            if hit[0] not in self.target and travelled + d >= self.near:
                return False
            travelled += d + PASS_M
        return False


def every_geom_multi_ray(
    model, data, origin: np.ndarray, units: np.ndarray, geomgroup: np.ndarray, bodyexclude: int
) -> tuple[np.ndarray, np.ndarray]:
    """(geom, distance) of the first hit of each ray from `origin` along `units` (N, 3), -1 where
    none: `mujoco.mj_multiRay` (static geoms included, no cutoff), giving what `mj_ray` gives ray by
    ray. MuJoCo 3.3.7's `mj_multiRay` first culls bodies by a sphere around their bounding volume,
    which covers the collision geoms only (the gripper's visual finger meshes reach out of it), and
    geoms by the angular span of their boxes' corners seen from the origin; on the wrist camera it
    missed the fingers on 40-90 of 1,024 rays with correct arguments (libero_goal-01). Both culls
    are skipped for bodies without a bounding volume, so the call runs with `body_bvhadr` set aside
    (restored before returning; meshes keep their own trees): then every geom is tested, and the
    hits equal `mj_ray`'s on every ray."""
    n = len(units)
    geom, dist = np.empty(n, dtype=np.int32), np.empty(n, dtype=np.float64)
    if n == 0:
        return geom, dist
    saved = model.body_bvhadr.copy()
    model.body_bvhadr[:] = -1
    try:
        args = {
            "m": model,
            "d": data,
            "pnt": np.asarray(origin, dtype=np.float64),
            "vec": np.ascontiguousarray(units, dtype=np.float64).reshape(-1),
            "geomgroup": geomgroup,
            "flg_static": 1,
            "bodyexclude": bodyexclude,
            "geomid": geom,
            "dist": dist,
            "nray": n,
            "cutoff": np.inf,
        }
        try:
            mujoco.mj_multiRay(**args)
        except TypeError:  # MuJoCo 3.5 on (packs' LIBERO forks): a `normal` output before `nray`
            mujoco.mj_multiRay(**args, normal=None)
    finally:
        model.body_bvhadr[:] = saved
    return geom, dist


# As ints: numpy compares an array with MuJoCo's enum objects one element at a time (0.4 ms a call).
_UNBOUNDED = (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD))


def beyond(model, data, origin: np.ndarray, within: float) -> np.ndarray:
    """(ngeom,) bool: the geoms wholly farther than `within` from `origin` (their box's bounding
    sphere, from `geom_aabb`, beyond it). Planes and height fields never are."""
    aabb = model.geom_aabb
    radius = np.linalg.norm(aabb[:, :3], axis=1) + np.linalg.norm(aabb[:, 3:], axis=1)
    far = np.linalg.norm(data.geom_xpos - origin, axis=1) - radius > within
    return far & (model.geom_type != _UNBOUNDED[0]) & (model.geom_type != _UNBOUNDED[1])


@contextlib.contextmanager
def beyond_set_aside(model, data, origin: np.ndarray, geomgroup: np.ndarray, within: float) -> Iterator[np.ndarray]:
    """Rays from `origin` that only need hits nearer than `within` skip the geoms wholly beyond it:
    inside the block every geom's group is 0 where `geomgroup` draws it and it is not `beyond`,
    1 otherwise, and the group mask yielded casts against group 0 alone (`mj_ray` and
    `mj_multiRay` eliminate geoms by group before any test). A hit nearer than `within` is the one
    `geomgroup` gives; a ray whose first hit is at `within` or beyond meets nothing or something at
    `within` or beyond. The groups are restored on leaving (as `body_bvhadr` around
    `every_geom_multi_ray`)."""
    saved = model.geom_group.copy()
    drawn = np.asarray(geomgroup, dtype=bool)[np.clip(saved, 0, len(geomgroup) - 1)]
    model.geom_group[:] = np.where(drawn & ~beyond(model, data, origin, within), 0, 1)
    mask = np.zeros(len(geomgroup), dtype=np.uint8)
    mask[0] = 1
    try:
        yield mask
    finally:
        model.geom_group[:] = saved


def projected_size(camera: Camera, points: np.ndarray) -> float:
    """The larger side of the box around the points' projections, of the image height (parts
    outside the image included)."""
    xy, _ = camera.project(points)
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    return float((xy.max(axis=0) - xy.min(axis=0)).max()) if len(xy) else 0.0


@dataclass(frozen=True)
class Choice:
    offset: np.ndarray  # world shift of the drawn target
    direction: int | None  # index of the candidate direction, None when none reaches the shift
    shift: float  # of the image height, from the target's projected centre
    share: float  # silhouette share seen, drawn at the offset
    real_share: float  # silhouette share seen at the real place


def candidates(
    camera: Camera, points: np.ndarray, shifts: tuple[float, ...], first_angle: float, previous: int | None = None
) -> Iterator[tuple[int, float, np.ndarray]]:
    """(direction, shift, world offset) of every candidate place, in the order they are tried:
    `shifts` in order, the previous step's direction first, then the trial's drawn one and the
    others around it; along each, the smallest distance on the grid that moves the target's
    projected centre by `shift` of the image height (none where no distance does)."""
    c_xy, _ = camera.project(points.mean(axis=0))
    angles = first_angle + 2 * np.pi * np.arange(DIRECTIONS) / DIRECTIONS
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros(DIRECTIONS)], axis=1)
    moved = points.mean(axis=0) + directions[:, None, :] * DISTANCES_M[None, :, None]  # (K, D, 3)
    m_xy, _ = camera.project(moved)
    moved_px = np.linalg.norm(m_xy - c_xy, axis=-1)  # NaN behind the camera: compares False below
    order = list(range(DIRECTIONS))
    if previous is not None:
        order.remove(previous)
        order.insert(0, previous)
    for shift in shifts:
        for k in order:
            hits = np.flatnonzero(moved_px[k] >= shift)
            if len(hits):
                yield k, shift, directions[k] * DISTANCES_M[hits[0]]


def choose_offset(
    visibility: Visibility,
    points: np.ndarray,
    shifts: tuple[float, ...],
    first_angle: float,
    previous: int | None = None,
) -> Choice:
    """Where to draw the target (world `points` on its surface at its real place): see the module
    doc. The first candidate (`candidates`) as visible as the real target wins; if none is, the most
    visible, scored again on the `REFINE_GRID` among those scored near the best. A place is scored
    once per grid: the same offset met again (the two shifts equal, as when the target's projected
    size is below `min_shift`, or reaching the same distance) takes its first score."""
    zero = np.zeros(3)
    real_share = visibility.share(points, zero)
    scored = []
    known: dict[bytes, float] = {}
    for k, shift, offset in candidates(visibility.camera, points, shifts, first_angle, previous):
        if offset.tobytes() not in known:
            known[offset.tobytes()] = visibility.share(points, offset)
        share = known[offset.tobytes()]
        if share >= real_share - 1.0 / GRID**2:
            return Choice(offset, k, shift, share, real_share)
        scored.append(Choice(offset, k, shift, share, real_share))
    if not scored:
        return Choice(zero, None, 0.0, 0.0, real_share)
    top = max(c.share for c in scored)
    near = [c for c in scored if c.share >= top - REFINE_BAND]
    fine: dict[bytes, float] = {}
    for c in near:
        if c.offset.tobytes() not in fine:
            fine[c.offset.tobytes()] = visibility.share(points, c.offset, REFINE_GRID)
    refined = [fine[c.offset.tobytes()] for c in near]
    best = int(np.argmax(refined))  # the first of equals: candidates keep their order
    return Choice(near[best].offset, near[best].direction, near[best].shift, refined[best], real_share)
