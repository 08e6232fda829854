#!/usr/bin/env bash
# A LIBERO "fork" environment without the toolkit: LIBERO's code and assets, robosuite, mujoco and
# CPU torch (LIBERO's benchmark module imports it), nothing of libero-vpro. The pack-import tests
# register packs in it through the pack's own vpro_libero_fork.py. Idempotent.
set -euo pipefail
source "$(dirname "$0")/lib-venv.sh"
fork_venv_begin "${1:-out/fork-venv}"
"$venv/bin/pip" install --quiet "robosuite==1.4.1" "mujoco==3.8.1" "numpy<2" "bddl==1.0.1" easydict gymnasium \
  pyyaml future cloudpickle opencv-python-headless matplotlib "torch==2.13.0" "${LIBERO_ASSET_WHEELS[@]}"
"$venv/bin/pip" install --quiet --no-deps hf-libero==0.1.4
fork_venv_finish
