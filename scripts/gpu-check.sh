#!/usr/bin/env bash
# gpu-check.sh — check brdftab on every OpenCL GPU of this machine.
#
#   scripts/gpu-check.sh [BUILD_DIR] [--quick]
#
# Lists the OpenCL devices; for every GPU among them runs the device-vs-host
# test subset (test_engine, test_specialisation, test_model_registry) with
# BRDFTAB_DEVICE set to it, then `brdftab bench --json` on it, and prints one
# table per GPU (rates and ratios against the serial and threaded host
# paths).  A GPU without cl_khr_fp64 is benchmarked with --precision float.
# With no GPU it says so and exits 0.  BUILD_DIR (default: build) must hold
# a configured build with brdftab and the test binaries built.
set -u
build=build
quick=
for a in "$@"; do
    case "$a" in
        --quick) quick=--quick ;;
        -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
        *) build=$a ;;
    esac
done
bin=$build/brdftab
if [[ ! -x $bin ]]; then
    echo "gpu-check: $bin not found; build first: cmake --build $build --target brdftab" >&2
    exit 2
fi
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$build/pocl-cache}
mkdir -p "$POCL_CACHE_DIR"
python=python3
[[ -x /usr/bin/python3 ]] && python=/usr/bin/python3

listing=$("$bin" devices 2>&1) || { echo "$listing"; echo "gpu-check: no OpenCL device at all"; exit 0; }
echo "$listing"
echo
# "[N] name" followed by "    type: GPU, ..." -> N<TAB>fp64<TAB>name
gpus=$(printf '%s\n' "$listing" | awk '
    /^\[[0-9]+\] / { idx = substr($1, 2, length($1) - 2); name = substr($0, length($1) + 2); next }
    /^ *type: GPU/ { fp64 = ($0 ~ /fp64: yes/) ? "yes" : "no"; printf "%s\t%s\t%s\n", idx, fp64, name }')
if [[ -z $gpus ]]; then
    echo "gpu-check: no OpenCL GPU found on this machine; nothing to check (no GPU figures measured)."
    exit 0
fi

status=0
while IFS=$'\t' read -r idx fp64 name; do
    echo "=== GPU [$idx] $name (fp64: $fp64) ==="
    precision=double
    [[ $fp64 == yes ]] || precision=float
    if [[ -f $build/CTestTestfile.cmake ]]; then
        if BRDFTAB_DEVICE=$idx ctest --test-dir "$build" --output-on-failure \
               -R '^(test_engine|test_specialisation|test_model_registry)$'; then
            tests=passed
        else
            tests=FAILED
            status=1
        fi
    else
        tests="not run (no CTest files in $build)"
    fi
    json=$(mktemp)
    if "$bin" bench --json $quick --device "$idx" --precision "$precision" >"$json"; then
        "$python" - "$json" "$name" "$precision" "$tests" <<'EOF'
import json, sys
report = json.load(open(sys.argv[1]))
name, precision, tests = sys.argv[2:5]
m = report["machine"]
print(f"device-vs-host tests: {tests}")
print(f"device: {name} ({precision}); peak double FMA: {m['peak_fma_gflops']:.1f} GFLOP/s"
      if m["peak_fma_gflops"] else f"device: {name} ({precision}); peak FMA not measured")
print(f"{'model':22} {'quantity':9} {'unit':8} {'device':>12} {'host':>12} {'threads':>12} "
      f"{'dev/host':>9} {'dev/thr':>9}")
for c in report["cases"]:
    print(f"{c['model']:22} {c['quantity']:9} {c['unit']:8} {c['device']['rate']:12.4g} "
          f"{c['host']['rate']:12.4g} {c['host_threads']['rate']:12.4g} "
          f"{c['device_over_host']:8.2f}x {c['device_over_threads']:8.2f}x")
EOF
    else
        echo "gpu-check: brdftab bench failed on device [$idx]"
        status=1
    fi
    rm -f "$json"
    echo
done <<<"$gpus"
exit $status
