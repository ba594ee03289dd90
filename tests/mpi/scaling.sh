#!/usr/bin/env bash
# Strong scaling of `mpirun -n N brdftab generate` on one machine, and the
# cost of a chunk (docs/benchmarks.md, "Distributed generation (MPI)").
# Usage: tests/mpi/scaling.sh BRDFTAB [REPEATS]   (BRDFTAB: an MPI build)
# Each rank gets one core's worth of PoCL (POCL_MAX_PTHREAD_COUNT=1), and
# ranks are not bound to cores (--bind-to none): on a shared machine a rank
# bound to a busy core would get a fraction of it.  Prints
# one line per run and the medians; the machine may be shared: compare
# medians of repeated runs, and note the load average printed with them.
set -u
BT=$(realpath "$1")
REPEATS=${2:-3}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cd "$WORK" || exit 1
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 POCL_MAX_PTHREAD_COUNT=1
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$WORK/pocl-cache}
# "WALL CPU": seconds of the command and CPU seconds of it and its children.
seconds() { /usr/bin/time -f "%e %U %S" -o time.txt "$@" >run.txt 2>&1 || { cat run.txt; exit 1; }
  awk '{ printf "%.2f %.2f", $1, $2 + $3 }' time.txt; }
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

# A slice of the Lambert-sphere BRDF: the exact (random-walk) table alone,
# 6 x 6 x 3 x 6 = 648 cells of 1024 walks each.
cat >slice.toml <<'SPEC'
model = "lambert-sphere"
[[axes]]
name = "theta_i"
spacing = "explicit"
values = [0.0, 20.0, 40.0, 60.0, 75.0, 85.0]
[[axes]]
name = "theta_o"
spacing = "explicit"
values = [0.0, 20.0, 40.0, 60.0, 75.0, 85.0]
[[axes]]
name = "phi_d"
range = [0.0, 180.0]
count = 3
[[axes]]
name = "c"
spacing = "explicit"
values = [0.3, 0.6, 0.8, 0.9, 0.95, 0.99]
[[tables]]
name = "brdf_mc"
quantity = "brdf_mc"
[tables.parameters]
order = 0
max_order = 1000
phase_mc = "exact"
[integration]
samples = 1024
seed = 1
SPEC
# Cheap cells: a closed form, 65536 cells, to time the chunks themselves.
cat >cheap.toml <<'SPEC'
model = "rough-dielectric"
[parameters]
eta = 1.5
alpha = 0.3
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 256
[[axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 256
[[tables]]
quantity = "brdf"
SPEC
"$BT" generate slice.toml -q -o warm.h5 --samples 16 >/dev/null 2>&1  # compile the kernels once
"$BT" generate cheap.toml -q -o warm.h5 >/dev/null 2>&1

echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq "$REPEATS"); do
  t1=$(seconds "$BT" generate slice.toml -q -o one.h5)
  echo "slice, 1 process (no MPI): wall, CPU ${t1}" | tee -a one.txt
  t2=$(seconds mpirun --oversubscribe --bind-to none -n 2 "$BT" generate slice.toml -q -o two.h5)
  echo "slice, 2 ranks: wall, CPU ${t2}; $(grep 'cells per rank' run.txt | sed 's/^ *//')" | tee -a two.txt
  grep "rank 0 received" run.txt | sed 's/^ */  /'
  c0=$(seconds "$BT" generate cheap.toml -q -o c0.h5)
  c1=$(seconds "$BT" generate cheap.toml -q -o c1.h5 --chunk-cells 4)
  c2=$(seconds mpirun --oversubscribe --bind-to none -n 2 "$BT" generate cheap.toml -q -o c2.h5 --chunk-cells 4)
  echo "cheap, 1 process: 1 chunk ${c0% *}s, 16384 chunks of 4 cells ${c1% *}s; 2 ranks: ${c2% *}s" | tee -a cheap.txt
  grep "rank 0 received" run.txt | sed 's/^ */  /'
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
m1=$(sed 's/.*CPU \([0-9.]*\) .*/\1/' one.txt | median)
m2=$(sed 's/.*CPU \([0-9.]*\) .*/\1/' two.txt | median)
u1=$(sed 's/.*CPU [0-9.]* \([0-9.]*\).*/\1/' one.txt | median)
u2=$(sed 's/.*CPU [0-9.]* \([0-9.]*\).*/\1/' two.txt | median)
mc0=$(sed 's/.*1 chunk \([0-9.]*\)s.*/\1/' cheap.txt | median)
mc1=$(sed 's/.*cells \([0-9.]*\)s;.*/\1/' cheap.txt | median)
mc2=$(sed 's/.*2 ranks: \([0-9.]*\)s.*/\1/' cheap.txt | median)
awk -v a="$m1" -v b="$m2" -v u="$u1" -v v="$u2" -v c0="$mc0" -v c1="$mc1" -v c2="$mc2" 'BEGIN {
  printf "median of %s: slice 1 process %.2fs (CPU %.2fs), 2 ranks %.2fs (CPU %.2fs), speed-up %.2f\n", "'"$REPEATS"'", a, u, b, v, a / b
  printf "median: cheap table 1 chunk %.2fs, 16384 chunks %.2fs (%.3f ms per chunk), 2 ranks %.2fs\n", c0, c1, 1000 * (c1 - c0) / 16383, c2 }'
