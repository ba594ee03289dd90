#!/usr/bin/env bash
# plan_check_smoke.sh — smoke test of scripts/plan-check.py (docs/planning.md,
# "How good are the predictions"): bad options exit 2; one small closed-form
# spec (tests/data/plan_rough_dielectric.toml, 9 x 9, shrunk by --max-cells 40
# to 6 x 6) is planned as written, generated and certified, and the measured
# max total error (certify's off-grid probes, an independent measurement) lies
# within a factor 2 of the planner's prediction.  ~10 s on 2 cores.
# Usage: plan_check_smoke.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
SCRIPT="$SRC/scripts/plan-check.py"

expect_exit 2 "missing binary" -- "$PY" "$SCRIPT" --brdftab "$WORK/nosuch" --presets "$DATA/plan_rough_dielectric.toml"
expect_grep "is not an executable" err.txt "missing binary message"
expect_exit 2 "missing preset" -- "$PY" "$SCRIPT" --brdftab "$BT" --presets "$WORK/nosuch.toml"
expect_grep "no file" err.txt "missing preset message"
expect_exit 2 "negative max cells" -- "$PY" "$SCRIPT" --brdftab "$BT" --max-cells -1 --presets "$DATA/plan_rough_dielectric.toml"

# plan --as-written predicts the spec's own plan: no target, no -o.
expect_exit 2 "--as-written with a target" -- "$BT" plan "$DATA/plan_rough_dielectric.toml" --as-written --accuracy 1e-2
expect_grep "excludes --accuracy" err.txt "--as-written with a target message"
expect_exit 0 "--as-written" -- "$BT" plan "$DATA/plan_rough_dielectric.toml" --as-written -q
expect_grep "^as written: nodes 9x9, closed-form, float32; predicted max total error" out.txt "as-written line"

mkdir -p work
expect_exit 0 "small run" -- "$PY" "$SCRIPT" --brdftab "$BT" --max-cells 40 --workdir work --json r.json \
  --presets "$DATA/plan_rough_dielectric.toml"
expect_grep "^plan_rough_dielectric +brdf +rel +36 " out.txt "report row (36 cells)"
expect_grep "note: brdf: 81 -> 36 cells" out.txt "shrink note"

if "$PY" - <<'PYEOF'; then ok; else bad "results are not sane (see above)"; fi
import json, math, sys, tomllib
r = json.load(open("r.json"))["results"][0]
spec = tomllib.load(open("work/plan_rough_dielectric.toml", "rb"))
counts = [a["count"] for a in spec["tables"][0]["axes"]]
t = r["tables"][0]
ok = True
def check(cond, what):
    global ok
    if not cond:
        print("FAIL:", what, json.dumps(r)[:800]); ok = False
check(counts == [6, 6], f"work spec counts {counts}")
check(t["cells"] == 36, "planned cells")
check(t["predicted_error"] > 0 and math.isfinite(t["predicted_error"]), "prediction")
check("measured_error" in t and t["measured_error"] > 0, "measurement")
if "measured_error" in t:
    ratio = t["measured_error"] / t["predicted_error"]
    check(0.5 <= ratio <= 2, f"measured / predicted {ratio:.3f} outside [0.5, 2]")
check(r["generate_wall"] > 0 and r["predicted_seconds"] > 0, "times")
sys.exit(0 if ok else 1)
PYEOF
cli_summary
