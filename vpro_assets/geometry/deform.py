"""The four target deformations as smooth maps of space, defined in an object's upright frame.

Every map moves points only horizontally (perpendicular to the object's up axis), so the object's
height, its bottom plane and its resting support are unchanged; and every map is a bijection of
each horizontal slice (a rotation or a positive radial scaling), so a closed 2-manifold stays a
closed 2-manifold without self-intersections.

With `t` the normalised height (0 at the bottom, 1 at the top), `r, phi` polar coordinates about
the vertical axis through the solid's centroid:

- taper:      horizontal offsets scaled by s(t) = (1 + (k - 1) t) * 2 / (1 + k), k = top_scale
              (the top is k times the bottom; mid-height keeps its size, so volume stays close);
- twist:      slice made elliptical, r scaled by 1 + e cos(2 phi), e = twist_ellipticity, then
              rotated by theta(t) = twist_degrees * (t - 1/2): a twisted elliptic column. The
              ellipse makes it a change of shape for round targets too (a rotation alone leaves a
              solid of revolution where it was); its width seen from any side now varies with
              height. Area of each slice grows by e^2/2;
- multipeak:  r scaled by 1 + a cos(5 phi), a = peak_amplitude (five lobes, volume +a^2/2);
- asymmetric: r scaled by 1 + b max(0, cos(phi - phi0))^2 * 4 t (1 - t), b = bulge, phi0 = 0
              (one side bulges, most at mid-height; bottom and top outlines unchanged).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from vpro_assets.core.errors import InvalidParameterError

MULTIPEAK_LOBES = 5
TWIST_LOBES = 2  # an ellipse: the lobe count whose silhouette width changes as the slice turns
# (an odd count gives a shape of nearly constant width, whose outline hardly shows the twist)
BULGE_AZIMUTH_DEG = 0.0  # towards the first horizontal axis of the object's upright frame

# deformation -> (parameter name, identity value, allowed open interval)
DEFORMATIONS: dict[str, tuple[str, float, tuple[float, float]]] = {
    "taper": ("top_scale", 1.0, (0.0, 10.0)),
    "multipeak": ("peak_amplitude", 0.0, (-0.5, 0.5)),
    "twist": ("twist_degrees", 0.0, (-360.0, 360.0)),
    "asymmetric": ("bulge", 0.0, (-0.5, 1.0)),
}
# deformation -> {extra parameter: (identity value, allowed open interval)}; a setting that omits
# one gets its identity value (only twist has one: the ellipticity of its cross-section).
EXTRA_PARAMS: dict[str, dict[str, tuple[float, tuple[float, float]]]] = {
    "twist": {"twist_ellipticity": (0.0, (-0.5, 0.5))},
}
AXES = {"+x": (0, 1.0), "-x": (0, -1.0), "+y": (1, 1.0), "-y": (1, -1.0), "+z": (2, 1.0), "-z": (2, -1.0)}


@dataclass(frozen=True)
class UprightFrame:
    """Object frame -> upright frame (u, v, w): w along the object's up axis, origin on the axis
    at the bottom of the solid."""

    rotation: np.ndarray  # (3, 3): rows are u, v, w expressed in object coordinates
    origin: np.ndarray  # (3,) object coordinates of the axis point at the bottom
    height: float

    def to_upright(self, points: np.ndarray) -> np.ndarray:
        return (points - self.origin) @ self.rotation.T

    def from_upright(self, points: np.ndarray) -> np.ndarray:
        return points @ self.rotation + self.origin


def upright_frame(up_axis: str, vertices: np.ndarray, centroid: np.ndarray) -> UprightFrame:
    """The frame whose w axis is `up_axis` ("+z", "+y"...), through the solid's centroid."""
    if up_axis not in AXES:
        raise InvalidParameterError(f"up axis {up_axis!r} is not one of {', '.join(AXES)}")
    index, sign = AXES[up_axis]
    w = np.zeros(3)
    w[index] = sign
    u = np.zeros(3)
    u[(index + 1) % 3] = 1.0
    v = np.cross(w, u)
    rotation = np.stack([u, v, w])
    heights = vertices @ w
    origin = centroid - (centroid @ w) * w + heights.min() * w
    return UprightFrame(rotation, origin, float(heights.max() - heights.min()))


def check_amount(deformation: str, amount: float, **extra: float) -> None:
    if deformation not in DEFORMATIONS:
        raise InvalidParameterError(f"deformation {deformation!r} is not one of {', '.join(DEFORMATIONS)}")
    name, _identity, bounds = DEFORMATIONS[deformation]
    allowed = EXTRA_PARAMS.get(deformation, {})
    for key in extra:
        if key not in allowed:
            raise InvalidParameterError(f"{deformation} has no parameter {key!r} (has {', '.join([name, *allowed])})")
    for key, value in ((name, amount), *extra.items()):
        lo, hi = bounds if key == name else allowed[key][1]
        if isinstance(value, bool) or not (isinstance(value, (int, float)) and np.isfinite(value) and lo < value < hi):
            raise InvalidParameterError(f"{deformation} {key}={value!r} is outside ({lo}, {hi})")


def _upright_map(
    deformation: str, amount: float, extra: Mapping[str, float]
) -> Callable[[np.ndarray, float], np.ndarray]:
    def apply(p: np.ndarray, height: float) -> np.ndarray:
        t = np.clip(p[:, 2] / height, 0.0, 1.0) if height > 0 else np.zeros(len(p))
        x, y = p[:, 0], p[:, 1]
        if deformation == "taper":
            scale = (1.0 + (amount - 1.0) * t) * 2.0 / (1.0 + amount)
            nx, ny = x * scale, y * scale
        elif deformation == "twist":
            ellipse = 1.0 + extra["twist_ellipticity"] * np.cos(TWIST_LOBES * np.arctan2(y, x))
            x, y = x * ellipse, y * ellipse
            theta = np.radians(amount) * (t - 0.5)
            c, s = np.cos(theta), np.sin(theta)
            nx, ny = c * x - s * y, s * x + c * y
        else:
            phi = np.arctan2(y, x)
            if deformation == "multipeak":
                scale = 1.0 + amount * np.cos(MULTIPEAK_LOBES * phi)
            else:  # asymmetric
                facing = np.maximum(0.0, np.cos(phi - np.radians(BULGE_AZIMUTH_DEG))) ** 2
                scale = 1.0 + amount * facing * 4.0 * t * (1.0 - t)
            nx, ny = x * scale, y * scale
        return np.stack([nx, ny, p[:, 2]], axis=1)

    return apply


def deformation_map(
    deformation: str, amount: float, frame: UprightFrame, **extra: float
) -> Callable[[np.ndarray], np.ndarray]:
    """The map object coordinates -> deformed object coordinates, vectorised over (N, 3); `extra`
    holds the deformation's other parameters (EXTRA_PARAMS; omitted ones take their identity)."""
    check_amount(deformation, amount, **extra)
    defaults = {key: identity for key, (identity, _bounds) in EXTRA_PARAMS.get(deformation, {}).items()}
    upright = _upright_map(deformation, float(amount), {**defaults, **{k: float(v) for k, v in extra.items()}})

    def warp(points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64)
        return frame.from_upright(upright(frame.to_upright(points), frame.height))

    return warp


def scaled(
    warp: Callable[[np.ndarray], np.ndarray], scale: float, origin: np.ndarray
) -> Callable[[np.ndarray], np.ndarray]:
    """`warp` followed by a uniform scaling by `scale` about `origin` (an upright frame's origin,
    the bottom point of its up axis: the bottom plane and the axis stay where they are)."""
    if not (isinstance(scale, (int, float)) and np.isfinite(scale) and 0.0 < scale <= 1.0):
        raise InvalidParameterError(f"fit scale {scale!r} is outside (0, 1]")
    origin = np.asarray(origin, dtype=np.float64)

    def apply(points: np.ndarray) -> np.ndarray:
        return origin + float(scale) * (warp(points) - origin)

    return apply


def amount_of(deformation: str, params: Mapping[str, object]) -> float:
    """The magnitude of `deformation` from a setting's params (taxonomy's GEOMETRY_SEVERITY names)."""
    name = DEFORMATIONS[deformation][0]
    if name not in params:
        raise InvalidParameterError(f"{deformation}: setting params lack {name!r} (have {sorted(params)})")
    value = params[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InvalidParameterError(f"{deformation}: {name} must be a number, got {value!r}")
    return float(value)


def extra_params_of(deformation: str, params: Mapping[str, object]) -> dict[str, float]:
    """The deformation's other parameters (EXTRA_PARAMS) present in a setting's params."""
    out = {}
    for name in EXTRA_PARAMS.get(deformation, {}):
        if name in params:
            value = params[name]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InvalidParameterError(f"{deformation}: {name} must be a number, got {value!r}")
            out[name] = float(value)
    return out


def displacement_measure(points: np.ndarray, warp: Callable[[np.ndarray], np.ndarray], size: float) -> float:
    """Mean displacement of `points` under `warp`, as a fraction of `size` (e.g. the bbox diagonal)."""
    moved = warp(points)
    return float(np.linalg.norm(moved - points, axis=1).mean() / size)


def transform_normals(
    points: np.ndarray, normals: np.ndarray, warp: Callable[[np.ndarray], np.ndarray], step: float = 1e-5
) -> np.ndarray:
    """Normals carried through `warp`: n' = J^-T n (J by central differences at each point), unit length."""
    points = np.asarray(points, dtype=np.float64)
    jacobian = np.empty((len(points), 3, 3))
    for k in range(3):
        offset = np.zeros(3)
        offset[k] = step
        jacobian[:, :, k] = (warp(points + offset) - warp(points - offset)) / (2 * step)
    moved = np.linalg.solve(np.transpose(jacobian, (0, 2, 1)), np.asarray(normals, np.float64)[..., None])[..., 0]
    return moved / np.maximum(np.linalg.norm(moved, axis=1, keepdims=True), 1e-12)
