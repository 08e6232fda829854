"""Writing images for people to look at (snapshots, contact sheets)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from vpro_assets.core.atomic import write_bytes_atomic
from vpro_assets.core.errors import VProError


def label(image: np.ndarray, text: str) -> np.ndarray:
    """A copy of an RGB image with `text` in its top-left corner."""
    out = np.ascontiguousarray(image).copy()
    scale = max(out.shape[0] / 512, 0.35)
    for color, thickness in (((0, 0, 0), 3), ((255, 255, 255), 1)):
        cv2.putText(
            out, text, (4, int(14 * scale / 0.5)), cv2.FONT_HERSHEY_SIMPLEX, scale, color, thickness, cv2.LINE_AA
        )
    return out


def write_png(path: Path | str, rgb: np.ndarray, labels: Sequence[str] = ()) -> None:
    """Write an RGB uint8 image; `labels` annotate equal-width panels left to right."""
    rgb = np.asarray(rgb, dtype=np.uint8)
    if labels:
        width = rgb.shape[1] // len(labels)
        rgb = np.concatenate([label(rgb[:, i * width : (i + 1) * width], t) for i, t in enumerate(labels)], axis=1)
    ok, encoded = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise VProError(f"could not encode PNG for {path}")
    write_bytes_atomic(path, encoded.tobytes())
