"""Every base task builds headless, resets, loads its first LIBERO initial state and steps."""

import numpy as np
import pytest

from vpro_assets.libero.bridge import suite_task_names
from vpro_assets.libero.env import CAMERAS, NOOP_ACTION, libero_init_states, task_env

KEYS = [f"{suite}-{i:02d}" for suite, names in suite_task_names().items() for i in range(len(names))]
RES = 128  # render cost barely depends on resolution; 128 keeps the 40 builds light


@pytest.mark.parametrize("key", KEYS)
def test_task_builds_resets_loads_initial_state_and_steps(key):
    from vpro_assets.libero.tasks import get_task

    task = get_task(key)
    states = libero_init_states(task)
    assert states.shape[0] == 50
    with task_env(task, RES) as env:
        env.reset()
        sim = env.sim
        assert states.shape[1] == 1 + sim.model.nq + sim.model.nv, "initial-state row width != time+qpos+qvel"
        obs = env.set_init_state(states[0])
        np.testing.assert_allclose(sim.data.qpos, states[0][1 : 1 + sim.model.nq])
        t0 = sim.data.time
        obs, reward, done, info = env.step(NOOP_ACTION)
        assert sim.data.time > t0
        for cam in CAMERAS:
            image = obs[f"{cam}_image"]
            assert image.shape == (RES, RES, 3) and image.dtype == np.uint8
            assert image.std() > 5, f"{cam} rendered a flat image"
        assert obs["robot0_eef_pos"].shape == (3,) and obs["robot0_gripper_qpos"].shape == (2,)
        assert not done


def test_interpreter_exit_with_a_live_env_prints_no_gl_teardown_errors(tmp_path):
    """robosuite terminates the EGL display at exit before live contexts are freed; the toolkit
    frees them first, so a CLI run ends without 'Exception ignored' tracebacks."""
    import os
    import subprocess
    import sys

    script = (
        "from vpro_assets.libero.env import make_env\nfrom vpro_assets.libero.tasks import get_task\n"
        "env = make_env(get_task('libero_spatial-00'), 32)\nenv.reset()\nprint('built')\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=dict(os.environ)
    )
    assert proc.returncode == 0 and proc.stdout.strip() == "built", proc.stderr[-2000:]
    assert "Exception ignored" not in proc.stderr, proc.stderr[-2000:]
