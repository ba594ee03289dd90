#!/usr/bin/env bash
# What the CLI tells a user who follows the README: the cost guard of
# `generate --accuracy` (a plan beyond 10 minutes or 100x the spec's cells is
# refused before computing, with cheaper plans and the flags that accept the
# cost), the advice of a failed `certify` (the axis responsible and a plan
# predicted to pass, checked by generating and certifying that plan), the
# exit code and digits of `scene` certificates, the certified error printed
# by `query` and the C header, the --slice rule shared by export and plot,
# 16-bit PNG export, and wording.  About 40 s of CPU.
# Usage: cli_guidance_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"

# --- generate --accuracy: a runaway plan is refused before computing.
# Light from inside a dielectric (eta 1.3-1.8): the albedo has the total
# internal reflection kink across theta_i, so 1e-2 absolute needs ~10^4
# theta_i nodes (10^7 cells against the spec's 2304) and hours of compute.
cat > inside.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
[[axes]]
name = "theta_i"
range = [91.0, 180.0]
count = 16
[[axes]]
name = "alpha"
range = [0.05, 1.0]
count = 16
[[axes]]
name = "eta"
range = [1.3, 1.8]
count = 9
[[tables]]
name = "albedo_r_inside"
quantity = "albedo_r"
[integration]
method = "quadrature"
[output]
type = "float32"
SPEC
# `timeout`: a binary without the guard starts the hours-long run.
expect_exit 2 "costly plan refused" -- timeout 120 "$BT" generate inside.toml -o inside.h5 --representation tensor --accuracy 1e-2 --abs </dev/null
expect_grep "beyond what a run starts unasked" err.txt "the refusal says why"
expect_grep "x the spec's own 2304" err.txt "names the cell factor"
expect_grep "cheaper plans \(predicted\)" err.txt "offers cheaper plans"
expect_grep "^    --budget [0-9]+: nodes [0-9]+x[0-9]+x[0-9]+" err.txt "a plan per budget"
expect_grep "run it anyway with --yes; or --budget SECONDS" err.txt "names the flags"
expect_grep "not a terminal: refused; nothing computed or written" err.txt "non-interactive refusal"
if ls inside.h5* >/dev/null 2>&1; then bad "a refused run wrote something"; ls inside.h5*; else ok; fi
expect_exit 2 "--yes without --accuracy" -- "$BT" generate inside.toml -o inside.h5 --yes
expect_grep "need --accuracy E or --budget SECONDS" err.txt "--yes needs a target"

# --- certify: a miss names the axis responsible and a plan predicted to pass.
# theta_o has 5 nodes, theta_i 41: theta_o must be the axis responsible, and
# the plan must raise it; generating the plan's counts must then pass.
cat > coarse.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
alpha = 0.5
eta = 1.5
phi_d = 180.0
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 41
[[axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 5
[[tables]]
name = "brdf"
quantity = "brdf"
[output]
type = "float32"
SPEC
expect_exit 0 "coarse table" -- "$BT" generate coarse.toml -o coarse.h5 -q
expect_exit 1 "certify misses" -- "$BT" certify coarse.h5 --table brdf --accuracy 1e-3 -q
expect_grep "the axis responsible: theta_o " out.txt "names the coarse axis"
expect_grep "a plan predicted to pass .*: nodes theta_i [0-9]+ x theta_o [0-9]+ \(now 41 x 5\)" out.txt "prints a plan"
expect_grep "plan and verify it: brdftab plan coarse.toml --table brdf --accuracy 0.001" out.txt "names the command"
ni=$(sed -nE 's/.*nodes theta_i ([0-9]+) x theta_o ([0-9]+) .*/\1/p' out.txt)
no=$(sed -nE 's/.*nodes theta_i ([0-9]+) x theta_o ([0-9]+) .*/\2/p' out.txt)
if [ -n "$no" ] && [ "$no" -gt 5 ]; then ok; else bad "the plan does not raise theta_o ($no)"; fi
if [ -n "$ni" ]; then
  sed -e "s/count = 41/count = $ni/; s/count = 5\$/count = $no/" coarse.toml > suggested.toml
  expect_exit 0 "suggested plan generated" -- "$BT" generate suggested.toml -o suggested.h5 -q
  expect_exit 0 "suggested plan passes" -- "$BT" certify suggested.h5 --table brdf --accuracy 1e-3 -q
else
  bad "no plan to check"
fi
expect_exit 1 "certify --no-advice" -- "$BT" certify coarse.h5 --table brdf --accuracy 1e-3 -q --no-advice
if grep -q "axis responsible" out.txt; then bad "--no-advice printed advice"; else ok; fi

# --- scene: a failed certificate exits 1 (files written) with digits enough
# to show the miss.  Closed-form BSDF template tables (--no-plan): cheap.
cat > glass.pbrt <<'SCENE'
MakeNamedMaterial "glass" "string type" "dielectric" "float roughness" 0.09 "float eta" 1.5
NamedMaterial "glass"
Shape "sphere"
SCENE
expect_exit 1 "scene with a missed certificate" -- "$BT" scene glass.pbrt --for bsdf --tabulate-closed-forms --no-plan --accuracy 1e-9 -o glass.h5 -q
expect_grep "certified t0_bsdf_reflection: .*FAILED" out.txt "the miss is printed"
expect_grep "certificate\(s\) missed the target .*were written with passed = false" err.txt "the error says the files stay"
if [ -s glass.h5 ] && [ -s glass.json ]; then ok; else bad "scene files not written"; fi
# A target a hair below the measured error: the printed numbers must differ
# and show max > target.
near=$("$PY" -c "
import json; m = json.load(open('glass.json'))
c = m['table_sets'][0]['certificates']['t0_bsdf_reflection']['certified_error']
print(repr(c * (1 - 1e-5)))")
expect_exit 1 "scene near miss" -- "$BT" scene glass.pbrt --for bsdf --tabulate-closed-forms --no-plan --accuracy "$near" -o glass2.h5 -q
line=$(grep "certified t0_bsdf_reflection" out.txt)
"$PY" - "$line" <<'PY' && ok || bad "near miss digits: $line"
import re, sys
m = re.search(r"max total error (\S+) \(relative\), target (\S+): FAILED", sys.argv[1])
assert m, sys.argv[1]
assert float(m.group(1)) > float(m.group(2)), m.groups()
PY

# --- a small quadrature table with a stored error estimate (60 cells)
cat > lut.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
[[axes]]
name = "mu_i"
range = [0.1, 1.0]
count = 5
[[axes]]
name = "alpha"
range = [0.1, 1.0]
count = 4
[[axes]]
name = "eta"
range = [1.2, 2.0]
count = 3
[[tables]]
name = "albedo_r"
quantity = "albedo_r"
[integration]
method = "quadrature"
[output]
type = "float32"
keep_stderr = true
SPEC
BRDFTAB_PROGRESS_INTERVAL=0.001 expect_exit 0 "lut generate" -- "$BT" generate lut.toml -o lut.h5
# Quadrature draws no samples: the progress rate is in cells/s, the summary
# names the rule difference, and prints one relative figure (no floor here).
expect_grep "cells/s  elapsed" err.txt "quadrature progress in cells/s"
if grep -q "samples/s" err.txt; then bad "quadrature progress in samples/s"; else ok; fi
expect_grep "albedo_r: albedo_r \[mu_i 5 x alpha 4 x eta 3\] = 60 cells, quadrature, max error estimate \(accurate - coarse rule\) [0-9.e-]+ absolute, [0-9.e-]+ relative, values in" out.txt "quadrature summary"
if grep -q "samples" out.txt; then bad "quadrature summary counts samples"; cat out.txt; else ok; fi
expect_exit 0 "eval quadrature" -- "$BT" eval rough-dielectric albedo_r mu_i=0.5 alpha=0.3 eta=1.5
expect_grep "± [0-9.e-]+ \(error estimate: accurate - coarse rule, quadrature\) \[1\]" out.txt "eval names the quadrature estimate"
if grep -q "samples" out.txt; then bad "eval quadrature counts samples"; else ok; fi
# A pure number has no unit after its range.
expect_exit 0 "info" -- "$BT" info lut.h5
expect_grep "axis eta +\[1.2, 2\], 3 nodes, linear" out.txt "info: no unit 1 after a range"
expect_exit 0 "models" -- "$BT" models
expect_grep "fine for float16 tables; float32 tables need double" out.txt "models: float wording"
if grep -q "accurate enough for float16 tables, not float32" out.txt; then bad "models: old wording"; else ok; fi

# --- query: the stored stderr and what is known of the error between nodes
expect_exit 0 "query uncertified" -- "$BT" query lut.h5 --table albedo_r mu_i=0.37 alpha=0.21 eta=1.45
expect_grep "^albedo_r = [0-9.e-]+ ± [0-9.e-]+ \(stderr, interpolated\) \[1\] \(linear\); no certificate: the interpolation error is not in the ±" out.txt "query says there is no certificate"
expect_exit 0 "header uncertified" -- "$BT" export lut.h5 --table albedo_r --header lut0.h
expect_grep "Accuracy: no certificate stored" lut0.h "header says there is no certificate"
expect_exit 0 "certify --store" -- "$BT" certify lut.h5 --table albedo_r --accuracy 1 --abs --store -q
max=$("$PY" -c "
import h5py; print('%.3g' % h5py.File('lut.h5')['albedo_r'].attrs['certificate_max_error'])")
expect_exit 0 "query certified" -- "$BT" query lut.h5 --table albedo_r mu_i=0.37 alpha=0.21 eta=1.45
expect_grep "\(stderr, interpolated\) \[1\] \(linear\); certified max total error $max absolute \(linear interpolation\)$" out.txt "query prints the certified error"
expect_exit 0 "query certified json" -- "$BT" query lut.h5 --table albedo_r mu_i=0.37 alpha=0.21 eta=1.45 --json
"$PY" - <<'PY' && ok || bad "query --json certified_error"
import h5py, json
j = json.load(open("out.txt"))
a = h5py.File("lut.h5")["albedo_r"].attrs
assert j["certified_error"]["max"] == a["certificate_max_error"], j
assert j["certified_error"]["measure"] == "absolute" and j["certified_error"]["passed"] is True, j
assert "stderr" in j
PY
expect_exit 0 "header certified" -- "$BT" export lut.h5 --table albedo_r --header lut.h
expect_grep "Accuracy: certified max total error $max \(RMS [0-9.e-]+, absolute, linear interpolation\)" lut.h "header states the certified error"
expect_grep "Stored stderr up to [0-9.e-]+ \(not in this header\)" lut.h "header states the stderr"
if [ -n "${3:-}" ]; then
  printf '#include "lut.h"\nint main(void) { double x[3] = {0.5, 0.5, 1.5}; return albedo_r_eval(x) > 0 ? 0 : 1; }\n' > lut.c
  if "$3" -std=c99 -Wall -Werror -o lut_c lut.c -lm && ./lut_c; then ok; else bad "the header with its accuracy comment compiles"; fi
fi

# --- --slice: the same rule in export (EXR, PNG, MERL) and plot: a node is
# taken as is, a value between nodes is interpolated linearly and a note
# says so, with short numbers.  eta = 1.5 lies between the nodes 1.2, 1.6.
expect_exit 0 "exr between nodes" -- "$BT" export lut.h5 --table albedo_r --exr mid.exr --slice eta=1.5
expect_grep "note: eta = 1.5 is not a node; it lies between the nodes 1.2 and 1.6: values interpolated linearly" err.txt "export states the interpolation"
if grep -qE "[0-9]{9,}" err.txt; then bad "long numbers in the note"; cat err.txt; else ok; fi
expect_exit 0 "plot between nodes" -- "$BT" plot lut.h5 --table albedo_r --slice eta=1.5 -o mid_plot.png
expect_grep "note: eta = 1.5 is not a node; it lies between the nodes 1.2 and 1.6: values interpolated linearly" err.txt "plot states the interpolation"
expect_exit 2 "slice outside" -- "$BT" export lut.h5 --table albedo_r --exr out.exr --slice eta=2.5
expect_grep "eta = 2.5 is outside the axis \[1.2, 2\]$" err.txt "outside: the range, no unit 1"
# PNG: 16-bit grey; at a node the stored values, between nodes what `query`
# interpolates (linear), each within the 16-bit rounding (values in [0, 1]:
# q / 65535).  Decoded here with zlib.
expect_exit 0 "png at a node" -- "$BT" export lut.h5 --table albedo_r --png node.png --slice eta=1.6
expect_grep "PNG 16-bit grey 4 x 5 \(x alpha, y mu_i\), value = 0 \+ 1.5259021896696422e-05 \* q" out.txt "png mapping printed"
expect_exit 0 "png between nodes" -- "$BT" export lut.h5 --table albedo_r --png mid.png --slice eta=1.5
expect_grep "note: eta = 1.5 is not a node" err.txt "png states the interpolation"
"$BT" export lut.h5 --table albedo_r --png x.png --layers >out.txt 2>err.txt; [ $? -eq 2 ] && ok || bad "--layers with --png accepted"
"$PY" - "$BT" <<'PY' >py.txt 2>&1 && ok || { bad "png contents"; cat py.txt; }
import struct, subprocess, sys, zlib
import h5py, numpy as np

def read_png16(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, text = 8, b"", {}
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 16 and colour == 0, (depth, colour)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"tEXt":
            k, v = body.split(b"\0", 1)
            text[k.decode()] = v.decode("latin-1")
        pos += 12 + n
    raw, stride = zlib.decompress(idat), 2 * w
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - 2] if i >= 2 else 0
            b, c = prev[i], prev[i - 2] if i >= 2 else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([line[2 * x] << 8 | line[2 * x + 1] for x in range(w)])
        prev = line
    return np.array(rows, dtype=float), text

g = h5py.File("lut.h5")["albedo_r"]
values = g["value"][()]
mu, alpha = g["mu_i"][()], g["alpha"][()]
q, text = read_png16("node.png")
assert q.shape == (5, 4), q.shape          # y = mu_i (row 0 = first node), x = alpha
assert text["brdftab_mapping"].startswith("value = 0 + "), text
assert "eta=1.6" in text["brdftab_slice"], text
assert np.max(np.abs(q / 65535 - values[:, :, 1])) <= 0.5 / 65535 + 1e-7
q, text = read_png16("mid.png")
assert "eta=1.5 (interpolated)" in text["brdftab_slice"], text
pts = "mu_i,alpha\n" + "".join("%.17g,%.17g\n" % (m, a) for m in mu for a in alpha)
open("nodes.csv", "w").write(pts)
out = subprocess.run([sys.argv[1], "query", "lut.h5", "--table", "albedo_r", "eta=1.5", "--points", "nodes.csv"],
                     capture_output=True, text=True, check=True).stdout.splitlines()[1:]
expected = np.array([float(line.split(",")[2]) for line in out]).reshape(5, 4)
assert np.max(np.abs(q / 65535 - expected)) <= 0.5 / 65535 + 1e-7, np.max(np.abs(q / 65535 - expected))
PY

cli_summary
