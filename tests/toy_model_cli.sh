#!/usr/bin/env bash
# The toy model through the CLI: brdftab_toy is the brdftab command line with
# the test-only toy-lambert model linked in (tests/CMakeLists.txt).  It must
# list the model, evaluate it and generate a table from a spec, with no other
# change to the program: what docs/adding-a-model.md promises.
# Usage: toy_model_cli.sh BRDFTAB_TOY SOURCE_DIR BINARY_DIR
set -euo pipefail
bin=$1 src=$2 build=$3
work=$build/tmp-toy-model-cli
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
# Debian's python3 has h5py and numpy (scripts/setup.sh); a python3 earlier on
# PATH may not.
PY=/usr/bin/python3

listing=$("$bin" models)
[[ $listing == *toy-lambert* ]] || fail "models does not list toy-lambert"
"$bin" models --json | "$PY" -c '
import json, sys
m = [x for x in json.load(sys.stdin) if x["name"] == "toy-lambert"]
assert len(m) == 1, "toy-lambert missing from models --json"
assert [q["name"] for q in m[0]["quantities"]] == ["brdf", "albedo"], m[0]["quantities"]
' || fail "models --json"

# brdf = albedo / pi exactly (closed form).
out=$("$bin" eval toy-lambert brdf theta_i=30 theta_o=45 albedo=0.5 --json)
"$PY" -c '
import json, math, sys
v = json.loads(sys.argv[1])["value"]
assert abs(v - 0.5 / math.pi) < 1e-15, v
' "$out" || fail "eval brdf: $out"

# albedo: the cosine-sampled estimator returns the parameter itself.
out=$("$bin" eval toy-lambert albedo theta_i=30 albedo=0.25 sampling=cosine --json)
"$PY" -c '
import json, sys
v = json.loads(sys.argv[1])["value"]
assert abs(v - 0.25) < 1e-15, v
' "$out" || fail "eval albedo: $out"

"$bin" generate "$src/tests/toy_model/toy_lambert.toml" -o "$work/toy.h5" --seed 5 > "$work/log" 2>&1 \
  || { cat "$work/log"; fail "generate"; }
"$PY" - "$work/toy.h5" <<'PY' || fail "generated table"
import sys, h5py, numpy as np
with h5py.File(sys.argv[1], "r") as f:
    v = f["albedo/value"][()]
    s = f["albedo/stderr"][()]
    a = np.linspace(0.1, 0.9, 3)[None, :]
    assert v.shape == (5, 3), v.shape
    assert np.all(np.abs(v - a) < 5 * s), (v, s)
    b = f["brdf_normal/value"][()]
    # stored as float32 (the default stored type): within half an ulp
    assert np.allclose(b, a / np.pi, rtol=6e-8, atol=0), b
PY
echo "toy model CLI: 4 passed, 0 failed"
