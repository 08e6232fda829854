"""Conforming refinement of a textured triangle soup to a maximum edge length.

A deformation that bends space only bends the mesh where it has vertices: a bottle side made of
15 cm triangles would stay straight under a twist. Edges longer than `max_edge` are split at
their midpoint in every triangle that shares them (edges are identified by corner positions, so
texture seams split consistently and no T-junction opens a crack). A triangle with one, two or
three split edges becomes two, three or four triangles; texture coordinates are interpolated per
triangle, so seams keep their own coordinates on each side.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.geometry.meshes import quantize

MAX_ITERATIONS = 10


def refine_soup(corners: np.ndarray, uv: np.ndarray | None, max_edge: float, normals: np.ndarray | None = None):
    """Return (corners, uv, normals) with every edge at most `max_edge` (or MAX_ITERATIONS halvings).

    `uv` (F, 3, 2) and `normals` (F, 3, 3) are per-corner attributes (either may be None);
    midpoint normals are renormalised.
    """
    attributes = [a for a in (uv, normals) if a is not None]
    for _ in range(MAX_ITERATIONS):
        lengths = np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=2)  # edge k: corner k -> k+1
        if lengths.max() <= max_edge:
            break
        corners, attributes = _split_once(corners, attributes, lengths > max_edge)
    out = iter(attributes)
    uv = None if uv is None else next(out)
    if normals is not None:
        normals = next(out)
        normals = normals / np.maximum(np.linalg.norm(normals, axis=2, keepdims=True), 1e-12)
    return corners, uv, normals


def _split_once(corners: np.ndarray, attributes: list[np.ndarray], long_edges: np.ndarray):
    # Mark an edge in every face sharing it: key by the two quantised corner positions, unordered.
    keys = quantize(corners).reshape(len(corners), 3, 3)
    a, b = keys, np.roll(keys, -1, axis=1)
    less = _lex_less(a, b)[..., None]
    lo, hi = np.where(less, a, b), np.where(less, b, a)
    edge_keys = np.concatenate([lo, hi], axis=2).reshape(-1, 6)
    unique, inverse = np.unique(edge_keys, axis=0, return_inverse=True)
    marked_unique = np.zeros(len(unique), dtype=bool)
    marked_unique[inverse[long_edges.reshape(-1)]] = True
    marked = marked_unique[inverse].reshape(-1, 3)

    arrays = [corners] + attributes  # split together: positions first, then per-corner attributes
    mids = [(a + np.roll(a, -1, axis=1)) / 2.0 for a in arrays]  # mid of edge k between corner k and k+1
    keep = ~marked.any(axis=1)
    out = [[a[keep]] for a in arrays]
    count = marked.sum(axis=1)
    for n_marked in (1, 2, 3):
        faces = np.nonzero(count == n_marked)[0]
        if len(faces) == 0:
            continue
        # Rotate each face so its pattern is canonical: 1 -> edge 0 marked; 2 -> edge 2 unmarked.
        if n_marked == 1:
            shift = np.argmax(marked[faces], axis=1)
        elif n_marked == 2:
            shift = (np.argmin(marked[faces], axis=1) + 1) % 3
        else:
            shift = np.zeros(len(faces), dtype=int)
        order = (np.arange(3)[None, :] + shift[:, None]) % 3
        for a, mid, collected in zip(arrays, mids, out, strict=True):
            c = np.take_along_axis(a[faces], order[..., None], axis=1)
            m = np.take_along_axis(mid[faces], order[..., None], axis=1)
            for tri in _PATTERNS[n_marked]:
                collected.append(np.stack([_pick(c, m, s) for s in tri], axis=1))
    arrays = [np.concatenate(collected) for collected in out]
    return arrays[0], arrays[1:]


def _lex_less(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Lexicographic a < b over the last axis."""
    less = np.zeros(a.shape[:-1], dtype=bool)
    decided = np.zeros(a.shape[:-1], dtype=bool)
    for k in range(a.shape[-1]):
        lt, gt = a[..., k] < b[..., k], a[..., k] > b[..., k]
        less |= ~decided & lt
        decided |= lt | gt
    return less


def _pick(c: np.ndarray, m: np.ndarray, slot: str) -> np.ndarray:
    kind, index = slot[0], int(slot[1])
    return c[:, index] if kind == "c" else m[:, index]


# Triangles of each split pattern, as corner ("c0") and edge-midpoint ("m0": mid of c0-c1) slots,
# all keeping the original counter-clockwise order.
_PATTERNS = {
    1: (("c0", "m0", "c2"), ("m0", "c1", "c2")),
    2: (("c0", "m0", "m1"), ("m0", "c1", "m1"), ("c0", "m1", "c2")),
    3: (("c0", "m0", "m2"), ("m0", "c1", "m1"), ("m2", "m1", "c2"), ("m0", "m1", "m2")),
}
