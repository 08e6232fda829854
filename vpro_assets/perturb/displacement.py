"""Where a position contradiction draws the target: elsewhere, and in view, in one camera.

A fixed shift in the world (10 cm in version 1) carries the drawn target out of the wrist
camera's field of view on most steps of an episode (the camera rides on the hand, a few
centimetres above the target), and the contradiction turns into an existence contradiction.
Here the shift is chosen per camera and step in the camera's image:

- candidates: horizontal directions (the trial's drawn direction first, then `DIRECTIONS`
  evenly spaced ones around it), each at the smallest world distance on a grid that moves the
  target's projected centre by `shift` of the image height; shifts are tried in the caller's
  order (the contradiction: the target's own projected size, then its `min_shift`);
- each candidate is scored by the share of the target's silhouette that would be seen there:
  of `SAMPLE_POINTS` area-weighted points on its visual meshes, `RAY_POINTS` drawn by the image
  area they cover there (a pinhole camera images a surface element dA with normal n at p, depth
  z, as f^2 dA n.(c - p) / z^3: off-axis parts cover more pixels per solid angle; points facing
  away cover none), each standing for an equal part of the silhouette, seen when inside the image
  (with `MARGIN` of it on every side) and on a clear line of sight (one `mujoco.mj_multiRay`
  call against the geoms the camera draws, past the near clipping distance and past the
  target's own geoms, which are not drawn where the target really is);
- the first candidate whose share reaches the real target's own share (same measure, at its
  real place) wins, the direction of the previous step first (so the drawn target does not jump
  between directions while it stays valid); if none does, the candidate with the largest share.

Projection: MuJoCo's camera looks along its frame's -z with +y up, `fovy` is the vertical field
of view, and LIBERO's frames are square (aspect 1).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import mujoco
import numpy as np

DIRECTIONS = 16  # candidate directions around the horizontal circle
MARGIN = 0.02  # of the image size on each side: points there count as out of view
DISTANCES_M = np.geomspace(0.005, 0.6, 96)  # world shifts tried along a direction
MAX_SHIFT = 0.5  # of the image height: the largest shift tried (a close-up target wider than this
# cannot be moved by its own size and stay in view)
SAMPLE_POINTS = 4096  # points on the target's surface, the pool the ray-tested points are drawn from
RAY_POINTS = 256  # points ray-tested per candidate place, drawn by image area (96 missed a plate's rim
# over 10% of a bowl)
SAMPLE_SEED = 0  # the surface sampling's stream: the same points in every episode
NEAR_M = 0.01  # closer than this to the camera plane counts as out of view
SURFACE_M = 1e-6  # a hit this close to the sampled point is the point itself (rounding only: the rays leave
# out the target's body or pass its geoms, so anything they hit in front of a point hides it; 1 mm let a
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
    """Points on the drawn target's surface with their outward normals, in their geoms' frames."""

    geoms: np.ndarray  # (N,) geom of each point
    points: np.ndarray  # (N, 3)
    normals: np.ndarray  # (N, 3)

    def world(self, data) -> tuple[np.ndarray, np.ndarray]:
        """World points and normals in the current state."""
        rot = data.geom_xmat[self.geoms].reshape(-1, 3, 3)
        points = np.einsum("nij,nj->ni", rot, self.points) + data.geom_xpos[self.geoms]
        return points, np.einsum("nij,nj->ni", rot, self.normals)


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


def _sample_triangles(tris: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """(points, face indices): `count` area-weighted points on the triangles, drawn as trimesh's
    `sample.sample_surface(mesh, count, seed=SAMPLE_SEED)` draws them (the same stream, the same
    points). Written out with numpy because this module ships in packs, whose LIBERO forks have
    numpy and mujoco but not trimesh."""
    rng = np.random.default_rng(SAMPLE_SEED)
    origins, vectors = tris[:, 0], tris[:, 1:] - tris[:, :1]
    cum = np.cumsum(0.5 * np.linalg.norm(np.cross(vectors[:, 0], vectors[:, 1]), axis=1))
    face = np.searchsorted(cum, rng.random(count) * cum[-1])
    lengths = rng.random((count, 2, 1))
    lengths[lengths.sum(axis=1).reshape(-1) > 1.0] -= 1.0  # folded back into the triangle
    return (vectors[face] * np.abs(lengths)).sum(axis=1) + origins[face], face


def target_samples(model, geoms: tuple[int, ...], count: int = SAMPLE_POINTS) -> Samples:
    """`count` area-weighted points on the target's visual meshes (boxes for other geom types), with
    their face normals, each geom's share by its area."""
    tris = [(g, _triangles(model, g)) for g in geoms]
    crosses = [np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]) for _, t in tris]
    areas = [float(0.5 * np.linalg.norm(c, axis=1).sum()) for c in crosses]
    total = sum(areas)
    geom_ids, points, normals = [], [], []
    for (g, t), cross, area in zip(tris, crosses, areas):
        take = max(1, round(count * area / total)) if total > 0 else 1
        pts, face = _sample_triangles(t, take)
        n = cross[face]
        geom_ids.append(np.full(take, g))
        points.append(pts)
        normals.append(n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12))
    return Samples(np.concatenate(geom_ids), np.concatenate(points), np.concatenate(normals))


class Visibility:
    """Which target points a camera would see with the target drawn shifted by some offset."""

    def __init__(self, model, data, camera: Camera, geomgroup: np.ndarray, target_geoms: tuple[int, ...]):
        self.model, self.data, self.camera = model, data, camera
        self.geomgroup = np.asarray(geomgroup, dtype=np.uint8)
        self.target = np.asarray(target_geoms, dtype=np.int32)
        # A target of one body is left out of the rays altogether: passing its own surfaces one hit
        # at a time runs out of passes inside a mesh of many layers (libero_10-05's book: its pages
        # took all 16 passes, so 28% of its points counted as hidden while the camera shows all).
        bodies = np.unique(model.geom_bodyid[self.target])
        self.exclude = int(bodies[0]) if len(bodies) == 1 else -1
        self.near = float(model.vis.map.znear * model.stat.extent)  # MuJoCo's near clipping distance

    def share(self, points: np.ndarray, normals: np.ndarray, offset: np.ndarray) -> float:
        """The share of the target's silhouette the camera would show with the target drawn shifted
        by `offset` (world `points` and `normals` at its real place, the `SAMPLE_POINTS` samples):
        of the image area the points facing the camera cover (`image_area`), the part inside the
        image margins and on a clear line of sight through the rest of the scene. Out-of-frame
        parts count as unseen, like parts hidden behind the gripper or a fixture.

        Only `RAY_POINTS` points are tested, drawn systematically by image area (each one
        standing for an equal part of the silhouette): weighting a uniform sample by area instead
        leaves a close-up's estimate to the few points nearest the camera (libero_10-02's moka pot
        in the wrist view: 0.42 from 256 such points where 4,096 give 0.64 and the render 0.74)."""
        shifted = points + offset
        xy, depth = self.camera.project(shifted)
        weight = image_area(self.camera, shifted, normals, depth)
        total = weight.sum()
        if not total > 0:
            return 0.0
        cumulative = np.cumsum(weight)
        picked = np.searchsorted(cumulative, (np.arange(RAY_POINTS) + 0.5) * (total / RAY_POINTS), side="right")
        picked = np.minimum(picked, len(weight) - 1)
        unique, counts = np.unique(picked, return_counts=True)
        seen = np.all((xy[unique] >= MARGIN) & (xy[unique] <= 1 - MARGIN), axis=-1) & (depth[unique] > NEAR_M)
        idx = np.flatnonzero(seen)
        if len(idx):
            seen[idx] = self._clear(shifted[unique[idx]])
        return float(counts[seen].sum() / RAY_POINTS)

    def _clear(self, points: np.ndarray) -> np.ndarray:
        """On a clear line of sight against the geoms the camera draws, past what is nearer than the
        camera's near clipping distance (drawing clips it: the wrist camera sits inside the hand's
        meshes) and past the target's own geoms (not drawn where the target really is). All rays in
        one `every_geom_multi_ray`; the few whose first hit is nearer than the near plane or on the
        target (a target of several bodies) go on one `mj_ray` at a time."""
        vec = points - self.camera.position
        lengths = np.linalg.norm(vec, axis=1)
        unit = vec / lengths[:, None]
        geom, dist = every_geom_multi_ray(
            self.model, self.data, self.camera.position, unit, self.geomgroup, self.exclude
        )
        clear = (geom < 0) | (dist >= lengths - SURFACE_M)
        passed = ~clear & ((dist < self.near) | np.isin(geom, self.target))
        for i in np.flatnonzero(passed):
            clear[i] = self._clear_ray(unit[i], float(lengths[i]))
        return clear

    def _clear_ray(self, unit: np.ndarray, length: float) -> bool:
        travelled, hit = 0.0, np.zeros(1, dtype=np.int32)
        for _ in range(MAX_PASSES):
            start = self.camera.position + unit * travelled
            d = mujoco.mj_ray(self.model, self.data, start, unit, self.geomgroup, 1, self.exclude, hit)
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


def image_area(camera: Camera, points: np.ndarray, normals: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """The image area (up to a constant) each surface point stands for: a pinhole camera images a
    surface element dA with normal n at p, depth z, as f^2 dA n.(c - p) / z^3 (cosine over squared
    distance, times 1 / cos^3 of the angle off the optical axis: off-axis parts cover more pixels
    per solid angle); 0 for points facing away. Points nearer than `NEAR_M` count as at `NEAR_M`."""
    facing = np.einsum("ni,ni->n", normals, camera.position - points)
    return np.maximum(facing, 0.0) / np.maximum(depth, NEAR_M) ** 3


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
    normals: np.ndarray,
    shifts: tuple[float, ...],
    first_angle: float,
    previous: int | None = None,
) -> Choice:
    """Where to draw the target (world `points` and `normals` at its real place): see the module
    doc. The first candidate (`candidates`) as visible as the real target wins."""
    zero = np.zeros(3)
    real_share = visibility.share(points, normals, zero)
    best = Choice(zero, None, 0.0, 0.0, real_share)
    for k, shift, offset in candidates(visibility.camera, points, shifts, first_angle, previous):
        share = visibility.share(points, normals, offset)
        if share >= real_share:
            return Choice(offset, k, shift, share, real_share)
        if best.direction is None or share > best.share:
            best = Choice(offset, k, shift, share, real_share)
    return best
