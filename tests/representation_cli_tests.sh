#!/usr/bin/env bash
# representation_cli_tests.sh — the choice between tensor and adaptive tables
# (docs/adaptive.md, "Choosing the representation"), end to end:
#   * a kink (the TIR edge of an inside albedo, tests/data/adaptive_inside.toml,
#     3e-2 absolute, linear) where adaptive must win, and a smooth albedo read
#     with Catmull-Rom (tests/data/representation_smooth.toml, 1e-4) where
#     tensor must win.  Oracle: both representations generated with
#     --representation forced, and their stored values counted in the files
#     (h5py); `generate --accuracy` without --representation must have made
#     the smaller one, and `plan` must choose it too.
#   * the adaptive prediction (`plan --json`, predicted_values) within a
#     factor 2 of the values the generated adaptive table stores.
#   * spec keys: [output] representation and [adaptive] generate adaptive
#     tables with no option; command-line options override them; bad keys
#     exit 2 naming the key.
#   * plan warns of a tensor plan above 10^8 cells, naming the axis; so does
#     scene --dry-run for a table set that large.
# About a minute of CPU.  Usage: representation_cli_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
if ! "$PY" -c "import h5py, numpy" 2>/dev/null; then
  echo "SKIP: /usr/bin/python3 lacks h5py or numpy"
  exit 77
fi

# stored FILE TABLE: the number of stored values, and the representation.
stored() {
  "$PY" - "$1" "$2" <<'PY'
import sys, h5py
g = h5py.File(sys.argv[1], "r")[sys.argv[2]]
rep = g.attrs.get("representation", b"tensor")
rep = rep.decode() if isinstance(rep, bytes) else str(rep)
print(g["value"].size, rep)
PY
}

# compare NAME SPEC TABLE WINNER ARGS...: generate both forced, then the
# automatic choice and `plan`; the winner must store fewer values, be chosen
# by both, and (adaptive) be predicted within a factor 2.
compare() {
  local name=$1 spec=$2 table=$3 winner=$4
  shift 4
  expect_exit 0 "$name: generate tensor" -- "$BT" generate "$spec" --representation tensor -q -o "$name-t.h5" "$@"
  expect_exit 0 "$name: generate adaptive" -- "$BT" generate "$spec" --representation adaptive -q -o "$name-a.h5" "$@"
  expect_exit 0 "$name: generate, representation chosen" -- "$BT" generate "$spec" -q -o "$name-auto.h5" "$@"
  cp err.txt "$name-auto.err"
  expect_grep "representation: chose $winner" "$name-auto.err" "$name: generate says which it chose"
  expect_exit 0 "$name: plan" -- "$BT" plan "$spec" --json --no-verify -q "$@"
  cp out.txt "$name-plan.json"
  read -r nt rt <<< "$(stored "$name-t.h5" "$table")"
  read -r na ra <<< "$(stored "$name-a.h5" "$table")"
  read -r nc rc <<< "$(stored "$name-auto.h5" "$table")"
  echo "$name: tensor stores $nt values, adaptive $na; generate chose $rc"
  [ "$rt" = tensor ] && [ "$ra" = adaptive ] && ok || bad "$name: forced representations $rt, $ra"
  if [ "$winner" = adaptive ]; then
    [ "$na" -lt "$nt" ] && ok || bad "$name: adaptive ($na) should store fewer values than tensor ($nt)"
  else
    [ "$nt" -lt "$na" ] && ok || bad "$name: tensor ($nt) should store fewer values than adaptive ($na)"
  fi
  [ "$rc" = "$winner" ] && ok || bad "$name: generate chose $rc, the smaller is $winner"
  if "$PY" - "$name-plan.json" "$winner" "$na" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
winner, stored = sys.argv[2], float(sys.argv[3])
assert j["representation"]["choice"] == winner, j["representation"]
pred = j["adaptive"]["predicted_values"]
print(f"  plan: adaptive predicted {pred:.0f} values, stored {stored:.0f} (ratio {stored / pred:.2f}); "
      f"{j['representation']['why']}")
# The prediction is a lower bound when the pilots stopped early (tensor won
# already); otherwise within a factor 2 of what generation stores.
if j["adaptive"]["tables"][0]["lower_bound"]:
    assert pred <= stored, (pred, stored)
else:
    assert 0.5 <= stored / pred <= 2.0, (pred, stored)
PY
  then ok; else bad "$name: plan's choice or adaptive prediction"; fi
}

compare kink "$DATA/adaptive_inside.toml" albedo_t_inside adaptive --accuracy 3e-2 --abs
compare smooth "$DATA/representation_smooth.toml" albedo_r tensor --accuracy 1e-4 --abs --interpolation cubic

# ---- spec keys: [output] representation and [adaptive], overridden by options
cp "$DATA/adaptive_inside.toml" keys.toml
cat >> keys.toml <<'EOF'
representation = "adaptive"
[adaptive]
accuracy = 3e-2
measure = "absolute"
max_values = 4000
patch_order = 2
EOF
expect_exit 0 "generate from spec keys" -- "$BT" generate keys.toml -q -o keys.h5
expect_grep "target max absolute error 0.03" err.txt "spec keys: accuracy and measure"
expect_grep "at most 4000 values, 3-node patches of order 2" err.txt "spec keys: max_values and patch_order"
expect_exit 0 "options override spec keys" -- "$BT" generate keys.toml -q -o keys1.h5 --patch-order 1 --max-values 3000
expect_grep "at most 3000 values, 3-node patches of order 1" err.txt "options override the spec"
if "$PY" - <<'PY'
import h5py, sys
a = h5py.File("keys.h5")["albedo_t_inside"].attrs
b = h5py.File("keys1.h5")["albedo_t_inside"].attrs
sys.exit(0 if int(a["patch_order"]) == 2 and int(b["patch_order"]) == 1 else 1)
PY
then ok; else bad "patch_order in the files"; fi
cp "$DATA/adaptive_inside.toml" badkey.toml
printf '[adaptive]\npatch_nodes = 4\n' >> badkey.toml
expect_exit 2 "bad [adaptive] key" -- "$BT" generate badkey.toml -q -o bad.h5
expect_grep "badkey.toml:[0-9]+:[0-9]+: key 'adaptive.patch_nodes'.*allowed: 3, 5, 9" err.txt "bad key message"
[ -e bad.h5 ] && bad "a refused spec wrote bad.h5" || ok

# ---- a tensor plan above 10^8 cells: the warning names the axis
expect_exit 0 "plan of a large tensor table" -- "$BT" plan "$DATA/plan_large.toml" --accuracy 1e-3 --no-verify -q \
  --representation tensor
expect_grep "warning: choice: the plan has [0-9.e+]+ cells, above 1e\+08: .* axis 'phi_d' needs the most nodes" \
  out.txt "large-plan warning"
expect_grep "adaptive representation" out.txt "large-plan warning suggests adaptive"

# ---- scene: a set above 10^8 cells is named with its axis (dry run: warned only)
expect_exit 0 "scene dry run with large BSDF sets" -- "$BT" scene "$DATA/scenes/pbrt_v4.pbrt" --for bsdf \
  --tabulate-closed-forms --dry-run -q
expect_grep "warning: t[0-9]+ \(rough-dielectric bsdf\): the plan has [0-9.e+]+ cells, above 1e\+08: .*axis '[a-z_]+' needs the most nodes" \
  out.txt "scene: large-set warning"

cli_summary
