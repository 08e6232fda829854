"""Records of the deformed-object pipeline: the results of its first stages (`Original`,
`Deformed`) and what it returns (`GeneratedObject`: the object's files with their sha256, its
record (`record.json`) and, when built rather than reused, the seconds each stage took)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import manifold3d
import numpy as np

from vpro_assets.geometry.deform import UprightFrame
from vpro_assets.geometry.meshes import LiberoObjectSource, MeshPart
from vpro_assets.geometry.solid import RepairReport


@dataclass(frozen=True)
class GeneratedFile:
    path: str  # relative to out_dir, '/' separated
    sha256: str
    role: str  # "mjcf", "urdf", "usd", "visual_mesh", "solid_mesh", "hull_mesh", "texture", "record"


@dataclass
class GeneratedObject:
    name: str
    category: str
    deformation: str
    severity: int
    setting_id: str
    out_dir: Path
    files: tuple[GeneratedFile, ...]
    record: dict
    cached: bool = False
    timings: dict[str, float] = field(default_factory=dict)  # seconds per stage (empty when cached)
    peak_rss_mb: float = 0.0  # of the child process it was generated in (`isolate`), else 0

    def path(self, role: str) -> Path:
        return self.out_dir / next(f.path for f in self.files if f.role == role)

    @property
    def xml_path(self) -> Path:
        return self.path("mjcf")

    @property
    def urdf_path(self) -> Path:
        return self.path("urdf")

    @property
    def usd_path(self) -> Path:
        return self.path("usd")

    def file_hashes(self) -> dict[str, str]:
        """{relative path: sha256} of every file, for the catalog."""
        return {f.path: f.sha256 for f in self.files}


@dataclass
class Original:
    """Stage 1: the source object and its solid, refined to edges under `max_edge`."""

    source: LiberoObjectSource
    solid: manifold3d.Manifold
    vertices: np.ndarray
    faces: np.ndarray
    reports: list[RepairReport]
    extent: float  # largest extent of the solid, m
    max_edge: float
    frame: UprightFrame


@dataclass
class Deformed:
    """Stage 2: the deformed solid and visual parts (part, corners, uv, normals)."""

    warp: Callable[[np.ndarray], np.ndarray]
    solid: manifold3d.Manifold
    vertices: np.ndarray
    faces: np.ndarray
    visual_parts: list[tuple[MeshPart, np.ndarray, np.ndarray | None, np.ndarray | None]]
    fit_scale: float = 1.0  # uniform scale after the deformation, about the bottom of the up axis (1: none)
