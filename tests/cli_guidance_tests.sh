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
expect_exit 2 "costly plan refused" -- timeout 120 "$BT" generate inside.toml -o inside.h5 --accuracy 1e-2 --abs </dev/null
expect_grep "beyond what a run starts unasked" err.txt "the refusal says why"
expect_grep "x the spec's own 2304" err.txt "names the cell factor"
expect_grep "cheaper plans \(predicted\)" err.txt "offers cheaper plans"
expect_grep "^    --budget 60: nodes [0-9]+x[0-9]+x[0-9]+" err.txt "a plan per budget"
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
expect_exit 1 "scene with a missed certificate" -- "$BT" scene glass.pbrt --for bsdf --no-plan --accuracy 1e-9 -o glass.h5 -q
expect_grep "certified t0_bsdf_reflection: .*FAILED" out.txt "the miss is printed"
expect_grep "certificate\(s\) missed the target .*were written with passed = false" err.txt "the error says the files stay"
if [ -s glass.h5 ] && [ -s glass.json ]; then ok; else bad "scene files not written"; fi
# A target a hair below the measured error: the printed numbers must differ
# and show max > target.
near=$("$PY" -c "
import json; m = json.load(open('glass.json'))
c = m['table_sets'][0]['certificates']['t0_bsdf_reflection']['certified_error']
print(repr(c * (1 - 1e-5)))")
expect_exit 1 "scene near miss" -- "$BT" scene glass.pbrt --for bsdf --no-plan --accuracy "$near" -o glass2.h5 -q
line=$(grep "certified t0_bsdf_reflection" out.txt)
"$PY" - "$line" <<'PY' && ok || bad "near miss digits: $line"
import re, sys
m = re.search(r"max total error (\S+) \(relative\), target (\S+): FAILED", sys.argv[1])
assert m, sys.argv[1]
assert float(m.group(1)) > float(m.group(2)), m.groups()
PY

cli_summary
