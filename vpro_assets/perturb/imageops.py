"""Pure image operations on raw frames and boolean masks (no simulator, no randomness of their own).

Every function takes and returns numpy arrays and never modifies its inputs, so the same clean
frame can feed several perturbations and the property tests can run on synthetic frames.
"""

from __future__ import annotations

import cv2
import numpy as np


def partial_mask(mask: np.ndarray, ratio: float, angle: float) -> np.ndarray:
    """The share `ratio` of `mask`'s pixels that lie furthest along direction `angle` (radians):
    a flat occluder sweeping across the entity from one side, covering exactly
    round(ratio * n) of its n visible pixels."""
    out = np.zeros_like(mask, dtype=bool)
    ys, xs = np.nonzero(mask)
    n = len(ys)
    k = int(round(ratio * n))
    if k <= 0:
        return out
    if k >= n:
        out[ys, xs] = True
        return out
    proj = xs * np.cos(angle) + ys * np.sin(angle)
    # Stable order: ties broken by pixel index, so the covered set is a pure function of the inputs.
    idx = np.lexsort((np.arange(n), -proj))[:k]
    out[ys[idx], xs[idx]] = True
    return out


def disk(radius: int) -> np.ndarray:
    """Structuring element: the pixel offsets at Euclidean distance <= radius."""
    yy, xx = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    return (yy * yy + xx * xx <= radius * radius).astype(np.uint8)


def dilate(mask: np.ndarray, radius: int) -> np.ndarray:
    """Pixels within Euclidean distance `radius` of the mask."""
    if radius <= 0:
        return mask.astype(bool)
    kernel = disk(radius)
    return cv2.dilate(mask.astype(np.uint8), kernel).astype(bool)


def meeting_region(a: np.ndarray, b: np.ndarray, radius: int) -> np.ndarray:
    """Where two entities meet in the image: pixels within `radius` of both (a contact region)."""
    if not a.any() or not b.any():
        return np.zeros_like(a, dtype=bool)
    return dilate(a, radius) & dilate(b, radius)


def occlude(frame: np.ndarray, mask: np.ndarray, gray: int) -> np.ndarray:
    """A copy of `frame` with the pixels of `mask` set to a flat grey."""
    out = frame.copy()
    out[mask] = gray
    return out


def blackout(frame: np.ndarray) -> np.ndarray:
    return np.zeros_like(frame)


def add_noise(frame: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """`frame` plus a float noise field, rounded and clipped to uint8."""
    return np.clip(frame.astype(np.float32) + noise, 0, 255).round().astype(np.uint8)


def scaled_px(px_at_256: int, height: int) -> int:
    """A pixel length stated at 256 px, scaled to a frame of `height` px (at least 1 if nonzero)."""
    if px_at_256 <= 0:
        return 0
    return max(1, int(round(px_at_256 * height / 256)))
