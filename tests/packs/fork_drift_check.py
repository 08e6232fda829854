"""Run inside a fork venv (no libero-vpro installed): the pack's own drift check, as a fork user
runs it after their own set-up lines: `vpro_libero_fork.main(["verify", PACK, "--simulate", ...])`,
the same as `python -m vpro_libero_fork verify PACK --simulate ...`; exits with its status.

usage: fork_drift_check.py PACK [verify options]
"""

import importlib.util
import sys

from fork_setup import fork_setup

assert importlib.util.find_spec("vpro_assets") is None, "the fork venv must not have the toolkit"
print(f"robosuite {fork_setup()}")
sys.path.insert(0, sys.argv[1])
import vpro_libero_fork  # noqa: E402

sys.exit(vpro_libero_fork.main(["verify", *sys.argv[1:], "--simulate"]))
