#!/usr/bin/env bash
# cli_progress_tests.sh BRDFTAB SOURCE_DIR — progress output in a log (stderr
# not a terminal): lines come from within a table's first round, each with
# cells done, samples/s, elapsed time and an ETA, and the last says 100 %.
# BRDFTAB_PROGRESS_INTERVAL shortens the 30 s log interval so a small run
# prints several lines; nothing here depends on how fast the machine is
# beyond "the run takes more than one launch".
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"

# 80 x 125 = 10000 cells: the engine's launches start at 256 work items and
# grow at most 4x per launch, so the only round of this table takes at least
# four launches (256 + 1024 + 4096 + 4624), each reported.
cat >progress.toml <<'TOML'
model = "rough-dielectric"
[parameters]
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 85.0]
count = 80
[[axes]]
name = "alpha"
range = [0.05, 0.9]
count = 125
[[tables]]
quantity = "albedo_r"
[integration]
method = "mc"
samples = 64
seed = 3
[output]
path = "progress.h5"
TOML

BRDFTAB_PROGRESS_INTERVAL=0.001 expect_exit 0 "generate with progress" -- "$BT" generate progress.toml
line='^\[1/1\] [^ ]+ +[0-9.]+%  cells [0-9]+/10000  [0-9.]+[kMG]? samples/s  elapsed [0-9.hms]+'
n=$(grep -cE "$line  ETA [0-9.hms]+$" err.txt)
if [ "$n" -ge 2 ]; then ok; else bad "expected >= 2 progress lines with ETA, got $n:"; cat err.txt; fi
# Progress within the round: some line reports part of the cells done.
if grep -E "$line" err.txt | grep -qvE "cells (0|10000)/10000"; then ok
else bad "no progress line with 0 < cells done < 10000:"; cat err.txt; fi
expect_grep "100\.0%  cells 10000/10000" err.txt "the last progress line reports completion"
# No ETA on the final line.
if tail -n 1 err.txt | grep -q "ETA"; then bad "final line carries an ETA"; cat err.txt; else ok; fi

# The default log interval (30 s): a short run prints only the final line.
expect_exit 0 "generate, default interval" -- "$BT" generate progress.toml -o p2.h5
n=$(grep -cE "cells [0-9]+/10000" err.txt)
if [ "$n" -le 2 ]; then ok; else bad "default interval printed $n lines for a short run"; cat err.txt; fi
# --quiet prints none.
expect_exit 0 "generate --quiet" -- "$BT" generate progress.toml -o p3.h5 --quiet
n=$(grep -cE "cells [0-9]+/10000" err.txt)
if [ "$n" -eq 0 ]; then ok; else bad "--quiet printed progress"; cat err.txt; fi
cli_summary
