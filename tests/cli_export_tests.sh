#!/usr/bin/env bash
# End-to-end tests of `brdftab export --header` and `--merl` (issue 16).
# Usage: cli_export_tests.sh BRDFTAB SOURCE_DIR [C_COMPILER]
#
# Oracles: `brdftab query` (the library's linear lookup) at random points;
# a C compiler building the generated header as strict C99; a MERL reader
# written here from the format's definition (docs/format.md), independent of
# the exporter: its own half/difference-angle conversion and bin lookup.
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
CC_BIN=${3:-}

# A closed-form isotropic BRDF over every kind of axis spacing: cos, linear,
# quadratic, explicit.  Stored as float32, so a float header holds exactly
# the values `query` interpolates.
cat >brdf.toml <<'TOML'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 90.0]
count = 10
spacing = "cos"
[[axes]]
name = "theta_o"
range = [0.0, 90.0]
count = 19
spacing = "quadratic"
[[axes]]
name = "phi_d"
range = [0.0, 180.0]
count = 13
[[axes]]
name = "alpha"
spacing = "explicit"
values = [0.3, 0.5, 0.9]
[[tables]]
quantity = "brdf"
[output]
type = "float32"
TOML
expect_exit 0 "generate the test table" -- "$BT" generate brdf.toml -o brdf.h5 -q

# ---------------------------------------------------------------- C header
# Random points, some outside the axes (clamped by both sides).
"$PY" - <<'EOF'
import random
random.seed(5)
with open("points.csv", "w") as f:
    f.write("theta_i,theta_o,phi_d,alpha\n")
    for _ in range(300):
        f.write("%.17g,%.17g,%.17g,%.17g\n" % (random.uniform(-5, 95), random.uniform(0, 90),
                                            random.uniform(0, 180), random.uniform(0.25, 0.95)))
    # nodes and end points exactly
    f.write("0,0,0,0.3\n90,90,180,0.9\n48.189685104221397,5,15,0.5\n")
EOF
"$BT" query brdf.h5 --table brdf --points points.csv -o query.csv 2>/dev/null

if [ -z "$CC_BIN" ] || ! command -v "$CC_BIN" >/dev/null 2>&1; then
  echo "SKIP: no C compiler (pass CMake's CMAKE_C_COMPILER as the third argument)"
else
  cat >probe.c <<'EOF'
/* Reads "x0,x1,x2,x3" lines, prints the header's lookup with %.17g. */
#include <stdio.h>
#include <math.h>
#include HEADER
int main(void) {
    char line[512];
    double x[4], maxabs = 0;
    size_t i;
    for (i = 0; i < lut_CELLS; ++i)
        if (fabs(lut_value(i)) > maxabs) maxabs = fabs(lut_value(i));
    printf("%.17g\n", maxabs);
    if (!fgets(line, sizeof line, stdin)) return 1; /* CSV header */
    while (fgets(line, sizeof line, stdin))
        if (sscanf(line, "%lf,%lf,%lf,%lf", &x[0], &x[1], &x[2], &x[3]) == 4)
            printf("%.17g\n", lut_eval(x));
    return 0;
}
EOF
  for type in float half uint16; do
    expect_exit 0 "export --header --type $type" -- \
      "$BT" export brdf.h5 --table brdf --header "lut_$type.h" --name lut --type "$type"
    if "$CC_BIN" -std=c99 -pedantic -Wall -Wextra -Werror \
         -O2 "-DHEADER=\"lut_$type.h\"" probe.c -o "probe_$type" -lm \
         2>cc.txt; then ok; else bad "header ($type) does not compile as C99"; cat cc.txt; fi
    "./probe_$type" <points.csv >"header_$type.txt"
    # Bounds (docs/format.md): float storage of a float32 table is exact, so
    # only arithmetic rounding remains (1e-12 relative to max|value|); half:
    # 2^-11 max|value| + 2^-25; uint16: half a quantisation step.
    if "$PY" - "$type" "lut_$type.h" <<'EOF'
import csv, sys, re
kind, header = sys.argv[1], sys.argv[2]
got = [float(v) for v in open("header_%s.txt" % kind)]
maxabs, got = got[0], got[1:]
want = [float(r["value"]) for r in csv.DictReader(open("query.csv"))]
assert len(got) == len(want) == 303, (len(got), len(want))
if kind == "float":
    bound = 1e-12 * maxabs
elif kind == "half":
    bound = 2.0**-11 * maxabs + 2.0**-25
else:
    scale = float(re.search(r"#define lut_SCALE (\S+)", open(header).read()).group(1))
    bound = 0.5 * scale * (1 + 1e-9) + 1e-12 * maxabs
err = max(abs(g - w) for g, w in zip(got, want))
print("%s: max |header - query| = %.3g, bound %.3g" % (kind, err, bound))
sys.exit(0 if err <= bound else 1)
EOF
    then ok; else bad "header ($type) differs from query beyond its bound"; fi
  done
fi
expect_exit 2 "--name must be a C identifier" -- \
  "$BT" export brdf.h5 --table brdf --header bad.h --name 9lives
expect_grep "C identifier" err.txt "the --name message says why"
[ ! -e bad.h ] && ok || bad "a refused header export left a file"
expect_exit 2 "--type is checked" -- "$BT" export brdf.h5 --table brdf --header bad.h --type double
expect_grep "float, half, uint16" err.txt "the --type message lists the choices"
expect_exit 2 "header options need --header" -- "$BT" export brdf.h5 --table brdf --merl x.binary --type half
expect_exit 2 "one output at a time" -- "$BT" export brdf.h5 --table brdf --header a.h --merl b.binary

# ---------------------------------------------------------------- MERL
expect_exit 0 "export --merl" -- "$BT" export brdf.h5 --table brdf --merl brdf.binary --slice alpha=0.6
# The reader: header, sizes, channel scales; then for random directions the
# bin a standard reader would use.  Each bin must hold the table at the bin's
# lower-edge angles (checked against `query` there, to 1e-9), and the
# truncating lookup must stay near the table at the point itself.
cat >merl_reader.py <<'EOF'
import math, struct, sys
import numpy as np

SCALE = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)  # red, green, blue

def read_merl(path):
    raw = open(path, "rb").read()
    dims = struct.unpack("<3i", raw[:12])
    n = dims[0] * dims[1] * dims[2]
    data = np.frombuffer(raw[12:], dtype="<f8")
    assert dims == (90, 90, 180), dims
    assert data.size == 3 * n, (data.size, n)
    return data.reshape(3, 90, 90, 180) * np.array(SCALE).reshape(3, 1, 1, 1)

def normalize(v):
    return v / np.linalg.norm(v)

def rotate(v, axis, angle):  # Rodrigues' rotation formula
    axis = normalize(axis)
    return (v * math.cos(angle) + np.cross(axis, v) * math.sin(angle)
            + axis * np.dot(axis, v) * (1 - math.cos(angle)))

def half_diff(wi, wo):
    h = normalize(wi + wo)
    theta_h = math.acos(max(-1.0, min(1.0, h[2])))
    phi_h = math.atan2(h[1], h[0])
    d = rotate(rotate(wi, np.array([0.0, 0, 1]), -phi_h), np.array([0.0, 1, 0]), -theta_h)
    return theta_h, math.acos(max(-1.0, min(1.0, d[2]))), math.atan2(d[1], d[0])

def bin_of(theta_h, theta_d, phi_d):
    ih = min(89, max(0, int(math.sqrt(max(0.0, theta_h / (math.pi / 2))) * 90)))
    id_ = min(89, max(0, int(theta_d / (math.pi / 2) * 90)))
    if phi_d < 0:
        phi_d += math.pi
    ip = min(179, max(0, int(phi_d / math.pi * 180)))
    return ih, id_, ip

def bin_edge_directions(ih, id_, ip):
    theta_h = (ih / 90.0) ** 2 * (math.pi / 2)
    theta_d = id_ / 90.0 * (math.pi / 2)
    phi_d = ip / 180.0 * math.pi
    d = np.array([math.sin(theta_d) * math.cos(phi_d), math.sin(theta_d) * math.sin(phi_d),
                  math.cos(theta_d)])
    wi = rotate(d, np.array([0.0, 1, 0]), theta_h)
    h = np.array([math.sin(theta_h), 0, math.cos(theta_h)])
    wo = 2 * np.dot(wi, h) * h - wi
    return wi, wo

def angles(wi, wo):
    ti = math.degrees(math.acos(max(-1.0, min(1.0, wi[2]))))
    to = math.degrees(math.acos(max(-1.0, min(1.0, wo[2]))))
    pd = math.degrees(math.atan2(wo[1], wo[0]) - math.atan2(wi[1], wi[0]))
    pd = abs((pd + 180) % 360 - 180)
    return ti, to, pd

def direction(theta, phi):
    t, p = math.radians(theta), math.radians(phi)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
EOF
cat >merl_points.py <<'EOF'
# Writes edge.csv (bin lower-edge angles) and point.csv (the random points)
# plus merl.txt (the MERL lookup, per channel) for `query` to compare with.
import random, sys
from merl_reader import *
brdf = read_merl(sys.argv[1])
extra = sys.argv[2] if len(sys.argv) > 2 else ""
random.seed(11)
edge, point, merl = [], [], []
while len(point) < 60:
    ti, to = random.uniform(2, 75), random.uniform(2, 75)
    pi_, po = random.uniform(-180, 180), random.uniform(-180, 180)
    wi, wo = direction(ti, pi_), direction(to, po)
    ih, id_, ip = bin_of(*half_diff(wi, wo))
    ewi, ewo = bin_edge_directions(ih, id_, ip)
    if ewi[2] <= 1e-6 or ewo[2] <= 1e-6:
        continue  # the bin's edge lies below the horizon: stored as 0
    edge.append(angles(ewi, ewo))
    point.append(angles(wi, wo))
    merl.append([brdf[c, ih, id_, ip] for c in range(3)])
for name, rows in (("edge.csv", edge), ("point.csv", point)):
    with open(name, "w") as f:
        f.write("theta_i,theta_o,phi_d\n")
        for r in rows:
            f.write("%.17g,%.17g,%.17g\n" % r)
with open("merl.txt", "w") as f:
    for m in merl:
        f.write("%.17g %.17g %.17g\n" % tuple(m))
EOF
cat >merl_compare.py <<'EOF'
# merl_compare.py CHANNEL_QUERY_CSVS...: edge values exact, points near.
import csv, sys
merl = [list(map(float, l.split())) for l in open("merl.txt")]
ok = True
for c, (edge_csv, point_csv) in enumerate(zip(sys.argv[1::2], sys.argv[2::2])):
    e = [float(r["value"]) for r in csv.DictReader(open(edge_csv))]
    p = [float(r["value"]) for r in csv.DictReader(open(point_csv))]
    err_edge = max(abs(m[c] - v) / max(abs(v), 1e-300) for m, v in zip(merl, e))
    # Resampling error: the bin's value stands for the whole bin (bins are
    # at most 2 deg wide); 25 % of the value plus 0.01/sr covers this GGX
    # lobe's variation across one bin.
    err_point = max(abs(m[c] - v) - (0.25 * abs(v) + 0.01) for m, v in zip(merl, p))
    print("channel %d: max rel |merl - query| at bin edges %.3g; points within bound: %s"
          % (c, err_edge, err_point <= 0))
    ok = ok and err_edge <= 1e-9 and err_point <= 0
sys.exit(0 if ok else 1)
EOF
if "$PY" merl_points.py brdf.binary; then ok; else bad "the MERL file cannot be read back"; fi
"$BT" query brdf.h5 --table brdf --points edge.csv alpha=0.6 -o q_edge.csv 2>/dev/null
"$BT" query brdf.h5 --table brdf --points point.csv alpha=0.6 -o q_point.csv 2>/dev/null
if "$PY" merl_compare.py q_edge.csv q_point.csv q_edge.csv q_point.csv q_edge.csv q_point.csv; then
  ok; else bad "MERL values differ from query"; fi

# A factored table (Oren-Nayar per unit rho and rho^2) with --rgb: each
# channel is the table at its own rho.
sed -e 's/count = 5/count = 7/' -e 's/range = \[0.0, 80.0\]/range = [0.0, 90.0]/' \
  "$DATA/oren_nayar_recombined.toml" >on.toml
expect_exit 0 "generate the factored table" -- "$BT" generate on.toml -o on.h5 -q
expect_exit 0 "export --merl --rgb" -- "$BT" export on.h5 --table brdf --merl on.binary --rgb 0.8,0.5,0.2
if "$PY" merl_points.py on.binary; then ok; else bad "the RGB MERL file cannot be read back"; fi
for rho in 0.8 0.5 0.2; do
  "$BT" query on.h5 --table brdf --points edge.csv rho=$rho -o "e_$rho.csv" 2>/dev/null
  "$BT" query on.h5 --table brdf --points point.csv rho=$rho -o "p_$rho.csv" 2>/dev/null
done
if "$PY" merl_compare.py e_0.8.csv p_0.8.csv e_0.5.csv p_0.5.csv e_0.2.csv p_0.2.csv; then
  ok; else bad "RGB MERL channels differ from query at their rho"; fi

# Refusals: exit 2, a message naming the problem, no output file.
expect_exit 2 "--rgb on a table without a recombination parameter" -- \
  "$BT" export brdf.h5 --table brdf --merl x.binary --slice alpha=0.5 --rgb 1,1,1
expect_grep "factored" err.txt "the --rgb message says what is needed"
cat >albedo.toml <<'TOML'
model = "rough-dielectric"
[parameters]
eta = 1.5
alpha = 0.5
[[axes]]
name = "theta_i"
range = [0.0, 90.0]
count = 3
[[tables]]
quantity = "albedo_r"
[integration]
samples = 16
TOML
# Light from inside: a BRDF, but not the reflection a MERL file holds.
cat >inside.toml <<'TOML'
model = "rough-dielectric"
[parameters]
eta = 1.5
alpha = 0.5
[[axes]]
name = "theta_i"
range = [100.0, 180.0]
count = 3
[[axes]]
name = "theta_o"
range = [100.0, 180.0]
count = 3
[[tables]]
quantity = "brdf"
TOML
expect_exit 0 "generate refusal tables" -- "$BT" generate albedo.toml -o albedo.h5 -q
expect_exit 0 "generate refusal tables" -- "$BT" generate inside.toml -o inside.h5 -q
expect_exit 2 "a table of light from inside is refused" -- "$BT" export inside.h5 --table brdf --merl x.binary
expect_grep "normal incidence" err.txt "the refusal says the table must start at normal incidence"
expect_exit 2 "a non-BRDF table is refused" -- "$BT" export albedo.h5 --table albedo_r --merl x.binary
expect_grep "BRDF" err.txt "the refusal names the BRDF requirement"
[ ! -e x.binary ] && ok || bad "a refused MERL export left a file"
expect_exit 2 "a missing parameter is named" -- "$BT" export brdf.h5 --table brdf --merl x.binary
expect_grep "alpha" err.txt "the missing parameter is named"

cli_summary
