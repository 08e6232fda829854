"""Run inside a fork venv (no libero-vpro installed): register a pack with the pack's own module,
then run the first task of every observation suite through a fork-style loop (LIBERO's benchmark
API, `OffScreenRenderEnv`, seed + reset + initial state, `step`) with the env wrapped by
`vpro_libero_fork.wrap`. The raw frames LIBERO returned are recorded beside the observations the
wrapper handed out, so the test can check what each case did. Prints a JSON report.

usage: fork_obs_check.py PACK STEPS
"""

import hashlib
import importlib.util
import json
import os
import sys
import time

import numpy as np

pack, steps = sys.argv[1], int(sys.argv[2])
assert importlib.util.find_spec("vpro_assets") is None, "the fork venv must not have the toolkit"
config_file = os.path.join(os.environ["LIBERO_CONFIG_PATH"], "config.yaml")


def digest(path):
    with open(path, "rb") as handle:
        return hashlib.sha256(handle.read()).hexdigest()


config_before = digest(config_file)
sys.path.insert(0, pack)
import robosuite  # noqa: E402
from fork_setup import fork_setup  # noqa: E402

fork_setup()
from libero.libero import benchmark  # noqa: E402
from libero.libero.envs import OffScreenRenderEnv  # noqa: E402

# What the fork writes by itself happens above (rpent-libero's import takes a file lock beside its
# config, matplotlib makes its config folder in the home); from here on nothing may appear in the
# home, the working folder or the config folder.
WATCHED = (os.environ["HOME"], os.getcwd(), os.environ["LIBERO_CONFIG_PATH"])


def files():
    return {os.path.join(d, f) for top in WATCHED for d, _, names in os.walk(top) for f in names}


files_before = files()
import vpro_libero_fork  # noqa: E402

CAMS = ("agentview", "robot0_eye_in_hand")


class Recorder:
    """The fork's env, keeping every observation LIBERO returns (the raw frames) in order."""

    def __init__(self, env):
        self.env, self.raw = env, []

    def __getattr__(self, name):
        return getattr(self.env, name)

    def step(self, action):
        out = self.env.step(action)
        self.raw.append(out[0])
        return out

    def set_init_state(self, state):
        obs = self.env.set_init_state(state)
        self.raw.append(obs)
        return obs


classes = vpro_libero_fork.register(pack)
report = {"robosuite": robosuite.__version__, "cases": {}}
for name in sorted(classes):
    suite = benchmark.get_benchmark_dict()[name]()
    task = suite.get_task(0)
    case_path = os.path.join(pack, "cases", name, f"{task.name}.json")
    with open(case_path) as handle:
        case = json.load(handle)
    if case["level"] != "observation":
        continue
    started = time.perf_counter()
    env = OffScreenRenderEnv(bddl_file_name=suite.get_task_bddl_file_path(0), camera_heights=128, camera_widths=128)
    built = time.perf_counter()
    recorder = Recorder(env)
    raw = recorder.raw  # what LIBERO returned: the initial state's frames, then one per step
    wrapped = vpro_libero_fork.wrap(recorder, case_path)
    obs = vpro_libero_fork.reset(wrapped, case["id"], 0, suite.get_task_init_states(0))  # an id: looked up in the pack
    seen, fed = [obs], []
    for t in range(steps):
        action = [0.4 * np.sin(t / 3.0), 0.4 * np.cos(t / 4.0), 0.3, 0.0, 0.0, 0.2, -1.0]
        predicted = None
        if case["category"] == "prediction_reality_divergence":
            predicted = {c: np.full_like(raw[-1][f"{c}_image"], (7 * t + 1) % 256) for c in CAMS}
            fed.append({c: int(v[0, 0, 0]) for c, v in predicted.items()})
        obs, reward, done, info = wrapped.step(action, predicted_frames=predicted)
        seen.append(obs)
    # The last state drawn with the case's per-camera scene edits (Cross-View Contradiction) and,
    # after the wrapper lets go of the renderer, as LIBERO draws it.
    edited = {c: env.sim.render(width=128, height=128, camera_name=c) for c in CAMS}
    wrapped._observer.pipeline.detach()
    clean = {c: env.sim.render(width=128, height=128, camera_name=c) for c in CAMS}
    env.close()
    seconds = {"build": round(built - started, 2), "episode": round(time.perf_counter() - built, 2)}
    rows = []
    for o, r in zip(seen, raw):
        row = {}
        for c in CAMS:
            key = f"{c}_image"
            if key not in o:
                row[c] = "absent"
                continue
            frame = o[key]
            same = [s for s in range(len(raw)) if np.array_equal(frame, raw[s][key])]
            row[c] = {
                "equals_raw": bool(np.array_equal(frame, r[key])),
                "raw_steps": same[:3],
                "shape": list(frame.shape),
                "value00": int(frame[0, 0, 0]),
                "uniform": bool((frame == frame.flat[0]).all()),
            }
        rows.append(row)
    edits = {c: not np.array_equal(edited[c], clean[c]) for c in CAMS}
    report["cases"][case["category"]] = {
        "id": case["id"],
        "rows": rows,
        "fed": fed,
        "scene_edits": edits,
        "seconds": seconds,
        "raw_moves": not np.array_equal(raw[0]["robot0_eye_in_hand_image"], raw[-1]["robot0_eye_in_hand_image"]),
    }
report["config_unchanged"] = digest(config_file) == config_before
report["written"] = sorted(files() - files_before)
print("REPORT " + json.dumps(report))
