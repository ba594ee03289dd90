#!/usr/bin/env bash
# sanitize.sh — build every target with -fsanitize=address,undefined in
# build-sanitize/ (CMake option BRDFTAB_SANITIZE) and run the unit tests
# there (CTest label `sanitize`).  Any ASan or UBSan report fails the test
# that triggered it.  The device tests run their kernels in PoCL inside the
# test process; tests/fuzz/lsan.supp drops the leaks of PoCL's LLVM from the
# leak report.  Details: docs/contributing.md,
# "Fuzzing and sanitizers".  Environment: BUILD_DIR (default
# build-sanitize), JOBS (parallel compile jobs, default: all cores), CC/CXX
# (default: the system compiler; GCC and clang both work).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD_DIR:-$root/build-sanitize}
jobs=${JOBS:-$(nproc)}

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBRDFTAB_SANITIZE=ON
# The unit test executables only (the CLI and install tests are not run here).
targets=$(ctest --test-dir "$build" -N -L sanitize | sed -n 's/^ *Test *#[0-9]*: sanitize_//p')
# shellcheck disable=SC2086
cmake --build "$build" -j "$jobs" --target $targets
ctest --test-dir "$build" -L sanitize --output-on-failure
