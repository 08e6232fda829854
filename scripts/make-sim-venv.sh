#!/usr/bin/env bash
# A simulator venv for comparing MuJoCo versions: the toolkit's own dependencies (pyproject.toml)
# with mujoco swapped for MUJOCO_VERSION, LIBERO's code from hf-libero (--no-deps, as the Makefile
# installs it) and the toolkit itself installed with --no-deps, so `vpro settle` / `vpro drift`
# run there unchanged. Usage: scripts/make-sim-venv.sh MUJOCO_VERSION [VENV_DIR]
# (default out/sim-venvs/mujoco-MUJOCO_VERSION). Idempotent: a finished venv is left alone.
set -euo pipefail
version=${1:?usage: scripts/make-sim-venv.sh MUJOCO_VERSION [VENV_DIR]}
repo=$(cd "$(dirname "$0")/.." && pwd)
venv=${2:-$repo/out/sim-venvs/mujoco-$version}
stamp="$venv/.sim-ready"
[ -f "$stamp" ] && exit 0
python=${PYTHON:-python3}
"$python" -m venv "$venv"
"$venv/bin/pip" install --quiet --upgrade pip wheel setuptools
# The toolkit's declared dependencies (base, the simulator extra and tests), with the mujoco pin replaced.
mapfile -t deps < <("$venv/bin/python" - "$repo/pyproject.toml" <<'PY'
import re, sys
try:
    import tomllib
except ImportError:  # Python 3.10
    from pip._vendor import tomli as tomllib
with open(sys.argv[1], "rb") as f:
    project = tomllib.load(f)["project"]
extras = project["optional-dependencies"]
for dep in project["dependencies"] + extras["sim"] + extras["test"]:
    if re.split(r"[<>=!~\[; ]", dep, maxsplit=1)[0].lower() != "mujoco":
        print(dep)
PY
)
"$venv/bin/pip" install --quiet "mujoco==$version" "${deps[@]}"
"$venv/bin/pip" install --quiet --no-deps hf-libero==0.1.4
"$venv/bin/pip" install --quiet --no-deps -e "$repo"
"$venv/bin/python" "$repo/scripts/robosuite_private_macros.py"
got=$("$venv/bin/python" -c "import mujoco; print(mujoco.__version__)")
[ "$got" = "$version" ] || { echo "make-sim-venv: mujoco $got installed, wanted $version" >&2; exit 1; }
touch "$stamp"
