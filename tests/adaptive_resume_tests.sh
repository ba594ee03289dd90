#!/usr/bin/env bash
# Checkpoint and --resume of `generate --representation adaptive`
# (docs/adaptive.md, "MPI and --resume"): a run stopped after refinement
# round K by the test hook BRDFTAB_TEST_ADAPTIVE_STOP=K (exit 1, no output,
# the checkpoint kept) and resumed gives a file bit-identical to an
# uninterrupted run's (tests/mpi/same_tables.py: every dataset and attribute,
# timings excepted), whether it stopped inside the first table or inside the
# second; the resumed run replays the logged rounds without the engine.  A
# resume with another accuracy is refused naming the setting, a damaged log
# is refused, without --resume an old checkpoint is left alone, and an
# input error removes the checkpoint its run made.
# About a minute of CPU.  Usage: adaptive_resume_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
if ! "$PY" -c "import h5py, numpy" 2>/dev/null; then
  echo "SKIP: $PY lacks h5py or numpy"
  exit 77
fi
same_tables() { "$PY" "$SRC/tests/mpi/same_tables.py" "$1" "$2"; }

# Two tables: the small inside spec and its reflectance.
sed 's/^\[integration\]/[[tables]]\nname = "albedo_r_inside"\nquantity = "albedo_r"\n[integration]/' \
  "$DATA/adaptive_inside.toml" > two.toml
BASE=(generate two.toml --representation adaptive --accuracy 3e-2 --abs)
GEN=("${BASE[@]}" -q)

"$BT" "${GEN[@]}" -o ref.h5 > ref.out 2> ref.err
if [ $? -eq 0 ] && [ -f ref.h5 ]; then ok; else bad "uninterrupted run failed: $(cat ref.err)"; fi
[ ! -e ref.h5.checkpoint ] && ok || bad "a finished run left its checkpoint"

# Rounds of the first table, from the uninterrupted run's own log lines.
first_rounds=$("$BT" "${BASE[@]}" -o count.h5 2>&1 | grep -c "albedo_t_inside: round")
[ "$first_rounds" -ge 3 ] && ok || bad "the first table refines in $first_rounds rounds; the test needs 3 or more"

for k in 2 $((first_rounds + 2)); do
  rm -rf out.h5 out.h5.checkpoint
  BRDFTAB_TEST_ADAPTIVE_STOP=$k "$BT" "${GEN[@]}" -o out.h5 > stop.out 2> stop.err
  code=$?
  [ "$code" -eq 1 ] && ok || bad "stop after round $k: exit $code, expected 1"
  expect_grep "stopped after $k stored refinement round" stop.err "stop after round $k"
  [ ! -e out.h5 ] && ok || bad "stop after round $k left an output file"
  [ -f out.h5.checkpoint/adaptive-0.log ] && ok || bad "stop after round $k: no refinement log"
  "$BT" "${GEN[@]}" -o out.h5 --resume > res.out 2> res.err
  code=$?
  [ "$code" -eq 0 ] && ok || { bad "resume after round $k: exit $code"; cat res.err; }
  expect_grep "resuming from .*out.h5.checkpoint" res.err "resume after round $k"
  same_tables ref.h5 out.h5 && ok || bad "resume after round $k: the file differs from an uninterrupted run's"
  [ ! -e out.h5.checkpoint ] && ok || bad "resume after round $k left the checkpoint"
done
# Stopped inside the second table, the first is replayed whole.
rm -rf out.h5 out.h5.checkpoint
BRDFTAB_TEST_ADAPTIVE_STOP=$((first_rounds + 1)) "$BT" "${GEN[@]}" -o out.h5 > /dev/null 2>&1
"$BT" "${BASE[@]}" -o out.h5 --resume > res.out 2> res.err
expect_grep "albedo_t_inside: .*$first_rounds round\(s\) from the checkpoint" res.err "first table replayed"
expect_grep "albedo_r_inside: .*1 round\(s\) from the checkpoint" res.err "second table's logged round replayed"
same_tables ref.h5 out.h5 && ok || bad "resume inside the second table: the file differs"

# Another accuracy: refused (exit 2), naming the adaptive settings; the
# checkpoint stays.
rm -rf out.h5 out.h5.checkpoint
BRDFTAB_TEST_ADAPTIVE_STOP=2 "$BT" "${GEN[@]}" -o out.h5 > /dev/null 2>&1
expect_exit 2 "resume with another accuracy" -- "$BT" generate two.toml --representation adaptive --accuracy 2e-2 \
  --abs -q -o out.h5 --resume
expect_grep "adaptive: checkpoint accuracy 0.03" err.txt "the differing setting is named"
[ -d out.h5.checkpoint ] && ok || bad "a refused resume removed the checkpoint"
# Without --resume: a warning, a full run, the checkpoint left alone.
"$BT" "${GEN[@]}" -o out.h5 > plain.out 2> plain.err
expect_grep "add --resume to continue it" plain.err "an old checkpoint without --resume"
same_tables ref.h5 out.h5 && ok || bad "a run beside an old checkpoint differs"
[ -f out.h5.checkpoint/adaptive-0.log ] && ok || bad "a run without --resume touched the old checkpoint"
# An input error after the checkpoint was made removes the one this run made.
expect_exit 2 "a breakpoint on no axis" -- "$BT" "${GEN[@]}" -o bad.h5 --breakpoint nope=1
[ ! -e bad.h5.checkpoint ] && ok || bad "an input error left the checkpoint this run made"
# A damaged log: refused, naming it.
rm -f out.h5
"$PY" - <<'PY'
p = "out.h5.checkpoint/adaptive-0.log"
b = bytearray(open(p, "rb").read())
b[len(b) // 2] ^= 0x40
open(p, "wb").write(bytes(b))
PY
expect_exit 2 "resume from a damaged log" -- "$BT" "${GEN[@]}" -o out.h5 --resume
expect_grep "refinement of table 'albedo_t_inside' is damaged" err.txt "damaged log"
[ ! -e out.h5 ] && ok || bad "a refused resume wrote an output file"
cli_summary
