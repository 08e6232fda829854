#!/usr/bin/env bash
# Debian packages for headless MuJoCo rendering: EGL through Mesa (llvmpipe) and OSMesa as
# the fallback. Installs only what is missing, so running it again is a no-op.
set -euo pipefail
needed=(libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libosmesa6 libglu1-mesa)
missing=()
for pkg in "${needed[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
((${#missing[@]})) || exit 0
if ! command -v apt-get >/dev/null; then
  echo "missing system packages ${missing[*]} and no apt-get: install them by hand" >&2
  exit 1
fi
sudo_cmd=""
[ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
echo "installing system packages: ${missing[*]}"
$sudo_cmd apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
