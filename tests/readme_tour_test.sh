#!/usr/bin/env bash
# The README's quick tour, run as written, in order, in an empty directory
# that sees only the repository's files (tables/, examples/): what a new user
# on a fresh clone types.  Every command must exit 0, except those whose
# comment says "exit 1 on purpose" (they must exit 1).  `brdftab` is the
# built binary.  About 3 minutes on 2 cores (the albedo preset and the
# Oren-Nayar BRDF preset are generated).
# Usage: readme_tour_test.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
ln -s "$SRC/tables" tables
ln -s "$SRC/examples" examples

# The first ```sh block after "## Quick tour".
awk '/^## Quick tour/ {tour = 1} tour && /^```sh/ {inside = 1; next}
     inside && /^```/ {exit} inside {print}' "$SRC/README.md" > tour.sh
commands=$(grep -cE '^brdftab ' tour.sh)
if [ "$commands" -ge 10 ]; then ok; else bad "only $commands commands found in the README's quick tour"; fi
if grep -vE '^(brdftab |#|$)' tour.sh; then bad "tour lines that are neither commands nor comments (above)"; else ok; fi

while IFS= read -r line; do
  case "$line" in brdftab\ *) ;; *) continue ;; esac
  expected=0
  case "$line" in *"exit 1 on purpose"*) expected=1 ;; esac
  command=${line%%  #*}               # the trailing comment
  start=$(date +%s)
  # shellcheck disable=SC2086
  eval "\"\$BT\" ${command#brdftab }" >out.txt 2>err.txt
  got=$?
  echo "$(( $(date +%s) - start )) s, exit $got: $command"
  if [ "$got" -eq "$expected" ]; then ok; else bad "README tour: '$command' exited $got, expected $expected"; cat err.txt; fi
done < tour.sh

# What the tour says it writes is there.
for f in values.csv albedo.h5 albedo_r.exr albedo_r_all.exr albedo_r.h albedo_r_lut.png oren-nayar.h5 on.binary albedo_r.png; do
  if [ -s "$f" ]; then ok; else bad "the tour did not write $f"; fi
done
cli_summary
