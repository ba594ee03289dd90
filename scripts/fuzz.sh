#!/usr/bin/env bash
# fuzz.sh [SECONDS] — build the libFuzzer targets with clang, ASan and UBSan
# in build-fuzz/ and run each for SECONDS (default 60) on its corpus:
#   fuzz_spec   the TOML spec parser
#   fuzz_table  the HDF5 table reader (and the lookup built on what it read)
#   fuzz_query  `query`'s name=value coordinates and their lookup in a table
# Fails if any target finds a crash, leak, undefined behaviour, hang or
# unexpected exception; the input is then in build-fuzz/tests/fuzz/artifacts/.
# Needs clang (scripts/setup.sh --fuzz).  Details: docs/contributing.md,
# "Fuzzing and sanitizers".  Environment: BUILD_DIR (default build-fuzz),
# JOBS (parallel compile jobs, default: all cores), CC/CXX (default clang).
set -euo pipefail
seconds=${1:-60}
case $seconds in ''|*[!0-9]*) echo "usage: $0 [SECONDS]" >&2; exit 2 ;; esac
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build-fuzz}
jobs=${JOBS:-$(nproc)}

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER="${CC:-clang}" -DCMAKE_CXX_COMPILER="${CXX:-clang++}" \
  -DBRDFTAB_FUZZ=ON -DBRDFTAB_FUZZ_SECONDS="$seconds"
# Only what the fuzz tests run: the three targets and brdftab (seed tables).
cmake --build "$build" -j "$jobs" --target fuzz_spec fuzz_table fuzz_query brdftab
ctest --test-dir "$build" -L fuzz --output-on-failure
