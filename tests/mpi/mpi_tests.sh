#!/usr/bin/env bash
# `mpirun -n N brdftab generate` (issue #17), on this machine with
# --oversubscribe: the file of N = 1, 2, 3, 4 ranks is bit-identical to one
# process (no mpirun) for the same seed; a rank that dies mid-run makes the
# job fail with no output file and a message naming the rank; --resume after
# it continues from the chunks every rank finished and is bit-identical;
# dynamic balancing shows in the cells per rank on a spec whose cells differ
# in cost by orders of magnitude; adaptive tables (docs/adaptive.md) on 1 to
# 3 ranks and resumed on 2 equal one process's.  The oracle is the one-process file,
# compared with same_tables.py (every dataset and attribute bit for bit, the
# timings `created`, `elapsed_seconds` and `certificate_seconds` excepted).
# Usage: mpi_tests.sh BRDFTAB SOURCE_DIR MPIEXEC
set -u
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=../cli_lib.sh
source "$HERE/../cli_lib.sh"
cli_setup "$1" "$2"
MPIEXEC=${3:-mpirun}

if ! { [ -x "$PY" ] && "$PY" -c "import h5py" 2>/dev/null; }; then
  echo "SKIP: $PY with h5py is needed to compare tables"
  exit 0
fi
# Open MPI refuses root unless told (CI runs as root); one PoCL thread per
# rank, as the machine has fewer cores than the ranks started here.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 POCL_MAX_PTHREAD_COUNT=1
# A shared PoCL cache: kernels compile once, not once per rank and run.
mpi() { local n=$1; shift; "$MPIEXEC" --oversubscribe -n "$n" "$@"; }
same_tables() { "$PY" "$HERE/same_tables.py" "$1" "$2"; }

# Adaptive RQMC tables (cells stop at different rounds) and a closed form on
# a 3-D grid (chunks of 5 cells cross its rows): 150 cells.
cat >spec.toml <<'EOF'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 8
[[axes]]
name = "alpha"
range = [0.1, 0.9]
count = 6
[[tables]]
quantity = "albedo_r"
[[tables]]
name = "avg"
quantity = "albedo_avg"
[[tables.axes]]
name = "alpha"
range = [0.1, 0.9]
count = 6
[[tables]]
name = "transmitted"
quantity = "albedo_t"
[[tables]]
name = "brdf"
quantity = "brdf"
[[tables.axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 4
[[tables.axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 4
[[tables.axes]]
name = "alpha"
range = [0.1, 0.9]
count = 3
[integration]
tolerance = 0.0002
max_samples = 65536
seed = 11
EOF

# --- the oracle: one process, no MPI -------------------------------------------
expect_exit 0 "one process" -- "$BT" generate spec.toml -q -o ref.h5
if [ ! -f ref.h5 ]; then cat err.txt; cli_summary; exit 1; fi

# --- N = 1..4 ranks: bit-identical, every rank counted ----------------------------
for n in 1 2 3 4; do
  start=$(date +%s.%N)
  expect_exit 0 "$n rank(s)" -- mpi "$n" "$BT" generate spec.toml -q -o "n$n.h5" --chunk-cells 5
  echo "$n rank(s): $(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')s"
  same_tables ref.h5 "n$n.h5" && ok || bad "$n rank(s): the file differs from one process"
  ranks=$(grep -c "MPI ranks" err.txt)
  [ "$n" -eq 1 ] || [ "$ranks" -eq 1 ] && ok || bad "$n ranks: the banner is printed $ranks times, not once"
  if [ "$n" -gt 1 ]; then
    line=$(grep "cells per rank" out.txt)
    counts=$(echo "$line" | sed 's/ (an even split.*//; s/.*cells per rank://' | tr ',' '\n' |
      awk -F': ' '{ s += $2; k++ } END { print k, s }')
    [ "$counts" = "$n 150" ] && ok || bad "$n ranks: cells per rank '$line' (want $n ranks, 150 cells)"
  fi
done

# --- a rank that dies mid-run: clean failure, then --resume -----------------------
# Rank 1 crashes (SIGABRT) holding its third chunk; rank 0 is terminated by
# mpirun and removes its temporary file.
BRDFTAB_TEST_RANK_ABORT=1:2 mpi 3 -x BRDFTAB_TEST_RANK_ABORT "$BT" generate spec.toml -q \
  -o dead.h5 --chunk-cells 5 >out.txt 2>err.txt
code=$?
[ "$code" -ne 0 ] && ok || bad "a dead rank: exit 0"
[ ! -e dead.h5 ] && ok || bad "a dead rank: an output file was written"
ls dead.h5.tmp-* >/dev/null 2>&1 && bad "a dead rank: a temporary file is left" || ok
expect_grep "rank 1" err.txt "a dead rank: the message names the rank"
stored=$(ls dead.h5.checkpoint/table-*-*.state 2>/dev/null | wc -l)
[ "$stored" -gt 0 ] && ok || bad "a dead rank: no finished chunk in the checkpoint"
echo "dead rank: exit $code, $stored chunk state(s) kept"
expect_exit 0 "resume on 2 ranks" -- mpi 2 "$BT" generate spec.toml -q -o dead.h5 --resume
expect_grep "resuming from .*chunks of tables: [1-9]" err.txt "the resume starts from stored chunks"
same_tables ref.h5 dead.h5 && ok || bad "resumed on 2 ranks: the file differs from one process"
[ ! -e dead.h5.checkpoint ] && ok || bad "the resumed run leaves its checkpoint"

# --- a bad spec: reported once, exit 2 on every rank ------------------------------
sed 's/count = 8/count = 1/' spec.toml >bad.toml
expect_exit 2 "a bad spec on 3 ranks" -- mpi 3 "$BT" generate bad.toml -q -o bad.h5
[ "$(grep -c "error:" err.txt)" -eq 1 ] && ok || bad "a bad spec: reported $(grep -c "error:" err.txt) times"
[ ! -e bad.h5 ] && ok || bad "a bad spec: an output file was written"

# --- dynamic balancing -------------------------------------------------------------
# One chunk of 4 costly cells (RQMC, 2^22 samples each: seconds) and 100
# chunks of 4 cheap closed-form cells (milliseconds each): while one rank
# computes the costly chunk, the other computes most of the cheap ones.
# (method = "rqmc": albedo_r's default is a quadrature of a few milliseconds
# per cell, which would make no chunk costly.)  A static split
# would give 202 cells each; the rank with the costly chunk must end with
# less than half of that.
cat >uneven.toml <<'EOF'
model = "rough-dielectric"
[parameters]
distribution = "ggx"
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 10
[[axes]]
name = "alpha"
range = [0.1, 0.9]
count = 10
[[axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 4
[[tables]]
name = "costly"
quantity = "albedo_r"
[[tables.axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 2
[[tables.axes]]
name = "alpha"
range = [0.1, 0.9]
count = 2
[[tables]]
name = "cheap"
quantity = "brdf"
[integration]
method = "rqmc"
samples = 4194304
seed = 5
EOF
expect_exit 0 "uneven costs on 2 ranks" -- mpi 2 "$BT" generate uneven.toml -q -o uneven.h5 \
  --chunk-cells 4
line=$(grep "cells per rank" out.txt)
echo "uneven costs: $line"
fewest=$(echo "$line" | sed 's/ (an even split.*//; s/.*cells per rank://' | tr ',' '\n' |
  awk -F': ' 'NR == 1 || $2 < m { m = $2 } END { print m }')
[ -n "$fewest" ] && [ "$fewest" -lt 101 ] && ok ||
  bad "uneven costs: the rank with the costly chunk computed $fewest cells (want < 101 of 404)"

# Adaptive tables (docs/adaptive.md, "MPI and --resume"): every rank refines
# the same tree, each round's engine run shared among them; the file of 1, 2
# and 3 ranks equals one process's, and so does one resumed on 2 ranks after
# the test hook stopped a 3-rank run after its third round.
ADAPT=(generate "$DATA/adaptive_inside.toml" --representation adaptive --accuracy 3e-2 --abs -q)
"$BT" "${ADAPT[@]}" -o aref.h5 >/dev/null 2>err.txt || { bad "adaptive, one process: $(cat err.txt)"; }
for n in 1 2 3; do
  expect_exit 0 "adaptive on $n rank(s)" -- mpi "$n" "$BT" "${ADAPT[@]}" -o "a$n.h5"
  same_tables aref.h5 "a$n.h5" && ok || bad "adaptive on $n rank(s): the file differs from one process"
done
BRDFTAB_TEST_ADAPTIVE_STOP=3 mpi 3 "$BT" "${ADAPT[@]}" -o astop.h5 >out.txt 2>err.txt
[ $? -ne 0 ] && ok || bad "adaptive: the stopped run exited 0"
[ ! -e astop.h5 ] && [ -f astop.h5.checkpoint/adaptive-0.log ] && ok ||
  bad "adaptive: the stopped run left an output or no refinement log"
expect_exit 0 "adaptive --resume on 2 ranks" -- mpi 2 "$BT" "${ADAPT[@]/-q/--resume}" -o astop.h5
expect_grep "3 round\(s\) from the checkpoint" err.txt "adaptive resume under MPI replays the logged rounds"
same_tables aref.h5 astop.h5 && ok || bad "adaptive resumed on 2 ranks: the file differs from one process"

cli_summary
