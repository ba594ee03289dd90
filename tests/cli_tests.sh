#!/usr/bin/env bash
# End-to-end tests of the brdftab command line: exit codes, error messages,
# no partial output on failure, determinism of generated files, CSV batches,
# inspection and EXR export.  Usage: cli_tests.sh BRDFTAB SOURCE_DIR
set -u
# The script may be run from anywhere, with relative paths.
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=cli_lib.sh
source "$HERE/cli_lib.sh"
cli_setup "$1" "$2"

have_h5py() { [ -x "$PY" ] && "$PY" -c "import h5py" 2>/dev/null; }

# --- help and listing ---------------------------------------------------------
expect_exit 0 "--help" -- "$BT" --help
expect_grep "generate" out.txt "--help lists generate"
expect_exit 0 "generate --help" -- "$BT" generate --help
expect_grep "tolerance" out.txt "generate --help explains --tolerance"
expect_exit 0 "models" -- "$BT" models
expect_grep "rough-dielectric" out.txt "models lists rough-dielectric"
expect_exit 0 "models --json" -- "$BT" models --json
expect_exit 0 "devices" -- "$BT" devices
expect_grep "^\[0\]" out.txt "devices lists device 0"
expect_exit 2 "no subcommand" -- "$BT"
expect_exit 2 "unknown subcommand" -- "$BT" frobnicate

# --- eval ---------------------------------------------------------------------
expect_exit 0 "eval closed form json" -- "$BT" eval rough-dielectric brdf theta_i=30 theta_o=30 \
  phi_d=180 alpha=0.3 eta=1.5 --json
expect_grep '"stderr":0' out.txt "closed form has zero stderr"
expect_grep '"value":' out.txt "json has value"
expect_grep '"samples":1' out.txt "closed form counts one sample"
# Oracle: at i = o = n the half vector is n, so f_r = F(0) D(n) G1(n)^2/(4) with
# GGX D(n) = 1/(pi alpha^2), G1(n) = 1, F(0) = ((eta-1)/(eta+1))^2.
expect_exit 0 "eval at normal" -- "$BT" eval rough-dielectric brdf theta_i=0 theta_o=0 alpha=0.5 \
  eta=1.5 --json
if [ -x "$PY" ]; then
  "$PY" - out.txt <<'EOF' && ok || bad "f_r at normal incidence against F0 D/4"
import json, math, sys
v = json.load(open(sys.argv[1]))["value"]
expected = ((1.5 - 1) / (1.5 + 1)) ** 2 / (math.pi * 0.5 ** 2) / 4
sys.exit(0 if abs(v - expected) <= 1e-9 * expected else 1)
EOF
fi
expect_exit 0 "eval integral" -- "$BT" eval rough-dielectric albedo_r theta_i=40 alpha=0.2 eta=1.5 \
  --samples 2048 --seed 3
expect_grep "±" out.txt "integral prints its error"
expect_exit 0 "eval host device" -- "$BT" eval rough-dielectric albedo_r theta_i=40 alpha=0.2 \
  eta=1.5 --samples 2048 --seed 3 --device host
expect_exit 2 "alpha out of range" -- "$BT" eval rough-dielectric brdf theta_i=0 theta_o=0 alpha=-1 eta=1.5
expect_grep "alpha.*\(0, 4\]" err.txt "range in message"
expect_exit 2 "theta out of range" -- "$BT" eval rough-dielectric brdf theta_i=200 theta_o=0 alpha=1 eta=1.5
expect_exit 2 "unknown parameter" -- "$BT" eval rough-dielectric brdf theta_i=0 theta_o=0 alpah=1 eta=1.5
expect_exit 2 "unknown option choice" -- "$BT" eval rough-dielectric brdf theta_i=0 theta_o=0 alpha=1 \
  eta=1.5 distribution=cauchy
expect_grep "beckmann" err.txt "choices listed"
expect_exit 2 "missing theta_o" -- "$BT" eval rough-dielectric brdf theta_i=0 alpha=1 eta=1.5
expect_exit 2 "unknown model" -- "$BT" eval no-such-model brdf
expect_exit 2 "mc for a closed form" -- "$BT" eval rough-dielectric brdf theta_i=0 theta_o=0 alpha=1 \
  eta=1.5 --method mc
expect_exit 2 "bad device" -- "$BT" eval rough-dielectric brdf theta_i=0 theta_o=0 alpha=1 eta=1.5 \
  --device nosuchdevice
expect_grep "\[0\]" err.txt "available devices listed"

# --points: many points in one launch, CSV out; file written atomically.
cat >pts.csv <<'EOF'
theta_i,theta_o,phi_d
0,0,0
30,30,180
30,150,180
60,120,0
EOF
expect_exit 0 "eval --points" -- "$BT" eval rough-dielectric bsdf alpha=0.3 eta=1.5 --points pts.csv -o res.csv
[ "$(wc -l <res.csv)" -eq 5 ] && ok || bad "points CSV has header + 4 rows"
expect_grep "^theta_i,theta_o,phi_d,value,stderr,samples" res.csv "CSV header"
printf 'theta_i,theta_o\n0,0\n30,x\n' >badpts.csv
expect_exit 2 "bad CSV value" -- "$BT" eval rough-dielectric bsdf alpha=0.3 eta=1.5 --points badpts.csv -o res2.csv
expect_grep "badpts.csv:3" err.txt "CSV error names file and line"
[ ! -e res2.csv ] && ok || bad "no output after a CSV error"

# --- generate -----------------------------------------------------------------
cp "$DATA/rough_dielectric_albedo.toml" albedo.toml
expect_exit 0 "generate albedo" -- "$BT" generate albedo.toml
expect_grep "wrote albedo.h5" out.txt "generate says where it wrote"
[ -s albedo.h5 ] && ok || bad "albedo.h5 written"
expect_exit 0 "generate again, other slab size" -- "$BT" generate albedo.toml -o albedo2.h5 --slab 3
expect_exit 0 "generate with other seed" -- "$BT" generate albedo.toml -o albedo3.h5 --seed 8
expect_exit 0 "info" -- "$BT" info albedo.h5 --values
expect_grep "albedo_t" out.txt "info lists tables"
expect_grep "theta_i=5" out.txt "info shows shape"
if have_h5py; then
  "$PY" - <<'EOF' && ok || bad "determinism / format via h5py"
import h5py, numpy as np, sys
a, b, c = (h5py.File(f, "r") for f in ("albedo.h5", "albedo2.h5", "albedo3.h5"))
for t in ("albedo_r", "albedo_t"):
    va, vb, vc = (f[t]["value"][...] for f in (a, b, c))
    assert va.shape == (5, 3), va.shape
    assert np.array_equal(va, vb), "slab size changed the table"
    assert not np.array_equal(va, vc), "seed did not change the table"
    assert (a[t]["stderr"][...] > 0).all()
    assert a[t].attrs["model"] == "rough-dielectric"
    assert list(a[t]["theta_i"][...]) == [0, 20, 40, 60, 80]
# Physics: R + T <= 1 in every cell (within 5 standard errors).
r, t = a["albedo_r"], a["albedo_t"]
excess = r["value"][...] + t["value"][...] - 1
se = np.hypot(r["stderr"][...], t["stderr"][...])
assert (excess <= 5 * se).all(), excess
EOF
else
  echo "skip: /usr/bin/python3 with h5py not available"
fi

# Bad specs: exit 2, message names file, line and key; nothing written, and an
# existing output is left untouched.
cp albedo.h5 keep.h5
cksum keep.h5 >keep.sum
sed -e 's/count = 3/count = 1/' -e 's/albedo.h5/keep.h5/' albedo.toml >bad1.toml
expect_exit 2 "count < 2" -- "$BT" generate bad1.toml
expect_grep "bad1.toml:[0-9]+" err.txt "error names the file and line"
expect_grep "count" err.txt "error names the key"
sed -e 's/0.1, 0.9/-0.1, 0.9/' -e 's/albedo.h5/keep.h5/' albedo.toml >bad2.toml
expect_exit 2 "alpha range below 0" -- "$BT" generate bad2.toml
expect_grep "alpha" err.txt "error names alpha"
sed -e 's/^seed = 7/seed = 7\nsede = 3/' -e 's/albedo.h5/keep.h5/' albedo.toml >bad3.toml
expect_exit 2 "unknown key" -- "$BT" generate bad3.toml
expect_grep "sede" err.txt "error names the unknown key"
sed -e 's/eta = 1.5/eta = 0.0/' -e 's/albedo.h5/keep.h5/' albedo.toml >bad4.toml
expect_exit 2 "eta <= 0" -- "$BT" generate bad4.toml
printf 'model = "rough-dielectric"\n[[tables]\n' >bad5.toml
expect_exit 2 "TOML syntax error" -- "$BT" generate bad5.toml -o keep.h5
expect_exit 2 "missing spec file" -- "$BT" generate does-not-exist.toml -o keep.h5
expect_exit 2 "output directory missing" -- "$BT" generate albedo.toml -o no/such/dir/x.h5
cksum keep.h5 | cmp -s - keep.sum && ok || bad "existing output untouched by failed runs"
ls ./*.tmp* >/dev/null 2>&1 && bad "temporary files left behind" || ok

# --- recombined tables: Oren-Nayar at any rho from its two factored tables ----
cp "$DATA/oren_nayar_recombined.toml" on.toml
expect_exit 0 "generate with a recombined table" -- "$BT" generate on.toml -q
expect_exit 0 "query recombined at rho" -- "$BT" query on.h5 --table brdf theta_i=40 theta_o=60 \
  phi_d=45 rho=0.5 --json
cp out.txt query.json
# Oracle: the model evaluated directly at rho = 0.5 at a grid node, so the
# interpolation is exact and only the quadrature's last bits may differ.
expect_exit 0 "eval at rho" -- "$BT" eval oren-nayar brdf theta_i=40 theta_o=60 phi_d=45 sigma=20 \
  rho=0.5 --json
if [ -x "$PY" ]; then
  "$PY" - query.json out.txt <<'EOF' && ok || bad "recombined query equals direct evaluation"
import json, sys
q = json.load(open(sys.argv[1]))["value"]
e = json.load(open(sys.argv[2]))["value"]
sys.exit(0 if abs(q - e) <= 1e-9 * abs(e) else 1)
EOF
fi
sed -e 's/table = "brdf_interreflection"/table = "nope"/' on.toml >bad6.toml
expect_exit 2 "recombined term names an unknown table" -- "$BT" generate bad6.toml -o bad6.h5
expect_grep "bad6.toml:[0-9]+.*recombined" err.txt "error names the file, line and key"
[ ! -e bad6.h5 ] && ok || bad "no output after a recombined-spec error"

# --- error tables: the qualitative model against the exact integral -----------
cat on.toml - >onerr.toml <<'EOF'
[[tables]]
name = "approx"
quantity = "qualitative"
[tables.parameters]
rho = 1.0
[[errors]]
name = "approx_error"
table = "approx"
reference = "brdf"
by = "theta_i"
EOF
sed -i -e 's/path = "on.h5"/path = "onerr.h5"/' onerr.toml
expect_exit 0 "generate with an error table" -- "$BT" generate onerr.toml -q
expect_grep "relative error of approx against brdf: max \|e\| [0-9.]+%" out.txt \
  "generate prints the error summary"
expect_grep "theta_i = 80: max \|e\|" out.txt "per-node summary along 'by'"
expect_exit 0 "info on an error table" -- "$BT" info onerr.h5
expect_grep "approx_error" out.txt "info lists the error table"
expect_exit 2 "validate refuses an error table" -- "$BT" validate onerr.h5 --table approx_error
expect_grep "validate the tables it compares: 'approx' and 'brdf'" err.txt \
  "validate names the compared tables"
sed -e 's/^by = .*/floor = -2.0/' onerr.toml >bad7.toml
expect_exit 2 "error table with a negative floor" -- "$BT" generate bad7.toml -o bad7.h5
expect_grep "bad7.toml:[0-9]+:[0-9]+: key 'errors\[0\]\.floor'" err.txt "error names the key"
[ ! -e bad7.h5 ] && ok || bad "no output after an error-spec error"

# --- export -------------------------------------------------------------------
expect_exit 0 "export exr" -- "$BT" export albedo.h5 --table albedo_r --exr slice.exr
[ -s slice.exr ] && ok || bad "slice.exr written"
expect_exit 2 "export wrong table" -- "$BT" export albedo.h5 --table nope --exr x.exr
expect_grep "albedo_r" err.txt "available tables listed"
[ ! -e x.exr ] && ok || bad "no EXR after an error"
expect_exit 2 "info on a non-HDF5 file" -- "$BT" info albedo.toml

cli_summary
