"""LIBERO's placement rotation of an object class (vpro_assets.scene.pose.class_quat)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
from robosuite.utils.transform_utils import quat_multiply

from vpro_assets.scene.pose import class_quat


def _libero_sampler(rotation: dict) -> np.ndarray:
    """LIBERO's MultiRegionRandomSampler._sample_quat for a dict of fixed angles: (x, y, z, w)."""
    quat = np.array([0.0, 0.0, 0.0, 1.0])
    for axis, (lo, hi) in rotation.items():
        angle = (lo + hi) / 2
        turn = np.zeros(4)
        turn[3], turn["xyz".index(axis)] = math.cos(angle / 2), math.sin(angle / 2)
        quat = quat_multiply(turn, quat)
    return quat


def test_dict_rotation_composes_like_libero_and_keeps_its_convention_slip():
    rotation = {"x": (math.pi / 2, math.pi / 2), "z": (math.pi / 3, math.pi / 3)}
    got = class_quat(SimpleNamespace(rotation=rotation))
    # LIBERO's own numbers (robosuite computes them in float32), written as they are into qpos.
    np.testing.assert_allclose(got, _libero_sampler(rotation), atol=1e-7)


def test_range_about_one_axis_gives_the_middle_or_a_draw_from_the_stream():
    obj = SimpleNamespace(rotation=(0.0, math.pi), rotation_axis="z")
    np.testing.assert_allclose(class_quat(obj), [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    a = class_quat(obj, np.random.default_rng(3))
    b = class_quat(obj, np.random.default_rng(3))
    assert np.array_equal(a, b) and not np.allclose(a, class_quat(obj))
