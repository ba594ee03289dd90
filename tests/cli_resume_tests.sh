#!/usr/bin/env bash
# Checkpoint and resume of `brdftab generate`: a run killed with SIGKILL at a
# random moment and continued with --resume writes the same tables, bit for
# bit, as an uninterrupted run; a checkpoint made with other settings is
# refused; a finished run leaves no checkpoint.  The oracle is the file of an
# uninterrupted run, compared through h5py (every dataset byte for byte, every
# attribute except the timings).  Usage: cli_resume_tests.sh BRDFTAB SOURCE_DIR
set -u
# The script may be run from anywhere, with relative paths.
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=cli_lib.sh
source "$HERE/cli_lib.sh"
cli_setup "$1" "$2"

if ! { [ -x "$PY" ] && "$PY" -c "import h5py" 2>/dev/null; }; then
  echo "SKIP: $PY with h5py is needed to compare tables"
  exit 0
fi

# Three adaptive RQMC tables (a few seconds in all): cells stop at different
# rounds, so a kill lands in the first round, in a later one, between tables
# or in the last table.
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
quantity = "albedo_t"
[[tables]]
name = "avg"
quantity = "albedo_avg"
[[tables.axes]]
name = "alpha"
range = [0.1, 0.9]
count = 6
[integration]
tolerance = 0.00005
max_samples = 65536
seed = 11
EOF
# Small launches and a checkpoint every 50 ms, so that kills find states of
# tables in progress.
OPTS=(-q --checkpoint-interval 0.05)
GEN=(generate spec.toml "${OPTS[@]}" --slab 64)

# same_tables A B: every dataset equal byte for byte (dtype, shape, values),
# every attribute equal except the timings (file `created`, table
# `elapsed_seconds`).
cat >same.py <<'EOF'
import sys, h5py, numpy as np
TIMINGS = {"created", "elapsed_seconds"}
a, b = h5py.File(sys.argv[1], "r"), h5py.File(sys.argv[2], "r")
problems = []
def attrs(x, y, where):
    if set(x.attrs) != set(y.attrs):
        problems.append(f"{where}: attribute names differ")
    for k in set(x.attrs) & set(y.attrs):
        if k in TIMINGS:
            continue
        if k in ("DIMENSION_LIST", "REFERENCE_LIST"):
            continue  # object references: compared as dimension scales below
        u, v = np.asarray(x.attrs[k]), np.asarray(y.attrs[k])
        same = u.dtype == v.dtype and u.shape == v.shape and (
            u.tolist() == v.tolist() if u.dtype.kind == "O" else u.tobytes() == v.tobytes())
        if not same:
            problems.append(f"{where}: attribute {k}: {x.attrs[k]!r} != {y.attrs[k]!r}")
def walk(x, y, where):
    attrs(x, y, where)
    if set(x) != set(y):
        problems.append(f"{where}: members {sorted(x)} != {sorted(y)}")
    for k in set(x) & set(y):
        if isinstance(x[k], h5py.Group):
            walk(x[k], y[k], f"{where}{k}/")
        else:
            u, v = x[k][()], y[k][()]
            if u.dtype != v.dtype or u.shape != v.shape or u.tobytes() != v.tobytes():
                problems.append(f"{where}{k}: values differ")
            attrs(x[k], y[k], f"{where}{k}")
            scales = lambda d: [[s.name for s in dim.values()] for dim in d.dims]
            if scales(x[k]) != scales(y[k]):
                problems.append(f"{where}{k}: dimension scales differ")
walk(a, b, "/")
tables = [k for k in a if isinstance(a[k], h5py.Group)]
if len(tables) != 3:
    problems.append(f"expected 3 tables, found {tables}")
for p in problems[:10]:
    print(p)
sys.exit(1 if problems else 0)
EOF
same_tables() { "$PY" same.py "$1" "$2"; }

now() { date +%s.%N; }
seconds_since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

expect_exit 0 "generate --help" -- "$BT" generate --help
expect_grep "--resume" out.txt "generate --help explains --resume"
expect_grep "--checkpoint-interval" out.txt "generate --help explains --checkpoint-interval"

# --- the reference: one uninterrupted run --------------------------------------
start=$(now)
expect_exit 0 "uninterrupted run" -- "$BT" "${GEN[@]}" -o ref.h5
run_seconds=$(seconds_since "$start")
echo "uninterrupted run: ${run_seconds}s"
[ ! -e ref.h5.checkpoint ] && ok || bad "a finished run removes its checkpoint"
ls ref.h5.tmp-* >/dev/null 2>&1 && bad "a finished run leaves temporary files" || ok

# kill_run OUT DELAY: start generate in the background and SIGKILL it after
# DELAY seconds (if it has not finished).
kill_run() {
  "$BT" "${GEN[@]}" -o "$1" >kill.log 2>&1 &
  local pid=$!
  sleep "$2"
  kill -KILL "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
}

# kill_when_stored OUT: start generate in the background and SIGKILL it as
# soon as its checkpoint holds a state file (or when it ends by itself).
kill_when_stored() {
  "$BT" "${GEN[@]}" -o "$1" >kill.log 2>&1 &
  local pid=$!
  while kill -0 "$pid" 2>/dev/null && ! ls "$1".checkpoint/table-*.state >/dev/null 2>&1; do
    sleep 0.02
  done
  kill -KILL "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
}

# What a checkpoint holds: "none", or "<finished> finished + <partial> partial".
# Byte 12 of a state file is its finished flag (host/generate/checkpoint.cpp).
held() {
  local dir=$1.checkpoint finished=0 partial=0 f
  [ -d "$dir" ] || { echo none; return; }
  for f in "$dir"/table-*.state; do
    [ -e "$f" ] || continue
    if [ "$(od -An -tu1 -j12 -N1 "$f" | tr -d ' ')" = 1 ]; then
      finished=$((finished + 1))
    else
      partial=$((partial + 1))
    fi
  done
  echo "$finished finished + $partial partial"
}

# --- a kill before any checkpoint exists ---------------------------------------
rm -f out.h5
kill_run out.h5 0.05
state=$(held out.h5)
case "$state" in none | "0 finished + 0 partial") ok ;; *) bad "early kill already found: $state" ;; esac
expect_exit 0 "resume with no stored state" -- "$BT" "${GEN[@]}" -o out.h5 --resume
same_tables ref.h5 out.h5 && ok || bad "resume after an early kill differs from the reference"
[ ! -e out.h5.checkpoint ] && ok || bad "resume leaves its checkpoint"

# --- settings that change values are refused, others accepted --------------------
rm -f out.h5
kill_when_stored out.h5
if [ -d out.h5.checkpoint ]; then
  expect_exit 2 "resume with another seed" -- "$BT" "${GEN[@]}" -o out.h5 --resume --seed 12
  expect_grep "seed: checkpoint 11, this run 12" err.txt "the refusal names the differing setting"
  sed 's/eta = 1.5/eta = 1.6/' spec.toml >other.toml
  expect_exit 2 "resume with another spec" -- "$BT" generate other.toml -q -o out.h5 --resume
  expect_grep "spec: checkpoint" err.txt "the refusal names the spec"
  [ -d out.h5.checkpoint ] && ok || bad "a refused resume removed the checkpoint"
  # Without --resume: reported and left alone (same bytes); the run starts
  # afresh (a coarse tolerance keeps it short).
  before=$(cat out.h5.checkpoint/* | md5sum)
  expect_exit 0 "run without --resume beside a checkpoint" -- "$BT" "${GEN[@]}" -o out.h5 \
    --tolerance 0.01
  expect_grep "add --resume to continue it" err.txt "an existing checkpoint is reported"
  [ "$(cat out.h5.checkpoint/* | md5sum)" = "$before" ] && ok || bad "the checkpoint was changed"
  # A different --slab does not change values: allowed.
  expect_exit 0 "resume with another slab size" -- "$BT" generate spec.toml "${OPTS[@]}" \
    --slab 7 -o out.h5 --resume
  same_tables ref.h5 out.h5 && ok || bad "resume with another slab size differs"
  [ ! -e out.h5.checkpoint ] && ok || bad "resume leaves its checkpoint"
else
  bad "no checkpoint while the run was going"
fi

# --- a damaged state file is refused (exit 2), not used ------------------------
rm -f out.h5
kill_when_stored out.h5
victim=$(ls out.h5.checkpoint/table-*.state 2>/dev/null | head -1)
if [ -n "$victim" ]; then
  printf '\x55' | dd of="$victim" bs=1 seek=100 conv=notrunc status=none
  expect_exit 2 "resume from a damaged state" -- "$BT" "${GEN[@]}" -o out.h5 --resume
  expect_grep "damaged" err.txt "the message says the checkpoint is damaged"
  rm -rf out.h5.checkpoint
else
  bad "no state file while the run was going"
fi

# --- ten kills at random moments spread over the run, each resumed -------------
# Kill k falls in the k-th tenth of the first 90 % of the run (the run may
# be faster than the reference was), at a random point within it.
rm -f out.h5
from_partial=0
from_finished=0
for k in 0 1 2 3 4 5 6 7 8 9; do
  delay=$(awk -v t="$run_seconds" -v k="$k" -v r="$RANDOM" \
    'BEGIN { printf "%.2f", 0.9 * t * (k + r / 32768) / 10 }')
  rm -rf out.h5 out.h5.checkpoint
  kill_run out.h5 "$delay"
  state=$(held out.h5)
  case "$state" in *" 0 partial" | none) ;; *) from_partial=$((from_partial + 1)) ;; esac
  case "$state" in none | "0 finished"*) ;; *) from_finished=$((from_finished + 1)) ;; esac
  start=$(now)
  if "$BT" "${GEN[@]}" -o out.h5 --resume >out.txt 2>err.txt; then ok; else bad "resume $k failed"; cat err.txt; fi
  echo "kill $k after ${delay}s (checkpoint: $state), resumed in $(seconds_since "$start")s"
  same_tables ref.h5 out.h5 && ok || bad "kill $k after ${delay}s ($state): resumed output differs"
  [ ! -e out.h5.checkpoint ] && ok || bad "resume $k leaves its checkpoint"
done
ls out.h5.tmp-* >/dev/null 2>&1 && bad "temporary files left behind" || ok
echo "resumed from a table in progress $from_partial time(s), with finished tables $from_finished time(s)"
[ $((from_partial + from_finished)) -gt 0 ] && ok || bad "no kill found a checkpoint to resume from"

cli_summary
