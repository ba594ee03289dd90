#!/usr/bin/env bash
# End-to-end test of `brdftab export --header --layout cycles|filament|ue4`.
# Usage: renderer_luts_cli.sh BRDFTAB SOURCE_DIR [C_COMPILER]
#
# A small table set in the renderers' axis orders (Cycles: (eta, mu, alpha);
# the textures: (alpha, mu_i)) is generated and exported, the headers are
# compiled as strict C99 and their arrays printed, and every element is
# checked against `brdftab query` at the node it belongs to, in the order the
# layout defines (Cycles: index z nx ny + y nx + x; textures: R, G per texel,
# NoV fastest): exactly for float (the tables are float64, the header rounds
# once to float: 2^-24 relative), to half rounding (2^-11 relative, 2^-25
# absolute below 2^-14) for half, and for UE4's 16-bit unorm within half a
# quantum (0.5/65535) of the value clamped to [0, 1].
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
CC_BIN=${3:-}

cat >luts.toml <<'TOML'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
shadowing = "height-correlated"
nodes = 8
eta = 1.5
[[tables]]
name = "E"
quantity = "albedo_r"
[tables.parameters]
fresnel = "none"
[[tables.axes]]
name = "mu_i"
spacing = "explicit"
values = [0.0001, 0.5, 1.0]
[[tables.axes]]
name = "alpha"
spacing = "explicit"
values = [1e-8, 0.25, 1.0]
[[tables]]
name = "glass"
quantity = "albedo"
[[tables.axes]]
name = "eta"
spacing = "explicit"
values = [1.2, 1.5]
[[tables.axes]]
name = "mu_i"
spacing = "explicit"
values = [0.2, 0.6, 1.0]
[[tables.axes]]
name = "alpha"
spacing = "explicit"
values = [0.01, 0.3, 0.6, 1.0]
[[tables]]
name = "Ag"
quantity = "split_a"
[[tables.axes]]
name = "alpha"
spacing = "explicit"
values = [0.001, 0.01]
[[tables.axes]]
name = "mu_i"
spacing = "explicit"
values = [0.01, 0.5]
[[tables]]
name = "Sg"
quantity = "sheen_albedo"
[[tables.axes]]
name = "alpha"
spacing = "explicit"
values = [0.001, 0.01]
[[tables.axes]]
name = "mu_i"
spacing = "explicit"
values = [0.01, 0.5]
[[tables]]
name = "B"
quantity = "split_b"
[[tables]]
name = "A"
quantity = "split_a"
[[tables]]
name = "E2"
quantity = "albedo_r"
[tables.parameters]
fresnel = "none"
[[tables]]
name = "S"
quantity = "sheen_albedo"
[[axes]]
name = "alpha"
range = [0.01, 1.0]
count = 3
[[axes]]
name = "mu_i"
range = [0.1, 1.0]
count = 4
[output]
type = "float64"
TOML
expect_exit 0 "generate the test tables" -- "$BT" generate luts.toml -o luts.h5 -q

# Node coordinates in row-major order (last axis fastest), queried.
query_nodes() {  # TABLE NAME=v1,v2,... (outermost first)
  local table=$1
  shift
  "$PY" - "$@" >"nodes_$table.csv" <<'EOF'
import itertools, sys
axes = [a.split("=") for a in sys.argv[1:]]
print(",".join(n for n, _ in axes))
for combo in itertools.product(*[v.split(",") for _, v in axes]):
    print(",".join(combo))
EOF
  "$BT" query luts.h5 --table "$table" --points "nodes_$table.csv" -o "q_$table.csv" 2>/dev/null
}
query_nodes E mu_i=0.0001,0.5,1.0 alpha=1e-8,0.25,1.0
query_nodes glass eta=1.2,1.5 mu_i=0.2,0.6,1.0 alpha=0.01,0.3,0.6,1.0
for t in A B E2 S; do query_nodes "$t" alpha=0.01,0.505,1.0 mu_i=0.1,0.4,0.7,1.0; done
for t in Ag Sg; do query_nodes "$t" alpha=0.001,0.01 mu_i=0.01,0.5; done

expect_exit 0 "export --layout cycles (3-D)" -- \
  "$BT" export luts.h5 --table glass --header glass.h --layout cycles
expect_grep "static const float table_glass\[24\]" glass.h "Cycles' declaration: float, 2 x 3 x 4"
expect_exit 0 "export --layout cycles (2-D), --name" -- \
  "$BT" export luts.h5 --table E --header e.h --layout cycles --name table_ggx_E
expect_grep "static const float table_ggx_E\[9\]" e.h "--name sets the array name"
expect_exit 0 "export --layout filament (half)" -- \
  "$BT" export luts.h5 --table B,E2 --header dfg.h --layout filament
expect_grep "const uint16_t DFG_LUT\[\]" dfg.h "Filament's declaration: binary16 bits"
expect_exit 0 "export --layout filament with the cloth channel (R, G, B)" -- \
  "$BT" export luts.h5 --table B,E2,S --header dfg3.h --layout filament
expect_grep "3 channels" dfg3.h "the header says three channels"
expect_exit 2 "ue4 takes two channels" -- \
  "$BT" export luts.h5 --table A,B,S --header bad.h --layout ue4
# The certificate in Cycles' interpolation, stored in a copy of the file.
cp luts.h5 cert.h5
expect_exit 0 "certify --layout cycles --store" -- \
  "$BT" certify cert.h5 --table E,glass --layout cycles --store -q
expect_grep "table glass in cycles's interpolation: max" out.txt "one line per table"
expect_grep "trilinear in .z, mu, r., node k of n at k/.n-1." out.txt "the interpolation named"
h5dump -a /glass/layout_certificate_cycles_max_error cert.h5 >attr.txt 2>&1 && ok || bad "the certificate is stored"
expect_exit 2 "certify --layout ue4: a 3-D table is not a texture" -- \
  "$BT" certify cert.h5 --table glass --layout ue4 -q
expect_exit 2 "certify needs --accuracy or --layout" -- "$BT" certify cert.h5 --table E -q
expect_exit 0 "export --layout ue4 (UE4's 16-bit unorm, the default)" -- \
  "$BT" export luts.h5 --table A,B --header ue4.h --layout ue4
expect_grep "static const uint16_t ue4_split_sum_lut\[24\]" ue4.h "UE4's type: two uint16 per texel"
expect_grep "0 elements outside \[0, 1\] clamped" ue4.h "A and B lie in [0, 1]"
expect_exit 0 "export --layout ue4 --type float" -- \
  "$BT" export luts.h5 --table A,B --header ue4f.h --layout ue4 --type float
expect_grep "static const float ue4_split_sum_lut\[24\]" ue4f.h "--type float"
# The sheen albedo exceeds 1 near grazing at small alpha: unorm clamps it (and
# the header says how often).
expect_exit 0 "export --layout ue4, a channel beyond [0, 1]" -- \
  "$BT" export luts.h5 --table Ag,Sg --header ue4s.h --layout ue4
expect_grep " [1-9] elements outside \[0, 1\] clamped" ue4s.h "the header counts the clamped elements"
expect_exit 2 "filament does not store 16-bit unorm" -- \
  "$BT" export luts.h5 --table B,E2 --header bad.h --layout filament --type uint16
# Refusals: wrong axis order, channels on different grids, half for Cycles.
expect_exit 2 "cycles needs alpha fastest" -- \
  "$BT" export luts.h5 --table B --header bad.h --layout cycles
expect_grep "alpha" err.txt "the message names the axis order"
expect_exit 2 "channels must share one grid" -- \
  "$BT" export luts.h5 --table B,E --header bad.h --layout filament
expect_exit 2 "cycles stores float only" -- \
  "$BT" export luts.h5 --table E --header bad.h --layout cycles --type half
expect_exit 2 "unknown layout" -- "$BT" export luts.h5 --table E --header bad.h --layout unity
expect_grep "cycles, filament, ue4" err.txt "the --layout message lists the choices"
[ ! -e bad.h ] && ok || bad "a refused export left a file"
# The two-channel texture as OpenEXR (pixels checked in tests/test_exr_export.cpp).
expect_exit 0 "export --exr R,G" -- "$BT" export luts.h5 --table B,E2 --exr dfg.exr --half
[ -s dfg.exr ] && ok || bad "dfg.exr written"
expect_exit 2 "EXR channels must share one grid" -- "$BT" export luts.h5 --table B,E --exr bad.exr
[ ! -e bad.exr ] && ok || bad "a refused EXR export left a file"

if [ -z "$CC_BIN" ] || ! command -v "$CC_BIN" >/dev/null 2>&1; then
  echo "SKIP: no C compiler (pass CMake's CMAKE_C_COMPILER as the third argument)"
else
  # Print each array in its own order (half decoded here, from the format).
  for h in glass:table_glass:float e:table_ggx_E:float dfg:DFG_LUT:half dfg3:DFG_LUT:half \
           ue4:ue4_split_sum_lut:unorm ue4f:ue4_split_sum_lut:float ue4s:ue4_split_sum_lut:unorm; do
    IFS=: read -r file name kind <<<"$h"
    cat >"p_$file.c" <<EOF
#include <stdio.h>
#include <stdint.h>
#include <math.h>
#include "$file.h"
static double decode(double v) { return v; }
static double decode_half(uint16_t h) {
    int e = (h >> 10) & 31, m = h & 1023;
    double v = e == 0 ? ldexp(m, -24) : ldexp(m + 1024, e - 25);
    return (h & 0x8000) ? -v : v;
}
int main(void) {
    size_t i;
    for (i = 0; i < sizeof $name / sizeof $name[0]; ++i)
        printf("%.17g\n", $(case $kind in half) echo "decode_half($name[i])" ;;
                                unorm) echo "$name[i] / 65535.0" ;; *) echo "decode($name[i])" ;; esac));
    return 0;
}
EOF
    if "$CC_BIN" -std=c99 -pedantic -Wall -Wextra -Werror -Wno-unused-function "p_$file.c" \
         -o "p_$file" -lm 2>cc.txt; then ok; else bad "$file.h does not compile as C99"; cat cc.txt; fi
    "./p_$file" >"v_$file.txt"
  done
  if "$PY" - <<'EOF'
import csv, sys
def q(t):
    return [float(r["value"]) for r in csv.DictReader(open("q_%s.csv" % t))]
def got(f):
    return [float(v) for v in open("v_%s.txt" % f)]
fails = 0
def check(label, g, w, rel, absolute=0.0):
    # |header - query| <= rel |query| + absolute (half: 2^-25 below 2^-14)
    global fails
    if len(g) != len(w):
        print("%s: %d elements, expected %d" % (label, len(g), len(w))); fails += 1; return
    err = max(abs(a - b) / (rel * abs(b) + absolute) for a, b in zip(g, w))
    print("%s: %d elements, max |header - query| / bound = %.3g" % (label, len(g), err))
    fails += err > 1
check("cycles glass", got("glass"), q("glass"), 2.0**-24)
check("cycles E", got("e"), q("E"), 2.0**-24)
inter = lambda r, g: [v for pair in zip(r, g) for v in pair]
check("filament (B, E)", got("dfg"), inter(q("B"), q("E2")), 2.0**-11, 2.0**-25)
# 16-bit unorm: within half a quantum of the value clamped to [0, 1]
clamp = lambda v: [min(max(x, 0.0), 1.0) for x in v]
check("ue4 (A, B) unorm", got("ue4"), clamp(inter(q("A"), q("B"))), 0.0, 0.5 / 65535 + 1e-12)
check("ue4 (A, S) unorm, clamped", got("ue4s"), clamp(inter(q("Ag"), q("Sg"))), 0.0, 0.5 / 65535 + 1e-12)
check("ue4 (A, B) float", got("ue4f"), inter(q("A"), q("B")), 2.0**-24)
inter3 = lambda r, g, b: [v for t in zip(r, g, b) for v in t]
check("filament (B, E, S)", got("dfg3"), inter3(q("B"), q("E2"), q("S")), 2.0**-11, 2.0**-25)
sys.exit(1 if fails else 0)
EOF
  then ok; else bad "a layout's elements differ from query at their nodes"; fi
fi
cli_summary
