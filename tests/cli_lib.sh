# cli_lib.sh — shared helpers of the end-to-end CLI test scripts (sourced).
# Each check adds to `passed` or `failed`; the script ends with cli_summary,
# which prints "N passed, M failed" and sets the exit status.
passed=0
failed=0

# cli_setup BRDFTAB SOURCE_DIR: the common start of every CLI test script.
# Sets BT (the binary), SRC (the source tree), DATA (tests/data), WORK (a
# scratch directory, removed on exit, made the current directory), PY (the
# Debian python3, which has h5py and numpy) and a PoCL cache directory.
cli_setup() {
  BT=$(realpath "$1")
  SRC=$(realpath "$2")
  DATA="$SRC/tests/data"
  WORK=$(mktemp -d)
  trap 'rm -rf "$WORK"' EXIT
  cd "$WORK" || exit 1
  export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$WORK/pocl-cache}"
  PY=/usr/bin/python3
}
ok() { passed=$((passed + 1)); }
bad() { failed=$((failed + 1)); echo "FAIL: $*"; }

# expect_exit CODE DESCRIPTION -- command...   (stdout -> out.txt, stderr -> err.txt)
expect_exit() {
  local code=$1 what=$2
  shift 3
  "$@" >out.txt 2>err.txt
  local got=$?
  if [ "$got" -eq "$code" ]; then ok; else bad "$what: exit $got, expected $code"; cat err.txt; fi
}

# expect_grep PATTERN FILE DESCRIPTION
expect_grep() {
  if grep -qE -- "$1" "$2"; then ok; else bad "$3: '$1' not in $2:"; cat "$2"; fi
}

cli_summary() {
  echo "$passed passed, $failed failed"
  [ "$failed" -eq 0 ]
}
