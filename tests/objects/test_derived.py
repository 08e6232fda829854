"""Derived copies of MJCF objects: referenced files found as MuJoCo finds them, copied, XML written."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
from PIL import Image

from vpro_assets.objects.derived import referenced_files, write_derived

TETRA = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
SOURCE = """<mujoco model="src">
  <compiler meshdir="parts" texturedir="pics"/>
  <asset>
    <texture name="t" type="2d" file="wood.png"/>
    <material name="m" texture="t"/>
    <mesh name="tetra" file="tetra.obj"/>
  </asset>
  <worldbody><body><body name="object"><geom type="mesh" mesh="tetra" material="m"/></body></body></worldbody>
</mujoco>
"""


def test_copy_honours_meshdir_and_texturedir_and_the_copy_compiles(tmp_path):
    src = tmp_path / "src"
    (src / "parts").mkdir(parents=True)
    (src / "pics").mkdir()
    (src / "parts" / "tetra.obj").write_text(TETRA)
    Image.fromarray(np.full((4, 4, 3), 128, np.uint8)).save(src / "pics" / "wood.png")
    (src / "src.xml").write_text(SOURCE)
    root = ET.parse(src / "src.xml").getroot()
    assert [rel for _e, rel in referenced_files(root)] == ["pics/wood.png", "parts/tetra.obj"]
    out = write_derived(root, src / "src.xml", "copy", tmp_path / "copy")
    assert out == tmp_path / "copy" / "copy.xml"
    assert (tmp_path / "copy" / "parts" / "tetra.obj").read_text() == TETRA
    assert ET.parse(out).getroot().get("model") == "copy"
    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.nmesh == 1 and model.ntex == 1
