#!/usr/bin/env bash
# End-to-end tests of adaptive tables (docs/adaptive.md, docs/format.md
# "Adaptive tables"): `generate --representation adaptive` through the
# engine, `query` against an independent Python reader written from
# docs/format.md (tests/python/read_adaptive.py, numpy + h5py) to 1e-12, an
# under-resolved table failing its certificate (in the file and under
# `certify`), `validate` against the engine, the exports' (and plot's)
# resampling error, and linear interpolation only.
# About a minute of CPU.  Usage: adaptive_cli_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
PY=/usr/bin/python3
if ! "$PY" -c "import h5py, numpy" 2>/dev/null; then
  echo "SKIP: /usr/bin/python3 lacks h5py or numpy"
  exit 77
fi

cp "$SRC/tests/data/adaptive_inside.toml" inside.toml

# A table refined to 3e-2 passes its certificate.
"$BT" generate inside.toml --representation adaptive --accuracy 3e-2 --abs --max-values 4000 -q -o a.h5 \
  > gen.out 2> gen.err
if [ $? -eq 0 ] && [ -f a.h5 ]; then ok; else bad "adaptive generate failed: $(cat gen.err)"; fi
expect_grep "certificate max .* \(passed\)" gen.out "generate summary"
"$BT" info a.h5 > info.out 2>&1
expect_grep "adaptive: [0-9]+ values in [0-9]+ patches" info.out "info"
expect_grep "faces at t = 0.5" info.out "info: the critical node's plane"

# The stored values are rounded to what the accuracy needs, unless
# --full-precision keeps the stored type's own rounding.
"$BT" generate inside.toml --representation adaptive --accuracy 3e-2 --abs --max-values 4000 --full-precision \
  -q -o full.h5 > /dev/null 2>&1
if "$PY" - <<'PY'
import h5py, sys
rounded = "rounding_accuracy" in h5py.File("a.h5", "r")["albedo_t_inside"].attrs
full = "rounding_accuracy" in h5py.File("full.h5", "r")["albedo_t_inside"].attrs
sys.exit(0 if rounded and not full else 1)
PY
then ok; else bad "--full-precision did not keep unrounded adaptive values"; fi

# query at random points (some outside the ranges: clamped) against the Python reader.
"$PY" - <<'PY'
import random
random.seed(3)
with open("pts.csv", "w") as f:
    f.write("mu_i,alpha,eta\n")
    for _ in range(2000):
        f.write(f"{random.uniform(-1.02, -0.01)!r},{10 ** random.uniform(-1.4, 0.02)!r},{random.uniform(1.19, 2.01)!r}\n")
PY
"$BT" query a.h5 --table albedo_t_inside --points pts.csv -o q.csv 2> /dev/null
"$PY" "$SRC/tests/python/read_adaptive.py" a.h5 albedo_t_inside pts.csv > py.csv
if "$PY" - <<'PY'
import csv, sys
a = list(csv.reader(open("q.csv")))[1:]
b = list(csv.reader(open("py.csv")))[1:]
assert len(a) == len(b) == 2000, (len(a), len(b))
worst = max(abs(float(x[-1]) - float(y[-1])) for x, y in zip(a, b))
print("query vs independent reader: max difference", worst)
sys.exit(0 if worst <= 1e-12 else 1)
PY
then ok; else bad "query and tests/python/read_adaptive.py differ"; fi

# Order 2 (piecewise-quadratic patches): the attribute is stored, and query
# agrees with the independent reader to 1e-12 as well.
"$BT" generate inside.toml --representation adaptive --accuracy 3e-2 --abs --max-values 4000 --patch-order 2 \
  -q -o a2.h5 > gen2.out 2> gen2.err
if [ $? -eq 0 ] && [ -f a2.h5 ]; then ok; else bad "adaptive generate --patch-order 2 failed: $(cat gen2.err)"; fi
"$BT" info a2.h5 > info2.out 2>&1
expect_grep "piecewise quadratic" info2.out "info: order 2"
expect_exit 2 "export --header of an order-2 table refused (its traversal is multilinear)" -- \
  "$BT" export a2.h5 --table albedo_t_inside --header a2.h
"$BT" query a2.h5 --table albedo_t_inside --points pts.csv -o q2.csv 2> /dev/null
"$PY" "$SRC/tests/python/read_adaptive.py" a2.h5 albedo_t_inside pts.csv > py2.csv
if "$PY" - <<'PY'
import csv, sys
import h5py
assert int(h5py.File("a2.h5")["albedo_t_inside"].attrs["patch_order"]) == 2
a = list(csv.reader(open("q2.csv")))[1:]
b = list(csv.reader(open("py2.csv")))[1:]
l1 = list(csv.reader(open("q.csv")))[1:]
assert len(a) == len(b) == 2000, (len(a), len(b))
worst = max(abs(float(x[-1]) - float(y[-1])) for x, y in zip(a, b))
print("order 2: query vs independent reader: max difference", worst)
# The two orders are different tables (the check above compares something).
assert max(abs(float(x[-1]) - float(y[-1])) for x, y in zip(a, l1)) > 1e-6
sys.exit(0 if worst <= 1e-12 else 1)
PY
then ok; else bad "order 2: query and tests/python/read_adaptive.py differ"; fi

# Determinism: the same spec and settings give bit-identical datasets.
"$BT" generate inside.toml --representation adaptive --accuracy 3e-2 --abs --max-values 4000 -q -o b.h5 \
  > /dev/null 2>&1
if "$PY" - <<'PY'
import h5py, numpy as np, sys
a, b = h5py.File("a.h5")["albedo_t_inside"], h5py.File("b.h5")["albedo_t_inside"]
names = ["value", "tree_axis", "tree_split", "tree_child", "leaf_box", "leaf_nodes"]
sys.exit(0 if all(np.array_equal(a[n][...], b[n][...]) for n in names) else 1)
PY
then ok; else bad "two runs of the same spec differ"; fi

# An under-resolved table (too few values for its target) fails its certificate:
# exit 1, the file written with certificate_passed = 0, and `certify` fails too.
expect_exit 1 "under-resolved generate" -- "$BT" generate inside.toml --representation adaptive --accuracy 1e-4 --abs --max-values 200 -q -o u.h5
if "$PY" -c "import h5py,sys; sys.exit(0 if h5py.File('u.h5')['albedo_t_inside'].attrs['certificate_passed'] == 0 else 1)"; then
  ok
else
  bad "under-resolved table: certificate_passed is not 0"
fi
expect_exit 1 "certify of the under-resolved table" -- "$BT" certify u.h5 --table albedo_t_inside --accuracy 1e-4 --abs -q
expect_exit 0 "certify of the resolved table" -- "$BT" certify a.h5 --table albedo_t_inside --accuracy 3e-2 --abs -q

# validate: the table against fresh engine evaluations at random points
# (linear only): its error stays within the refinement's target, and the
# table values it reports are what `query` gives at those points.
expect_exit 0 "validate of an adaptive table" -- "$BT" validate a.h5 --table albedo_t_inside --points 300 --worst 20 --json -q
"$BT" validate a.h5 --table albedo_t_inside --points 300 --worst 20 --json -q > v.json 2> /dev/null
if "$PY" - "$BT" <<'PY'
import json, subprocess, sys
v = json.load(open("v.json"))
assert v["representation"] == "adaptive" and "cubic" not in v, sorted(v)
assert v["linear"]["abs"]["max"] <= 3e-2, v["linear"]["abs"]
for w in v["linear"]["worst"]:
    args = [f"{k}={x!r}" for k, x in w["coordinates"].items()]
    q = json.loads(subprocess.run([sys.argv[1], "query", "a.h5", "--table", "albedo_t_inside", "--json", *args],
                                  capture_output=True, text=True, check=True).stdout)
    assert abs(q["value"] - w["table"]) <= 1e-12, (w, q["value"])
print("validate: max abs", v["linear"]["abs"]["max"])
PY
then ok; else bad "validate of the adaptive table"; fi
# export --exr / --png / --merl resample onto a tensor grid and state the
# resampling error.  Oracle: a 2-D table (continuous up to the rounding of
# its stored values, docs/adaptive.md) is piecewise bilinear on its leaves'
# dyadic sub-cells, so a tensor grid that refines every sub-cell in the same
# warped coordinate reproduces it up to the cracks that rounding leaves at
# hanging nodes (<= 2 x rounding_bound); a coarse grid misses it visibly.
cat > two.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
nodes = 8
eta = 1.5
[[axes]]
name = "mu_i"
range = [-1.0, -0.02]
count = 33
spacing = "critical"
[[axes]]
name = "alpha"
range = [0.05, 1.0]
count = 2
spacing = "log"
[[tables]]
name = "albedo_t_inside"
quantity = "albedo_t"
[integration]
method = "quadrature"
SPEC
"$BT" generate two.toml --representation adaptive --accuracy 1e-2 --abs --max-values 4000 -q -o two.h5 > /dev/null 2> two.err
if [ -f two.h5 ]; then ok; else bad "2-D adaptive generate failed: $(cat two.err)"; fi
read -r fine_mu fine_alpha bound < <("$PY" - <<'PY'
import h5py, numpy as np
g = h5py.File("two.h5")["albedo_t_inside"]
n = int(g.attrs["patch_nodes"])
b = g["leaf_box"][...].reshape(-1, 2, 2)
w = (b[:, :, 1] - b[:, :, 0]).min(axis=0)
# Patches of a higher order than multilinear (an attribute naming their
# order or interpolation) are not reproduced exactly: no bound then.
higher = any(("order" in k or "interpolation" in k) and not k.startswith("certificate")
             and str(g.attrs[k]).strip("b'") not in ("1", "linear") for k in g.attrs)
bound = float("inf") if higher else float(g.attrs.get("rounding_bound", 0.0))
print(*[int(round(1 / x)) * (n - 1) + 1 for x in w], bound)
PY
)
resample_error() { sed -n 's/^resampling error: max abs \([^ ]*\) .*/\1/p' "$1"; }
expect_exit 0 "export --exr, fine grid" -- "$BT" export two.h5 --table albedo_t_inside --exr fine.exr \
  --resample mu_i="$fine_mu" --resample alpha="$fine_alpha"
"$BT" export two.h5 --table albedo_t_inside --exr fine.exr --resample mu_i="$fine_mu" --resample alpha="$fine_alpha" > fine.out 2>&1
"$BT" export two.h5 --table albedo_t_inside --exr coarse.exr --resample 5 > coarse.out 2>&1
if "$PY" -c "import sys; f, c, b = map(float, sys.argv[1:]); print('resampling error: fine', f, 'coarse', c, 'bound', 2 * b); sys.exit(0 if f <= 2 * b + 1e-12 and c > 5 * f else 1)" \
    "$(resample_error fine.out)" "$(resample_error coarse.out)" "$bound"; then ok
else bad "resampling error: fine $(resample_error fine.out), coarse $(resample_error coarse.out), rounding bound $bound"; fi
expect_exit 0 "export --png of an adaptive table" -- "$BT" export a.h5 --table albedo_t_inside --png a.png --slice eta=1.5
"$BT" generate two.toml -q -o tensor.h5 > /dev/null 2>&1
expect_exit 2 "--resample of a tensor table refused" -- "$BT" export tensor.h5 --table albedo_t_inside --exr t.exr --resample 9
cat > on.toml <<'SPEC'
model = "oren-nayar"
[parameters]
nodes = 6
sigma = 20.0
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 7
[[axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 7
[[axes]]
name = "phi_d"
range = [0.0, 180.0]
count = 7
[[tables]]
quantity = "brdf_direct"
SPEC
"$BT" generate on.toml --representation adaptive --accuracy 1e-2 --abs --max-values 4000 -q -o on.h5 > /dev/null 2>&1
"$BT" export on.h5 --table brdf_direct --merl on.binary --resample 33 > merl.out 2>&1
if [ "$(stat -c %s on.binary 2>/dev/null)" = "$((12 + 3 * 8 * 90 * 90 * 180))" ] && grep -q "^resampling error: max abs" merl.out; then ok
else bad "export --merl of an adaptive table: $(cat merl.out)"; fi
# plot draws an adaptive table through the resampled grid and says so.
"$BT" plot a.h5 --table albedo_t_inside --slice eta=1.5 --curves alpha -o plot.png > plot.out 2>&1
if [ -s plot.png ] && grep -q "drawn through a tensor grid .* resampling error max abs" plot.out; then ok
else bad "plot of an adaptive table: $(cat plot.out)"; fi
expect_exit 2 "plot --cubic refused" -- "$BT" plot a.h5 --table albedo_t_inside --slice eta=1.5 --cubic -o plot2.png
expect_exit 2 "query --cubic refused" -- "$BT" query a.h5 --table albedo_t_inside --cubic mu_i=-0.5 alpha=0.1 eta=1.5
expect_exit 2 "adaptive needs --accuracy" -- "$BT" generate inside.toml --representation adaptive -q -o x.h5
expect_exit 2 "export --rgl of an adaptive table refused" -- "$BT" export a.h5 --table albedo_t_inside --rgl a.bsdf
cli_summary
