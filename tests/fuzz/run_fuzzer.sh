#!/usr/bin/env bash
# run_fuzzer.sh FUZZER SECONDS CORPUS ARTIFACTS [SEED_DIR | -flag | --known-crashes-in=LIB]...
# Runs one libFuzzer target for SECONDS ($BRDFTAB_FUZZ_SECONDS overrides) on
# CORPUS (grown in place) plus the seed directories, writing crashing inputs
# to ARTIFACTS/.  Exit status: non-zero on any finding.
#
# --known-crashes-in=LIB: crashes *inside* LIB that are not ours to fix
# (libhdf5 1.10 segfaults and loops on some corrupted files: issue #15,
# defect 10) must not stop the run nor fail it.  The fuzzer then runs in
# fork mode, keeps going after crashes, and every crashing input is replayed
# and classified: a SEGV/BUS signal, a stack overflow, a timeout, a huge
# allocation or a memory error on LIB's own heap whose innermost frame (past
# the sanitizer, libFuzzer, libc and the allocator) lies in LIB is counted as
# known; anything else (any ASan/UBSan memory or UB report, a
# crash in our code, an unexpected exception, a leak) fails the run.
set -uo pipefail
fuzzer=$1 seconds=${BRDFTAB_FUZZ_SECONDS:-$2} corpus=$3 artifacts=$4
shift 4
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$corpus" "$artifacts"
# Leaks inside libraries we do not own (libhdf5's error paths): lsan.supp.
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$here/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
inputs=() flags=() known_lib=""
for a in "$@"; do
  case $a in
    --known-crashes-in=*) known_lib=${a#*=} ;;
    -*) flags+=("$a") ;;
    *) [ -d "$a" ] && inputs+=("$a") ;;
  esac
done
# -timeout: one input taking longer is a hang.  -rss_limit_mb also bounds
# single allocations (libFuzzer's malloc limit), so an input that makes the
# reader allocate gigabytes is a finding too.
common=(-timeout=10 -rss_limit_mb=2048 -artifact_prefix="$artifacts/" "${flags[@]}")
name=$(basename "$fuzzer")
echo "run_fuzzer: $name for ${seconds}s on $corpus ${inputs[*]}"
if [ -z "$known_lib" ]; then
  exec "$fuzzer" -max_total_time="$seconds" -print_final_stats=1 "${common[@]}" \
    "$corpus" "${inputs[@]}"
fi

marker=$(mktemp)
log=$(mktemp)
"$fuzzer" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
  -max_total_time="$seconds" "${common[@]}" "$corpus" "${inputs[@]}" >"$log" 2>&1
rc=$?
grep -E '^#[0-9]+: cov:' "$log" | tail -n 1 | sed "s/^/run_fuzzer: last status: /"
# Frames of the sanitizer and libFuzzer runtimes, libc and the allocator.
runtime='__sanitizer|__asan|__ubsan|__interceptor|fuzzer::|libc\.so|AlarmCallback|CrashCallback| in (malloc|calloc|realloc|free) |operator (new|delete)'
# first_frame TEXT: the innermost stack frame outside the runtime.
first_frame() { grep -E '^ +#[0-9]+ ' <<<"$1" | grep -vE "$runtime" | head -n 1; }
known=0 ours=0 unconfirmed=0 timeouts=0
for f in $(find "$artifacts" -type f -newer "$marker" | sort); do
  # Each hang costs its full timeout to replay: replay the first few only.
  if [[ $(basename "$f") == timeout-* ]]; then
    timeouts=$((timeouts + 1))
    if [ $timeouts -gt 5 ]; then
      echo "run_fuzzer: not replayed (more than 5 timeouts): $f"; unconfirmed=$((unconfirmed + 1)); continue
    fi
  fi
  replay=$(timeout 120 "$fuzzer" -runs=1 -timeout=10 -rss_limit_mb=2048 "$f" 2>&1)
  replay_rc=$?
  if [ $replay_rc -eq 0 ]; then
    # The run process had read earlier inputs first; libhdf5 keeps global
    # state (free lists, caches) that a corrupted file can damage, so a
    # crash that needs that history is reported but does not fail the run.
    echo "run_fuzzer: UNCONFIRMED (passes on replay alone; inspect it): $f"
    unconfirmed=$((unconfirmed + 1))
    continue
  fi
  kind=$(grep -m1 -oE 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer|UndefinedBehaviorSanitizer): [a-zA-Z-]+' <<<"$replay" | sed 's/.*: //')
  # The first report's stack, and for heap errors where the memory came from.
  report=$(awk '/ERROR:/{on=1} on&&/^$/{n++} on&&n<1' <<<"$replay")
  allocated=$(awk '/allocated by thread/{on=1} on&&/^$/{exit} on' <<<"$replay")
  inner=$(first_frame "$report")
  origin=$(first_frame "$allocated")
  is_known=0
  if [[ $inner == *"$known_lib"* ]]; then
    case $kind in
      SEGV|BUS|stack-overflow|timeout|deadly-signal|memcpy-param-overlap|negative-size-param|unknown-crash) is_known=1 ;;
      # Sizes read from the corrupted file (ASan: allocation-size-too-big).
      requested|allocation-size-too-big|out-of-memory) is_known=1 ;;
      # Heap memory libhdf5 allocated, or a wild pointer (no allocation).
      heap-buffer-overflow|heap-use-after-free)
        [[ -z $allocated || $origin == *"$known_lib"* ]] && is_known=1 ;;
    esac
  fi
  if [ $is_known -eq 1 ]; then
    known=$((known + 1))
    echo "run_fuzzer: known, inside $known_lib: $kind: $f"
  else
    ours=$((ours + 1))
    echo "run_fuzzer: FINDING: ${kind:-exit $replay_rc}: $f"
    grep -E 'ERROR:|SUMMARY:|^fuzz:|^ +#[0-9]+ ' <<<"$replay" | head -n 25
  fi
done
rm -f "$marker"
echo "run_fuzzer: $name: $known crash(es) inside $known_lib (known), $unconfirmed unconfirmed, $ours finding(s); fuzzer exit $rc"
if [ $ours -ne 0 ] || { [ $rc -ne 0 ] && [ $known -eq 0 ]; }; then
  tail -n 30 "$log"; rm -f "$log"; exit 1
fi
rm -f "$log"
