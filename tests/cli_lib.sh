# cli_lib.sh — shared helpers of the end-to-end CLI test scripts (sourced).
# Each check adds to `passed` or `failed`; the script ends with cli_summary,
# which prints "N passed, M failed" and sets the exit status.
passed=0
failed=0
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
