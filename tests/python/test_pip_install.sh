#!/usr/bin/env bash
# CTest test_pip_install (label `pip`): `pip install .` of the repository
# (pyproject.toml, scikit-build-core) into a fresh venv, then import brdftab
# there and evaluate a table that the CLI wrote; the result must equal
# `brdftab query` (an independent process and parser) to 1e-12.
#     test_pip_install.sh PYTHON SOURCE_DIR CLI WORK_DIR
# Skips (exit 77) with a message when PYTHON cannot make a venv or when pip
# cannot reach its package index (the build backend comes from PyPI).
set -euo pipefail
python=$1 source=$2 cli=$3 work=$4
rm -rf "$work"
mkdir -p "$work"
trap 'rm -rf "$work"' EXIT

if ! "$python" -m venv "$work/venv" >"$work/venv.log" 2>&1; then
  echo "SKIPPED: $python -m venv failed (Debian: apt-get install python3-venv):"
  cat "$work/venv.log"
  exit 77
fi
pip=("$work/venv/bin/python" -m pip)
# Reachability of the index pip is configured with (PyPI unless PIP_INDEX_URL
# or pip.conf say otherwise): fetch the build backend alone.
if ! timeout 120 "${pip[@]}" download -q --no-deps -d "$work/probe" scikit-build-core \
    >"$work/probe.log" 2>&1; then
  echo "SKIPPED: pip cannot download scikit-build-core (no package index reachable):"
  tail -n 3 "$work/probe.log"
  exit 77
fi

# ccache, when there is one, keeps repeated runs short (the build directory
# is a fresh temporary one each time).
settings=()
if command -v ccache >/dev/null; then
  settings+=(--config-settings=cmake.define.CMAKE_CXX_COMPILER_LAUNCHER=ccache
             --config-settings=cmake.define.CMAKE_C_COMPILER_LAUNCHER=ccache)
fi
echo "pip install $source into $work/venv"
"${pip[@]}" install -q "${settings[@]}" "$source"

# The module must come from the venv's site-packages, not from a build tree.
cd "$work"
spec="$work/oren-nayar.toml"
cat >"$spec" <<'EOF'
model = "oren-nayar"
[parameters]
nodes = 6
sigma = 20.0
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 5
[[axes]]
name = "theta_o"
range = [0.0, 90.0]
count = 6
[[axes]]
name = "phi_d"
range = [0.0, 180.0]
count = 5
[[tables]]
quantity = "brdf_direct"
[integration]
method = "quadrature"
[output]
type = "float64"
EOF
"$cli" generate "$spec" -o "$work/table.h5" >/dev/null
"$cli" query "$work/table.h5" --table brdf_direct theta_i=33 theta_o=47 phi_d=101 --json \
  >"$work/query.json"
PYTHONPATH= "$work/venv/bin/python" - "$work/table.h5" "$work/query.json" "$work/venv" <<'EOF'
import importlib.util
import json
import os
import sys

import brdftab

path, query, venv = sys.argv[1], sys.argv[2], sys.argv[3]
with open(query) as f:
    expected = json.load(f)["value"]
where = os.path.realpath(brdftab.__file__)
assert where.startswith(os.path.realpath(venv)), f"brdftab imported from {where}, not the venv"
# The Mitsuba plugin is installed beside it (importing it needs mitsuba).
assert importlib.util.find_spec("brdftab.mitsuba") is not None
got = brdftab.open(path).tables["brdf_direct"].eval(theta_i=33, theta_o=47, phi_d=101)
assert abs(got - expected) <= 1e-12 * max(1.0, abs(expected)), (got, expected)
print(f"pip-installed brdftab ({where}): {got!r} == brdftab query {expected!r}")
EOF
