#!/usr/bin/env bash
# End-to-end tests of adaptive tables (docs/adaptive.md, docs/format.md
# "Adaptive tables"): `generate --representation adaptive` through the
# engine, `query` against an independent Python reader written from
# docs/format.md (tests/python/read_adaptive.py, numpy + h5py) to 1e-12, an
# under-resolved table failing its certificate (in the file and under
# `certify`), and tensor-only consumers refusing adaptive tables by name.
# About a minute of CPU.  Usage: adaptive_cli_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
PY=/usr/bin/python3
if ! "$PY" -c "import h5py, numpy" 2>/dev/null; then
  echo "SKIP: /usr/bin/python3 lacks h5py or numpy"
  exit 77
fi

cat > inside.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
nodes = 8
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
[[axes]]
name = "eta"
range = [1.2, 2.0]
count = 2
spacing = "log"
[[tables]]
name = "albedo_t_inside"
quantity = "albedo_t"
[integration]
method = "quadrature"
[output]
type = "float32"
SPEC

# A table refined to 3e-2 passes its certificate.
"$BT" generate inside.toml --representation adaptive --accuracy 3e-2 --abs --max-values 4000 -q -o a.h5 \
  > gen.out 2> gen.err
if [ $? -eq 0 ] && [ -f a.h5 ]; then ok; else bad "adaptive generate failed: $(cat gen.err)"; fi
expect_grep "certificate max .* \(passed\)" gen.out "generate summary"
"$BT" info a.h5 > info.out 2>&1
expect_grep "adaptive: [0-9]+ values in [0-9]+ patches" info.out "info"
expect_grep "faces at t = 0.5" info.out "info: the critical node's plane"

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

# Consumers of tensor tables refuse adaptive ones, naming them; linear only.
expect_exit 2 "validate refuses" -- "$BT" validate a.h5 --table albedo_t_inside --points 10
"$BT" validate a.h5 --table albedo_t_inside --points 10 > v.out 2>&1
expect_grep "adaptive table" v.out "validate's message"
expect_exit 2 "query --cubic refused" -- "$BT" query a.h5 --table albedo_t_inside --cubic mu_i=-0.5 alpha=0.1 eta=1.5
expect_exit 2 "adaptive needs --accuracy" -- "$BT" generate inside.toml --representation adaptive -q -o x.h5
cli_summary
