#!/usr/bin/env bash
# The CLI tells the truth (issue 16, "CLI truth-telling"): messages name the
# problem, `models` reads well, metadata says what happened, `query` folds
# phi_d, the README's examples run.
# Usage: cli_truth_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"

# ---------------------------------------------------------------- messages
expect_exit 2 "unknown subcommand" -- "$BT" exprt
expect_grep "unknown command 'exprt'" err.txt "the unknown word is named"
expect_grep "did you mean 'export'" err.txt "the closest subcommand is suggested"
expect_exit 2 "help is not a command" -- "$BT" help
expect_grep "brdftab --help" err.txt "'help' points to --help"
expect_exit 2 "unknown subcommand, nothing close" -- "$BT" zzzzzzzz
expect_grep "unknown command 'zzzzzzzz'" err.txt "the unknown word is named"
if grep -q "did you mean" err.txt; then bad "no suggestion for a word unlike any command"; else ok; fi

# Range messages give the range, never CLI11's bound of 1.8e308 in full.
no_long_number() {
  if grep -qE '[0-9]{25}' err.txt; then bad "$1: a huge number in the message"; cat err.txt; else ok; fi
}
cp "$DATA/rough_dielectric_brdf.toml" t.toml
for args in "eval rough-dielectric albedo_r theta_i=30 alpha=0.3 eta=1.5 --samples 0" \
            "generate t.toml -o t.h5 --samples 0" \
            "validate t.h5 --table brdf --samples 0" \
            "validate t.h5 --table brdf --max-samples 0" \
            "eval rough-dielectric albedo_r theta_i=30 alpha=0.3 eta=1.5 --abs-floor 0"; do
  # shellcheck disable=SC2086
  expect_exit 2 "$args" -- "$BT" $args
  expect_grep "out of range; allowed: (integers in \[1, 4294967295\]|a number > 0)" err.txt \
    "$args: the allowed range is stated"
  no_long_number "$args"
done
for args in "eval rough-dielectric albedo_r theta_i=30 alpha=0.3 eta=1.5 --tolerance 0" \
            "generate t.toml -o t.h5 --tolerance 0" \
            "generate t.toml -o t.h5 --tolerance 1"; do
  # shellcheck disable=SC2086
  expect_exit 2 "$args" -- "$BT" $args
  expect_grep "allowed: \(0, 1\)" err.txt "$args: the documented range (0, 1) is stated"
done
[ ! -e t.h5 ] && ok || bad "a refused generate wrote its output"

# ---------------------------------------------------------------- models
expect_exit 0 "models MODEL" -- "$BT" models oren-nayar
expect_grep "^oren-nayar$" out.txt "the model is shown"
if grep -qE "^(rough-dielectric|micrograin|lambert-sphere)$" out.txt; then
  bad "models MODEL shows other models too"; else ok; fi
expect_exit 2 "models with an unknown model" -- "$BT" models oren_nayar
expect_grep "unknown model 'oren_nayar'" err.txt "the unknown model is named"
expect_exit 0 "models --json MODEL" -- "$BT" models micrograin --json
if "$PY" -c 'import json,sys; j=json.load(open("out.txt")); sys.exit(0 if j["name"]=="micrograin" else 1)'; then
  ok; else bad "models MODEL --json is not that model's object"; fi
expect_exit 0 "models" -- "$BT" models
# Columns: within each section of each model, the text after the names starts
# in one column, at least two spaces after the longest name.
if "$PY" - <<'EOF'
import re, sys
section, cols, ok = None, {}, True
for line in open("out.txt"):
    line = line.rstrip("\n")
    if re.match(r"^\S", line):
        cols = {}
    m = re.match(r"^  (Parameters|Options|Quantities):$", line)
    if m:
        section = m.group(1)
        continue
    m = re.match(r"^    (\S+)( +)\S", line)
    if section and m:
        if len(m.group(2)) < 2:
            print("name runs into its text:", line[:80]); ok = False
        col = len(m.group(1)) + len(m.group(2))
        if cols.setdefault(section, col) != col:
            print("column moves:", line[:80]); ok = False
sys.exit(0 if ok else 1)
EOF
then ok; else bad "models columns are not aligned"; fi
expect_grep "; dimensionless; depends on" out.txt "unit 1 reads as dimensionless"
if grep -q "; 1; depends on" out.txt; then bad "unit printed as a bare 1"; else ok; fi

# ---------------------------------------------------------------- metadata
# The spec's text is stored, its name without directories.
mkdir -p specs/sub
cat >specs/sub/inside.toml <<'TOML'
# light from inside: theta_i > 90
model = "rough-dielectric"
[parameters]
alpha = 0.4
eta = 1.5
[[axes]]
name = "theta_i"
range = [100.0, 180.0]
count = 3
[[axes]]
name = "theta_o"
range = [0.0, 180.0]
count = 5
[[tables]]
quantity = "bsdf"
TOML
expect_exit 0 "generate from an absolute spec path" -- "$BT" generate "$WORK/specs/sub/inside.toml" -o inside.h5 -q
if "$PY" - <<'EOF'
import h5py, json, sys
g = h5py.File("inside.h5", "r")["bsdf"]
spec_file = g.attrs["spec_file"]
spec = g.attrs["spec"]
params = json.loads(g.attrs["parameters"])
ok = True
if spec_file != "inside.toml":
    print("spec_file is %r, want the bare name" % spec_file); ok = False
if spec != open("specs/sub/inside.toml").read():
    print("stored spec text differs from the file"); ok = False
if params.get("side") != "inside":
    print("parameters do not record the real side (inside):", params); ok = False
sys.exit(0 if ok else 1)
EOF
then ok; else bad "spec text / spec_file / side metadata"; fi
expect_exit 0 "info shows the stored spec" -- "$BT" info inside.h5
expect_grep "spec: inside.toml, text stored" out.txt "info names the spec and its stored text"

# A quadrature table records no sample budget.
cat >quad.toml <<'TOML'
model = "oren-nayar"
[parameters]
sigma = 20.0
[[axes]]
name = "theta_i"
range = [0.0, 60.0]
count = 2
[[axes]]
name = "theta_o"
range = [0.0, 60.0]
count = 2
[[tables]]
quantity = "brdf_direct"
TOML
expect_exit 0 "generate a quadrature table" -- "$BT" generate quad.toml -o quad.h5 -q
expect_exit 0 "info on a quadrature table" -- "$BT" info quad.h5
expect_grep "method: quadrature" out.txt "the method is quadrature"
if grep -q "samples/cell requested" out.txt; then bad "quadrature table claims a sample budget"; cat out.txt; else ok; fi
if "$PY" -c 'import h5py,sys; sys.exit(0 if h5py.File("quad.h5","r")["brdf_direct"].attrs["samples_requested"] == 1 else 1)'; then
  ok; else bad "quadrature samples_requested is not 1"; fi

# docs/format.md names the real command.
if grep -q "export-exr" "$SRC/docs/format.md"; then bad "docs/format.md says export-exr"; else ok; fi

# ---------------------------------------------------------------- query folding
sed -e 's/^path = .*/path = "q.h5"/' "$DATA/rough_dielectric_brdf.toml" >q.toml
expect_exit 0 "generate a query table" -- "$BT" generate q.toml -q
q() { "$BT" query q.h5 --table brdf theta_i=30 theta_o=50 "phi_d=$1" --json 2>err_q.txt; }
fold_same() {  # fold_same GIVEN EQUIVALENT
  local a b
  a=$(q "$1") && b=$(q "$2") || { bad "query phi_d=$1 failed"; return; }
  if [ "$a" = "$b" ]; then ok; else bad "phi_d=$1 should equal phi_d=$2: $a vs $b"; fi
  if grep -q clamped err_q.txt; then bad "phi_d=$1 reported as clamped"; else ok; fi
}
fold_same -180 180
fold_same 190 170
fold_same -30 30
fold_same 400 40
fold_same -370 10
# Other axes are still clamped, with the warning.
expect_exit 0 "theta out of range clamps" -- "$BT" query q.h5 --table brdf theta_i=85 theta_o=50 phi_d=10
expect_grep "clamped" err.txt "clamping is reported"

# ---------------------------------------------------------------- README
# The README's --points example runs as written (its file ships in examples/).
line=$(grep -o 'brdftab eval [^`]*--points [^ ]*' "$SRC/README.md" | head -1)
points=$(echo "$line" | sed 's/.*--points //')
[ -n "$points" ] && [ -f "$SRC/$points" ] && ok || bad "README's points file '$points' is not in the repository"
args=$(echo "$line" | sed -e 's/^brdftab eval //' -e 's/ --points .*//')
# shellcheck disable=SC2086
expect_exit 0 "README --points example" -- "$BT" eval $args --points "$SRC/$points" -o values.csv
rows=$(($(wc -l <values.csv) - 1))
[ "$rows" -eq $(($(grep -c . "$SRC/$points") - 1)) ] && ok || bad "values.csv has $rows rows"

cli_summary
