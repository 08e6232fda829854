"""Convex decomposition with coacd: fixed seed, recorded parameters, canonical hull order.

coacd (approximate convex decomposition by collision-aware Monte-Carlo tree search) splits a
closed solid into convex hulls for MuJoCo's collision detection. Its search is random: the seed
is always given, and with `seed`, input and parameters fixed its output is repeatable (checked by
the byte-identical regeneration test). Hulls are returned sorted by their centroid, so the order
never depends on the search's internals, and each is re-hulled with trimesh (consistent winding).
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass

import manifold3d
import numpy as np
import trimesh

from vpro_assets.geometry.meshes import MeshError, quantize

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CoacdParams:
    """Every coacd argument we set (the rest are coacd 1.0.14's defaults, recorded by version)."""

    threshold: float = 0.05  # concavity allowed per hull; lower = more, tighter hulls
    max_convex_hull: int = 48  # hulls merged down to at most this many (MuJoCo contact cost)
    preprocess_mode: str = "off"  # inputs are already closed 2-manifolds (manifold3d)
    preprocess_resolution: int = 50
    resolution: int = 1000  # surface samples per hull evaluation
    mcts_nodes: int = 20
    mcts_iterations: int = 60
    mcts_max_depth: int = 3
    pca: bool = False
    merge: bool = True
    decimate: bool = False  # decimated hulls lose flat bases (a bottle then rocks on 3 vertices)
    max_ch_vertex: int = 256  # used only with decimate
    extrude: bool = False
    extrude_margin: float = 0.01
    apx_mode: str = "ch"
    seed: int = 0

    def to_json(self) -> dict:
        return asdict(self)


# Lighter search for tests and previews: same algorithm, fewer samples and iterations.
FAST = {
    "threshold": 0.15,
    "max_convex_hull": 12,
    "resolution": 600,
    "mcts_iterations": 30,
    "mcts_nodes": 10,
    "mcts_max_depth": 2,
}
MIN_HULLS, MAX_HULLS = 1, 64


def decompose(vertices: np.ndarray, faces: np.ndarray, params: CoacdParams, what: str) -> list[trimesh.Trimesh]:
    """Convex hulls of the solid (vertices, faces), in canonical order."""
    import coacd  # the heavy engine loads only when a decomposition runs

    coacd.set_log_level("error")
    mesh = coacd.Mesh(np.ascontiguousarray(vertices, np.float64), np.ascontiguousarray(faces, np.int32))
    try:
        parts = coacd.run_coacd(mesh, **asdict(params))
    except Exception as exc:  # coacd raises plain RuntimeError on bad input
        raise MeshError(f"{what}: coacd failed: {exc}") from exc
    hulls = []
    for part_vertices, _part_faces in parts:
        points = quantize(np.asarray(part_vertices, np.float64))
        if len(np.unique(points, axis=0)) < 4:
            continue
        hull = trimesh.convex.convex_hull(points)
        if hull.volume <= 0:
            continue
        hulls.append(hull)
    if not MIN_HULLS <= len(hulls) <= MAX_HULLS:
        raise MeshError(f"{what}: coacd gave {len(hulls)} usable hulls, outside {MIN_HULLS}..{MAX_HULLS}")
    hulls.sort(key=lambda h: tuple(quantize(np.asarray(h.vertices).mean(axis=0))))
    return hulls


SUPPORT_TOLERANCE = 0.0005  # metres: a hull within this of the solid's bottom carries the object
MIN_SUPPORT_HULLS = 3


def split_support_hulls(
    hulls: list[trimesh.Trimesh], up: np.ndarray, across: tuple[np.ndarray, np.ndarray], what: str
) -> list[trimesh.Trimesh]:
    """Give a resting object several supporting hulls.

    MuJoCo makes one contact per convex pair (LIBERO does not enable multi-contact), so an object
    standing on a single bottom hull rests on one point at a time and buzzes. When fewer than
    MIN_SUPPORT_HULLS hulls reach the bottom plane, each that does is cut into quadrants by the two
    vertical planes (`across`, unit vectors) through its centroid (manifold3d `split_by_plane`);
    the pieces are convex and cover the same volume.
    """
    heights = [float((np.asarray(h.vertices) @ up).min()) for h in hulls]
    bottom = min(heights)
    support = [i for i, h in enumerate(heights) if h - bottom <= SUPPORT_TOLERANCE]
    if len(support) >= MIN_SUPPORT_HULLS:
        return hulls
    out = [h for i, h in enumerate(hulls) if i not in support]
    for i in support:
        hull = hulls[i]
        pieces = [
            manifold3d.Manifold(
                manifold3d.Mesh(
                    vert_properties=np.ascontiguousarray(hull.vertices, np.float32),
                    tri_verts=np.ascontiguousarray(hull.faces, np.uint32),
                )
            )
        ]
        centre = np.asarray(hull.vertices).mean(axis=0)
        for normal in across:
            offset = float(centre @ normal)
            pieces = [part for piece in pieces for part in piece.split_by_plane(tuple(map(float, normal)), offset)]
        for piece in pieces:
            if piece.is_empty() or piece.volume() <= 0:
                continue
            mesh = piece.to_mesh()
            points = quantize(np.asarray(mesh.vert_properties, np.float64)[:, :3])
            if len(np.unique(points, axis=0)) >= 4:
                part = trimesh.convex.convex_hull(points)
                if part.volume > 0:
                    out.append(part)
    if len(out) > MAX_HULLS:
        raise MeshError(f"{what}: {len(out)} hulls after splitting the supporting ones, above {MAX_HULLS}")
    out.sort(key=lambda h: tuple(quantize(np.asarray(h.vertices).mean(axis=0))))
    return out
