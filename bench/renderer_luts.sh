#!/usr/bin/env bash
# renderer_luts.sh — times the renderer LUT presets (docs/renderer-luts.md):
# the whole Cycles set (target < 60 s on 2 cores) and Filament's 128 x 128 DFG
# texture (target < 10 s), the UE4 split-sum LUT, and prints each table's largest error estimate.
# Usage: bench/renderer_luts.sh BRDFTAB [SOURCE_DIR]
set -eu
BT=$(realpath "$1")
SRC=$(realpath "${2:-$(dirname "$0")/..}")
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
for preset in cycles filament-dfg ue4-splitsum; do
  start=$(date +%s.%N)
  "$BT" generate "$SRC/tables/renderers/$preset.toml" -o "$WORK/$preset.h5" >"$WORK/log.txt" 2>&1
  end=$(date +%s.%N)
  printf '%s: %.1f s wall\n' "$preset" "$(echo "$end - $start" | bc)"
  grep -E '^  [a-z_A-Z]+: ' "$WORK/log.txt" | sed -E 's/^  ([^:]+):.*max stderr ([^ ]+) absolute.*, ([0-9.]+m?[0-9.]*s)$/  \1: largest estimate \2, \3/'
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
