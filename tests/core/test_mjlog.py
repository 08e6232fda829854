"""MuJoCo's warnings reach logging, not MUJOCO_LOG.TXT in the user's working directory."""

import subprocess
import sys

# 20 spheres piled into each other with room for too few contacts: the first forward pass warns.
WARNS = """
import logging, mujoco
logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
{route}
pile = "".join(f'<body pos="0 0 {{0.01 * i}}"><freejoint/><geom size="0.1"/></body>' for i in range(20))
model = mujoco.MjModel.from_xml_string(f'<mujoco><size memory="16K"/><worldbody>{{pile}}</worldbody></mujoco>')
mujoco.mj_forward(model, mujoco.MjData(model))
"""


def _run(tmp_path, route: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", WARNS.format(route=route)], cwd=tmp_path, capture_output=True, text=True
    )


def test_a_routed_warning_is_logged_and_writes_no_file(tmp_path):
    (tmp_path / "default").mkdir()
    (tmp_path / "routed").mkdir()
    # MuJoCo's own handler writes the file: what the routing must prevent.
    _run(tmp_path / "default", "")
    assert (tmp_path / "default" / "MUJOCO_LOG.TXT").is_file()
    routed = _run(tmp_path / "routed", "from vpro_assets.core import mjlog; mjlog.route_warnings()")
    assert routed.returncode == 0, routed.stderr
    assert list((tmp_path / "routed").iterdir()) == []
    assert "mujoco: Too many contacts" in routed.stderr, routed.stderr
