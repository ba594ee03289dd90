#!/usr/bin/env bash
# End-to-end tests of `brdftab query`, `validate` and `plot` (issue 7).
# Oracles: `brdftab eval` (direct evaluation of the closed form on the device)
# at table nodes and node midpoints, the PNG format itself, and the
# expectation that a refined grid interpolates better.
# Usage: cli_table_tests.sh BRDFTAB SOURCE_DIR
set -u
# The script may be run from anywhere, with relative paths.
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=cli_lib.sh
source "$HERE/cli_lib.sh"
cli_setup "$1" "$2"

json_field() {  # json_field FILE KEY -> prints the number
  "$PY" -c 'import json,sys; print(repr(float(json.load(open(sys.argv[1]))[sys.argv[2]])))' "$1" "$2"
}
# The closed-form GGX rough dielectric BRDF of the fixture, its nodes set to
# $2 per axis; $1 = name.
make_spec() {
  sed -e "s/^count = .*/count = $2/" -e "s/^path = .*/path = \"$1.h5\"/" \
    "$DATA/rough_dielectric_brdf.toml" >"$1.toml"
}
make_spec coarse 5   # nodes 0,20,40,60,80 deg and 0,45,90,135,180 deg
make_spec fine 17    # refines every coarse cell 4x per axis
expect_exit 0 "generate coarse" -- "$BT" generate coarse.toml -q
expect_exit 0 "generate fine" -- "$BT" generate fine.toml -q
EVAL=("$BT" eval rough-dielectric brdf alpha=0.5 eta=1.5 distribution=ggx --json)

# --- query at a node equals the direct evaluation (to float32 storage) --------
expect_exit 0 "eval at node" -- "${EVAL[@]}" theta_i=40 theta_o=60 phi_d=135
cp out.txt eval_node.json
for interp in "" "--cubic"; do
  expect_exit 0 "query at node $interp" -- "$BT" query coarse.h5 --table brdf theta_i=40 theta_o=60 \
    phi_d=135 --json $interp
  "$PY" - eval_node.json out.txt <<'EOF' && ok || bad "query $interp at a node != eval (float32)"
import json, sys
e = json.load(open(sys.argv[1]))["value"]; q = json.load(open(sys.argv[2]))["value"]
# float32 storage: relative rounding <= 2^-24; allow 2 ulp.
sys.exit(0 if abs(q - e) <= 2 * 2**-24 * abs(e) and e > 0 else 1)
EOF
done
expect_exit 0 "query text output" -- "$BT" query coarse.h5 --table brdf theta_i=40 theta_o=60 phi_d=135
expect_grep "^brdf = [0-9.e-]+ \[1/sr\] \(linear\)" out.txt "text output names value and units"

# --- between nodes: monotone slice along phi_d (theta_i=40, theta_o=60) ------
# The forward lobe makes f increase from phi_d = 90 to 135 (checked below on
# the direct evaluations).  Linear interpolation at the midpoint of a linear
# axis is the mean of the two node values; it must lie between them.
expect_exit 0 "eval phi_d=90" -- "${EVAL[@]}" theta_i=40 theta_o=60 phi_d=90
cp out.txt eval_90.json
expect_exit 0 "query midpoint" -- "$BT" query coarse.h5 --table brdf theta_i=40 theta_o=60 \
  phi_d=112.5 --json
cp out.txt q_mid.json
expect_exit 0 "eval midpoint" -- "${EVAL[@]}" theta_i=40 theta_o=60 phi_d=112.5
cp out.txt eval_mid.json
"$PY" - eval_90.json eval_node.json q_mid.json eval_mid.json <<'EOF' && ok || bad "midpoint query"
import json, sys
f0, f1, q, fm = (json.load(open(p))["value"] for p in sys.argv[1:5])
assert f0 < fm < f1, (f0, fm, f1)             # the slice is monotone here
assert f0 < q < f1, (f0, q, f1)               # interpolant between neighbours
assert abs(q - 0.5 * (f0 + f1)) <= 1e-6 * f1  # linear: the mean of the nodes
EOF

# --- query --points: CSV in, CSV out (atomic), same values -------------------
printf 'theta_o,phi_d\n60,135\n60,112.5\n0,0\n' >pts.csv
expect_exit 0 "query --points" -- "$BT" query coarse.h5 --table brdf theta_i=40 --points pts.csv -o res.csv
[ "$(wc -l <res.csv)" -eq 4 ] && ok || bad "points CSV has header + 3 rows"
expect_grep "^theta_o,phi_d,value$" res.csv "points CSV header"
"$PY" - res.csv eval_node.json q_mid.json <<'EOF' && ok || bad "points CSV values"
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
e = json.load(open(sys.argv[2]))["value"]; m = json.load(open(sys.argv[3]))["value"]
assert abs(float(rows[0]["value"]) - e) <= 2 * 2**-24 * e
assert float(rows[1]["value"]) == m
EOF

# --- validate: finite report; refining the grid reduces the error -------------
expect_exit 0 "validate text" -- "$BT" validate coarse.h5 --table brdf --points 300 --seed 5
expect_grep "linear +rel" out.txt "report has linear relative errors"
expect_grep "cubic +abs" out.txt "report has cubic absolute errors"
expect_grep "worst 5 \(linear" out.txt "report lists the worst points"
for g in coarse fine; do
  expect_exit 0 "validate $g --json" -- "$BT" validate $g.h5 --table brdf --points 300 --seed 5 --json
  cp out.txt val_$g.json
done
"$PY" - val_coarse.json val_fine.json <<'EOF' && ok || bad "validate report / refinement"
import json, math, sys
c, f = (json.load(open(p)) for p in sys.argv[1:3])
for r in (c, f):
    assert r["points"] == 300 and r["reference"]["method"] == "closed-form"
    for m in ("linear", "cubic"):
        for k in ("abs", "rel"):
            s = r[m][k]
            assert all(math.isfinite(s[q]) and s[q] >= 0 for q in ("max", "rms", "p50", "p95", "p99"))
            assert s["p50"] <= s["p95"] <= s["p99"] <= s["max"]
        assert len(r[m]["worst"]) == 5
        w = r[m]["worst"][0]
        assert set(w["coordinates"]) == {"theta_i", "theta_o", "phi_d"}
        assert abs(w["rel"]) == r[m]["rel"]["max"]
# Same points (same seed) on a 4x finer grid: errors must drop.  Linear
# interpolation error ~ h^2 would drop 16x; ask for 3x to stay robust.
for m in ("linear", "cubic"):
    for q in ("rms", "p95"):
        assert f[m]["rel"][q] * 3 < c[m]["rel"][q], (m, q, f[m]["rel"][q], c[m]["rel"][q])
EOF
expect_exit 0 "validate same seed twice" -- "$BT" validate coarse.h5 --table brdf --points 300 --seed 5 --json
"$PY" - out.txt val_coarse.json <<'EOF' && ok || bad "validate is deterministic for a seed"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert a["linear"] == b["linear"] and a["cubic"] == b["cubic"]
EOF

# Integral table: the reference's own noise is reported.
cp "$DATA/rough_dielectric_albedo.toml" albedo.toml
expect_exit 0 "generate albedo" -- "$BT" generate albedo.toml --method mc --samples 2048 --seed 3 -q
expect_exit 0 "query integral table" -- "$BT" query albedo.h5 --table albedo_r theta_i=30 alpha=0.5 --json
"$PY" -c 'import json,sys; d=json.load(open("out.txt")); sys.exit(0 if d["stderr"] > 0 else 1)' \
  && ok || bad "query of an integral table reports an interpolated stderr"
expect_exit 0 "validate integral table" -- "$BT" validate albedo.h5 --table albedo_r --points 40 --json -q
"$PY" - out.txt <<'EOF' && ok || bad "validate reports reference noise"
import json, math, sys
r = json.load(open(sys.argv[1]))
assert r["reference"]["method"] == "mc" and r["reference"]["stderr"]["max"] > 0
for m in ("linear", "cubic"):
    assert 0 <= r[m]["significant_fraction"] <= 1
    assert math.isfinite(r[m]["rel"]["rms_noise_corrected"])
    assert r[m]["rel"]["rms_noise_corrected"] <= r[m]["rel"]["rms"]
    assert "reference_stderr" in r[m]["worst"][0]
EOF

# --- plot: valid PNGs of the documented size ---------------------------------
check_png() {  # check_png FILE WIDTH HEIGHT
  "$PY" - "$@" <<'EOF'
import struct, sys, zlib
d = open(sys.argv[1], "rb").read()
assert d[:8] == b"\x89PNG\r\n\x1a\n", "signature"
n, kind = struct.unpack(">I4s", d[8:16])
assert kind == b"IHDR" and n == 13
w, h, depth, colour = struct.unpack(">IIBB", d[16:26])
assert (w, h) == (int(sys.argv[2]), int(sys.argv[3])), (w, h)
assert depth == 8 and colour == 2
assert zlib.crc32(d[12:29]) == struct.unpack(">I", d[29:33])[0], "IHDR CRC"
assert d[-8:-4] == b"IEND"
EOF
}
expect_exit 0 "plot 1-D" -- "$BT" plot coarse.h5 --table brdf --slice theta_i=30 phi_d=180 -o p1.png
check_png p1.png 960 620 && ok || bad "1-D plot PNG"
expect_exit 0 "plot curves" -- "$BT" plot fine.h5 --table brdf --slice theta_i=30 --curves phi_d -o p2.png
check_png p2.png 960 620 && ok || bad "curves PNG"
expect_exit 0 "plot 2-D" -- "$BT" plot coarse.h5 --table brdf --slice theta_i=30 --x phi_d -o p3.png --cubic
check_png p3.png 900 660 && ok || bad "2-D PNG"
expect_exit 0 "plot 2-D log" -- "$BT" plot coarse.h5 --table brdf --slice theta_o=10 -o p4.png --log
check_png p4.png 900 660 && ok || bad "2-D log PNG"
cmp -s p3.png p4.png && bad "different slices gave identical images" || ok

# --- errors: exit 2, message, no output ---------------------------------------
expect_exit 2 "query unknown table" -- "$BT" query coarse.h5 --table nope theta_i=1 theta_o=1 phi_d=1
expect_grep "available: brdf" err.txt "available tables listed"
expect_exit 2 "query unknown coordinate" -- "$BT" query coarse.h5 --table brdf theta_i=1 theta_o=1 \
  phi_d=1 alpha=0.5
expect_grep "not a coordinate" err.txt "unknown coordinate named"
expect_exit 2 "query missing coordinate" -- "$BT" query coarse.h5 --table brdf theta_i=1 theta_o=1
expect_grep "missing phi_d" err.txt "missing coordinate named"
expect_exit 2 "query --reject out of range" -- "$BT" query coarse.h5 --table brdf theta_i=85 theta_o=1 \
  phi_d=1 --reject
expect_grep "theta_i.*85.*\[0, 80\]" err.txt "range in message"
expect_exit 0 "query clamps by default" -- "$BT" query coarse.h5 --table brdf theta_i=85 theta_o=1 phi_d=1
expect_grep "clamped" err.txt "clamping is reported"
printf 'theta_o,phi_d\n60,135\n60,abc\n' >badpts.csv
expect_exit 2 "query bad CSV" -- "$BT" query coarse.h5 --table brdf theta_i=40 --points badpts.csv -o bad.csv
expect_grep "badpts.csv:3" err.txt "CSV error names file and line"
printf 'theta_o,eta\n60,1.5\n' >badcol.csv
expect_exit 2 "query bad CSV column" -- "$BT" query coarse.h5 --table brdf theta_i=40 --points badcol.csv -o bad.csv
[ ! -e bad.csv ] && ok || bad "no CSV after an error"
expect_exit 2 "validate unknown table" -- "$BT" validate coarse.h5 --table nope
expect_exit 2 "validate missing file" -- "$BT" validate missing.h5 --table brdf
expect_exit 2 "plot unknown table" -- "$BT" plot coarse.h5 --table nope --slice theta_i=3 -o e1.png
expect_exit 2 "plot unknown slice axis" -- "$BT" plot coarse.h5 --table brdf --slice alpha=3 theta_i=3 -o e2.png
expect_grep "alpha" err.txt "bad slice named"
expect_exit 2 "plot slice out of range" -- "$BT" plot coarse.h5 --table brdf --slice theta_i=95 -o e3.png
expect_grep "theta_i.*95" err.txt "out-of-range slice named"
expect_exit 2 "plot bad slice syntax" -- "$BT" plot coarse.h5 --table brdf --slice theta_i -o e4.png
expect_exit 2 "plot three free axes" -- "$BT" plot coarse.h5 --table brdf -o e5.png
expect_grep "without --slice" err.txt "free axes explained"
expect_exit 2 "plot no free axis" -- "$BT" plot coarse.h5 --table brdf --slice theta_i=1 theta_o=1 \
  phi_d=1 -o e6.png
expect_exit 2 "plot --curves on a fixed axis" -- "$BT" plot coarse.h5 --table brdf --slice theta_i=1 \
  --curves theta_i -o e7.png
expect_exit 2 "plot into a missing directory" -- "$BT" plot coarse.h5 --table brdf --slice theta_i=1 \
  -o no/such/e8.png
ls e*.png >/dev/null 2>&1 && bad "a PNG was written by a failed plot" || ok
ls ./*.tmp* >/dev/null 2>&1 && bad "temporary files left behind" || ok

cli_summary
