#!/usr/bin/env bash
# tradeoffs_smoke.sh — smoke test of scripts/tradeoffs.py (docs/tradeoffs.md):
# one small case in --quick mode (rough-dielectric albedo_r, RQMC, 3 levels,
# 2 budgets, 100 probes), then checks that the outputs exist and are sane: the
# CSV has every run, the PNG is a PNG of the expected size, the measured error
# falls as nodes are added (at a fixed budget) and the measured time grows with
# the work (cells x samples).  Bad options exit 2.  ~15 s on 2 cores.
# Usage: tradeoffs_smoke.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
SCRIPT="$SRC/scripts/tradeoffs.py"

expect_exit 2 "unknown case" -- "$PY" "$SCRIPT" --brdftab "$BT" --case nosuch --out o
expect_grep "--case matches no case" err.txt "unknown case message"
expect_exit 2 "missing binary" -- "$PY" "$SCRIPT" --brdftab "$WORK/nosuch" --quick --out o
expect_grep "not an executable" err.txt "missing binary message"
expect_exit 2 "zero levels" -- "$PY" "$SCRIPT" --brdftab "$BT" --quick --levels 0 --out o
expect_grep "--levels 0: must be in \[1, 8\]" err.txt "zero levels message"
expect_exit 2 "zero run cap" -- "$PY" "$SCRIPT" --brdftab "$BT" --quick --run-cap 0 --out o
expect_grep "--run-cap 0: must be in \[1, 86400\] seconds" err.txt "run cap message"
expect_exit 2 "zero case cap" -- "$PY" "$SCRIPT" --brdftab "$BT" --quick --case-cap 0 --out o
expect_grep "--case-cap 0: must be in \[1, 86400\] seconds" err.txt "case cap message"
if [ -e o ]; then bad "a refused run created its output folder"; else ok; fi

# Caps out of the way: the checks below need every run.  --case-cap 300: the
# quick run's 15 s cap is wall time, and on a busy machine (load 4-5 on 2 cores)
# it cut half the runs.  --run-cap 60: a run's prediction extrapolates the
# earlier runs, whose times include the first kernel builds (with a cold PoCL
# cache the finest 256-sample level was once predicted at 5.03 s > the quick
# 5 s, and skipped, where it takes about 1 s).
expect_exit 0 "quick run" -- "$PY" "$SCRIPT" --brdftab "$BT" --quick --out out \
  --case rough-dielectric-albedo.albedo_r --levels 3 --budgets 256,4096 --methods rqmc \
  --combos double:float32,double:float16 --probes 100 --case-cap 300 --run-cap 60
for f in results.csv results.json summary.md rough-dielectric-albedo.albedo_r.png; do
  if [ -s "out/$f" ]; then ok; else bad "out/$f missing or empty"; fi
done
expect_grep "^\| rough-dielectric-albedo.albedo_r \| max abs \| 1e-02 \|" out/summary.md "summary row"

if "$PY" - out <<'EOF'; then ok; else bad "results are not sane (see above)"; fi
import csv, json, struct, sys
out = sys.argv[1]
rows = list(csv.DictReader(open(f"{out}/results.csv")))
doc = json.load(open(f"{out}/results.json"))
case = doc["cases"][0]
problems = []
if len(rows) != len(case["runs"]) or len(rows) < 8:
    problems.append(f"{len(rows)} CSV rows, {len(case['runs'])} runs in the JSON (expected >= 8)")
for key in ("date", "machine", "load_before", "load_after", "children_cpu_s", "command"):
    if key not in doc:
        problems.append(f"results.json lacks '{key}'")
# The reference is the quietest method the quantity accepts (RQMC, or quadrature where
# the build has the rough-dielectric albedo quadrature); it must be far quieter than
# the errors measured (>= 1e-2 here).
ref = case["reference"]
if ref["method"] not in ("rqmc", "quadrature") or not 0 <= ref["max_stderr"] < 1e-3:
    problems.append(f"reference: {ref}")
# Error falls with nodes: the double/float32 line at 256 samples, coarsest vs finest level.
line = sorted((int(r["level"]), float(r["linear_max_abs"])) for r in rows
              if r["samples"] == "256" and r["precision"] == "double" and r["type"] == "float32")
if len(line) < 3 or not line[-1][1] < 0.7 * line[0][1]:
    problems.append(f"max abs error does not fall with nodes: {line}")
# Time grows with work: the largest run against the smallest.
work = sorted((int(r["cells"]) * int(r["samples"]), float(r["engine_s"]), float(r["cpu_s"])) for r in rows)
if not (work[-1][1] > work[0][1] and work[-1][2] > work[0][2]):
    problems.append(f"time does not grow with work: smallest {work[0]}, largest {work[-1]}")
for r in rows:
    if not (0 < float(r["linear_max_abs"]) < 1 and float(r["linear_rms_abs"]) <= float(r["linear_max_abs"])):
        problems.append(f"implausible error: {r}")
png = open(f"{out}/rough-dielectric-albedo.albedo_r.png", "rb").read()
if png[:8] != b"\x89PNG\r\n\x1a\n" or struct.unpack(">II", png[16:24]) != (1100, 660):
    problems.append("the figure is not a 1100x660 PNG")
for p in problems:
    print("FAIL:", p)
sys.exit(1 if problems else 0)
EOF
cli_summary
