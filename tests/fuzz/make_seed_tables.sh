#!/usr/bin/env bash
# make_seed_tables.sh BRDFTAB SPEC_DIR OUT_DIR
# Writes OUT_DIR/<spec>.h5 for every SPEC_DIR/*.toml with the serial host
# backend (tiny tables: seeds for fuzz_table and the tables fuzz_query looks up).
set -euo pipefail
brdftab=$1 specs=$2 out=$3
mkdir -p "$out"
# The instrumented brdftab's own leaks would fail it here; fuzz targets check leaks.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}
for spec in "$specs"/*.toml; do
  name=$(basename "$spec" .toml)
  "$brdftab" generate "$spec" -o "$out/$name.h5" --device host -q
done
ls -l "$out"
