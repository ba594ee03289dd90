#!/usr/bin/env bash
# CTest driver of the Python tests: run_pytest.sh PYTHON BUILD_DIR CLI TEST_FILE...
# Runs pytest with PYTHON on the module built into BUILD_DIR/python.  Exits
# 77 (CTest: skipped) with a message when PYTHON lacks pytest, or, for the
# Mitsuba tests, mitsuba (scripts/setup.sh --mitsuba makes that venv).
set -euo pipefail
python=$1 build=$2 cli=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
if [ ! -x "$python" ]; then
  echo "SKIPPED: no Python at $python (for the mitsuba tests: bash scripts/setup.sh --mitsuba)"
  exit 77
fi
if [[ " $* " == *"mitsuba"* || " $* " == *" test_rgl.py "* ]]; then
  llvm=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM-19.so}
  if ! "$python" -c "import mitsuba" 2>/dev/null; then
    echo "SKIPPED: $python cannot import mitsuba (bash scripts/setup.sh --mitsuba)"
    exit 77
  fi
  if [ ! -e "$llvm" ]; then
    echo "SKIPPED: $llvm is missing: Mitsuba's llvm_* variants need LLVM 19 (apt-get install libllvm19)"
    exit 77
  fi
  export DRJIT_LIBLLVM_PATH=$llvm
fi
if ! "$python" -c "import pytest" 2>/dev/null; then
  echo "SKIPPED: $python has no pytest (Debian: apt-get install python3-pytest)"
  exit 77
fi
export PYTHONPATH="$build/python${PYTHONPATH:+:$PYTHONPATH}"
export BRDFTAB_CLI=$cli
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$build/pocl-cache}
cd "$here"
exec "$python" -m pytest -q -p no:cacheprovider "$@"
