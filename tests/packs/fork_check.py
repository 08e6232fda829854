"""Run inside the fork venv (no libero-vpro installed): register a pack with the pack's own
module, then build every pack scene through LIBERO's own API the way openpi's LIBERO example
does, load every initial state with LIBERO's torch.load, and step. Prints a JSON report.
`--every N`: only every N-th task over all suites (the full pack's measurement, docs/packs.md)."""

import importlib.util
import json
import os
import sys

pack = sys.argv[1]
assert importlib.util.find_spec("vpro_assets") is None, "the fork venv must not have the toolkit"
if pack.endswith(".tar.gz"):
    # A user unpacks the archive to get the module (`tar xzf`); register() takes the archive itself.
    import tarfile
    import tempfile

    unpacked = tempfile.mkdtemp()
    with tarfile.open(pack) as tar:
        tar.extractall(unpacked, filter="data")
    sys.path.insert(0, os.path.join(unpacked, os.listdir(unpacked)[0]))
else:
    sys.path.insert(0, pack)
import vpro_libero_fork  # noqa: E402

if len(sys.argv) > 2 and sys.argv[2] == "--expect-clash":
    # The pack's manifest was edited to reuse names LIBERO already has: registration must refuse
    # and leave both registries exactly as they were.
    from libero.libero import benchmark
    from libero.libero.envs import OBJECTS_DICT

    before = (dict(OBJECTS_DICT), dict(benchmark.BENCHMARK_MAPPING))
    try:
        vpro_libero_fork.register(pack)
    except vpro_libero_fork.PackRegistrationError as exc:
        after = (dict(OBJECTS_DICT), dict(benchmark.BENCHMARK_MAPPING))
        print("REPORT " + json.dumps({"error": str(exc), "unchanged": before == after}))
    else:
        print("REPORT " + json.dumps({"error": None}))
    sys.exit(0)

every = int(sys.argv[sys.argv.index("--every") + 1]) if "--every" in sys.argv else 1
classes = vpro_libero_fork.register(pack)
again = vpro_libero_fork.register(pack)  # idempotent
from libero.libero import benchmark, get_libero_path  # noqa: E402
from libero.libero.envs import OffScreenRenderEnv  # noqa: E402

report = {
    "suites": {},
    "idempotent": {k: v.__name__ for k, v in again.items()} == {k: v.__name__ for k, v in classes.items()},
    "tasks": 0,
}
for name in classes:
    suite = benchmark.get_benchmark_dict()[name]()
    rows = []
    for i in range(suite.n_tasks):
        report["tasks"] += 1
        if (report["tasks"] - 1) % every:
            continue
        task = suite.get_task(i)
        bddl = os.path.join(get_libero_path("bddl_files"), task.problem_folder, task.bddl_file)
        assert bddl == suite.get_task_bddl_file_path(i)
        states = suite.get_task_init_states(i)
        env = OffScreenRenderEnv(bddl_file_name=bddl, camera_heights=64, camera_widths=64)
        env.seed(0)
        env.reset()
        stepped = 0
        for state in states[:10]:
            env.set_init_state(state)
            obs, reward, done, info = env.step([0.0] * 6 + [-1.0])
            stepped += 1
        env.close()
        rows.append(
            {
                "task": task.name,
                "language": task.language,
                "init_states": int(len(states)),
                "stepped": stepped,
                "image": list(obs["agentview_image"].shape),
            }
        )
    report["suites"][name] = rows
print("REPORT " + json.dumps(report))
