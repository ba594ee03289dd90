#!/usr/bin/env bash
# End-to-end tests of rounded storage (host/io/bit_rounding.h, docs/format.md
# "Rounded storage"): [output] round_to_accuracy / round_measure read by
# h5py (a reader sharing no code with brdftab: the trailing mantissa bits
# zero, the attributes, the built-in filters only), `generate --accuracy`
# rounding by default with its certificate measured on the rounded values,
# --full-precision, and bad input.  A few seconds of CPU.
# Usage: bit_rounding_cli_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"

# A small closed-form BSDF slice and a small Monte Carlo albedo (with stderr).
spec() {  # spec NAME [OUTPUT LINES...]
  local name=$1
  shift
  {
    cat <<'SPEC'
model = "rough-dielectric"
[parameters]
alpha = 0.4
eta = 1.5
phi_d = 180.0
[[tables]]
name = "brdf"
quantity = "brdf"
[[tables.axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 17
[[tables.axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 33
[integration]
method = "closed-form"
[output]
type = "float32"
SPEC
    printf '%s\n' "$@"
  } > "$name"
}
mc_spec() {  # mc_spec NAME [OUTPUT LINES...]
  local name=$1
  shift
  {
    cat <<'SPEC'
model = "rough-dielectric"
[parameters]
alpha = 0.4
eta = 1.5
[[tables]]
name = "albedo_r"
quantity = "albedo_r"
[[tables.axes]]
name = "mu_i"
range = [0.05, 1.0]
count = 24
[integration]
method = "mc"
samples = 2048
[output]
type = "float32"
keep_stderr = true
SPEC
    printf '%s\n' "$@"
  } > "$name"
}

# --- relative: every value keeps 9 mantissa bits (2^-10 <= 0.1 x 1e-2)
spec rel.toml 'round_to_accuracy = 1e-2'
spec plain.toml
expect_exit 0 "rounded generate" -- "$BT" generate rel.toml -o rel.h5 -q
expect_exit 0 "plain generate" -- "$BT" generate plain.toml -o plain.h5 -q
mc_spec mc.toml 'round_to_accuracy = 1e-3' 'round_measure = "absolute"'
expect_exit 0 "rounded mc generate" -- "$BT" generate mc.toml -o mc.h5 -q
mc_spec mcplain.toml
expect_exit 0 "plain mc generate" -- "$BT" generate mcplain.toml -o mcplain.h5 -q
"$PY" - <<'PY' >py.txt 2>&1 && ok || { bad "h5py reads the rounded files"; cat py.txt; }
import h5py, numpy as np
with h5py.File("rel.h5", "r") as f, h5py.File("plain.h5", "r") as p:
    g, q = f["brdf"], p["brdf"]
    a = g.attrs
    assert a["rounding"] == "relative" and a["rounding_accuracy"] == 1e-2, dict(a)
    m = int(a["keep_bits"])
    assert m == 9 and a["rounding_bound"] == 2.0 ** -10, (m, a["rounding_bound"])
    ds = g["value"]
    # Built-in filters only: shuffle + deflate (+ the Fletcher-32 checksum).
    assert ds.dtype == np.float32 and ds.shuffle and ds.compression == "gzip" and ds.fletcher32, ds
    v = ds[...]
    bits = v.view(np.uint32)
    assert np.all(bits & np.uint32((1 << (23 - m)) - 1) == 0), "trailing bits not zero"
    exact = q["value"][...].astype(np.float64)   # the plain float32 values
    assert "rounding" not in q.attrs and "keep_bits" not in q.attrs
    nz = exact != 0
    rel = np.abs(v.astype(np.float64) - exact)[nz] / np.abs(exact[nz])
    # the bound against the double value, plus the float32 rounding of `exact`
    assert rel.max() <= 2.0 ** -10 + 2.0 ** -23, rel.max()
    assert rel.max() > 2.0 ** -14, rel.max()   # something was rounded
    assert np.all(v[~nz] == 0)
with h5py.File("mc.h5", "r") as f, h5py.File("mcplain.h5", "r") as p:
    g, q = f["albedo_r"], p["albedo_r"]
    a = g.attrs
    assert a["rounding"] == "absolute" and a["rounding_accuracy"] == 1e-3, dict(a)
    qt = 2.0 ** -13                                    # largest power of 2 with q/2 <= 1e-4
    assert a["rounding_bound"] == qt / 2, a["rounding_bound"]
    v = g["value"][...].astype(np.float64)
    assert np.all(np.mod(v, qt) == 0), "values off the quantum grid"
    e = q["value"][...].astype(np.float64)              # same seed: the same estimates
    assert np.abs(v - e).max() <= qt / 2 + 2.0 ** -24, np.abs(v - e).max()
    # stderr keeps stderr_keep_bits bits
    sm = int(a["stderr_keep_bits"])
    s = g["stderr"][...]
    assert sm == 6 and np.all(s.view(np.uint32) & np.uint32((1 << (23 - sm)) - 1) == 0)
    se = q["stderr"][...].astype(np.float64)
    assert np.all(np.abs(s - se) <= 2.0 ** -7 * se * (1 + 1e-6))
PY
# brdftab reads it back too, and info/query work on it.
expect_exit 0 "query rounded" -- "$BT" query rel.h5 --table brdf theta_i=30 theta_o=40 --json
expect_exit 0 "info rounded" -- "$BT" info rel.h5
expect_grep "storage: rounded for 0.01 \(relative\): 9 of 23 mantissa bits kept" out.txt "info shows the kept bits"
expect_exit 0 "info plain" -- "$BT" info plain.h5
if grep -q "storage: rounded" out.txt; then bad "info of a plain table claims rounding"; else ok; fi

# --- a table's own round_to_accuracy wins over [output]'s
cat > pertable.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
alpha = 0.4
eta = 1.5
phi_d = 180.0
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 9
[[axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 9
[[tables]]
name = "coarse"
quantity = "brdf"
round_to_accuracy = 0.5
[[tables]]
name = "fine"
quantity = "brdf"
[integration]
method = "closed-form"
[output]
round_to_accuracy = 1e-3
SPEC
expect_exit 0 "per-table rounding" -- "$BT" generate pertable.toml -o pertable.h5 -q
"$PY" - <<'PY' >py.txt 2>&1 && ok || { bad "per-table rounding"; cat py.txt; }
import h5py
with h5py.File("pertable.h5", "r") as f:
    c, g = f["coarse"].attrs, f["fine"].attrs
    # 0.5: 2^-(m+1) <= 0.05 -> m = 4; 1e-3: 2^-(m+1) <= 1e-4 -> m = 13
    assert c["rounding_accuracy"] == 0.5 and c["keep_bits"] == 4, dict(c)
    assert g["rounding_accuracy"] == 1e-3 and g["keep_bits"] == 13, dict(g)
PY
sed 's/round_to_accuracy = 0.5/round_to_accuracy = -1/' pertable.toml > badtable.toml
expect_exit 2 "bad per-table rounding" -- "$BT" generate badtable.toml -o badtable.h5 -q
expect_grep "tables\[0\].round_to_accuracy" err.txt "names the table's key"

# --- certified generation rounds by default; the certificate is measured
# on the rounded values and still passes.
spec cert.toml
expect_exit 0 "certified, rounded" -- "$BT" generate cert.toml --representation tensor --accuracy 3e-2 -o cert.h5 -q --max-refinements 1
expect_grep "certificate passed" out.txt "certificate passed"
expect_exit 0 "certified, full precision" -- "$BT" generate cert.toml --representation tensor --accuracy 3e-2 --full-precision -o full.h5 -q --max-refinements 1
"$PY" - <<'PY' >py.txt 2>&1 && ok || { bad "certified files"; cat py.txt; }
import h5py, numpy as np
with h5py.File("cert.h5", "r") as f, h5py.File("full.h5", "r") as p:
    a, b = f["brdf"].attrs, p["brdf"].attrs
    assert a["rounding"] == "relative" and a["rounding_accuracy"] == 3e-2, dict(a)
    assert a["certificate_passed"] == 1 and a["certificate_max_error"] <= 3e-2
    # The stored spec reproduces the file: its [output] rounds too.
    assert "round_to_accuracy" in a["spec"] and "round_measure = 'relative'" in a["spec"], a["spec"]
    assert "rounding" not in b and b["certificate_passed"] == 1
    m = int(a["keep_bits"])
    assert m == 8, m   # 2^-9 <= 3e-3 < 2^-8
    v = f["brdf"]["value"][...]
    # float32, or float16 where the planner chose it
    p_bits, u = (10, np.uint16) if v.dtype == np.float16 else (23, np.uint32)
    assert np.all(v.view(u) & u((1 << (p_bits - m)) - 1) == 0)
PY
# A separate certify of the rounded file agrees.
expect_exit 0 "certify rounded" -- "$BT" certify cert.h5 --table brdf --accuracy 3e-2
expect_grep "certificate passed" out.txt "certify passes"

# --- bad input
spec bad1.toml 'round_to_accuracy = 0'
expect_exit 2 "round_to_accuracy 0" -- "$BT" generate bad1.toml -o bad1.h5 -q
expect_grep "output.round_to_accuracy" err.txt "names the key"
spec bad2.toml 'round_to_accuracy = 1e-2' 'round_measure = "rms"'
expect_exit 2 "bad round_measure" -- "$BT" generate bad2.toml -o bad2.h5 -q
expect_grep "allowed: relative, absolute" err.txt "lists the measures"
spec bad3.toml 'round_measure = "absolute"'
expect_exit 2 "round_measure alone" -- "$BT" generate bad3.toml -o bad3.h5 -q
expect_grep "needs round_to_accuracy" err.txt "says what it needs"
expect_exit 2 "--full-precision alone" -- "$BT" generate plain.toml --full-precision -o x.h5 -q
if [ -e bad1.h5 ] || [ -e bad2.h5 ] || [ -e x.h5 ]; then bad "bad input wrote a file"; else ok; fi

cli_summary
