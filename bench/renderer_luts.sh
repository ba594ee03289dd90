#!/usr/bin/env bash
# renderer_luts.sh — times the renderer LUT presets (docs/renderer-luts.md):
# the whole Cycles set generated and certified in Cycles' interpolation
# (target < 60 s on 2 cores), Filament's 128 x 128 DFG texture (target < 10 s)
# and the UE4 split-sum LUT, and prints each table's largest error estimate
# and its certificate in the renderer's interpolation.  Times are wall and
# CPU (user + system) seconds; other jobs on the machine inflate the wall time.
# Usage: bench/renderer_luts.sh BRDFTAB [SOURCE_DIR]
# (prints the load average before and after: report it with the times)
set -eu
BT=$(realpath "$1")
SRC=$(realpath "${2:-$(dirname "$0")/..}")
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
timed() {  # timed LABEL COMMAND...: runs it, prints LABEL: wall, CPU
  /usr/bin/time -f "%e %U %S" -o "$WORK/time.txt" "${@:2}" >"$WORK/log.txt" 2>&1
  read -r wall user sys <"$WORK/time.txt"
  printf '%s: %.1f s wall, %.1f s CPU\n' "$1" "$wall" "$(echo "$user + $sys" | bc)"
}
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
add_cpu() {  # adds the last timed command to the preset's totals
  total_cpu=$(echo "$total_cpu + $(awk '{print $2 + $3}' "$WORK/time.txt")" | bc)
  total_wall=$(echo "$total_wall + $(awk '{print $1}' "$WORK/time.txt")" | bc)
}
declare -A layout=([cycles]=cycles [filament-dfg]=filament [ue4-splitsum]=ue4)
# The certificate's direct values, per group of tables (TABLES:NODES; "all":
# every table): quadrature nodes whose own error (reported) stays far below
# the interpolation error it measures: 8 for the F = 1 tables and the
# textures, 6 for the Cycles glass tables (their interpolation errors are
# 3e-3 to 0.17; the direct values' estimates at 6 nodes <= 6.4e-5).
declare -A certify_groups=(
  [cycles]="ggx_E,ggx_Eavg:8 ggx_glass_E,ggx_glass_Eavg,ggx_glass_inv_E,ggx_glass_inv_Eavg:6"
  [filament-dfg]="all:8" [ue4-splitsum]="all:8")
for preset in cycles filament-dfg ue4-splitsum; do
  total_cpu=0 total_wall=0
  timed "$preset generate" "$BT" generate "$SRC/tables/renderers/$preset.toml" -o "$WORK/$preset.h5"
  add_cpu
  grep -E '^  [a-z_A-Z]+: ' "$WORK/log.txt" | sed -E 's/^  ([^:]+):.*max error estimate[^0-9]*([0-9.e+-]+) absolute.*, ([0-9.]+m?[0-9.]*s)$/  \1: largest estimate \2, \3/'
  all=$("$BT" info "$WORK/$preset.h5" | sed -nE "s/^  table '([a-zA-Z_0-9]+)'.*/\1/p" | paste -sd, -)
  for group in ${certify_groups[$preset]}; do
    tables=${group%:*} nodes=${group##*:}
    [ "$tables" = all ] && tables=$all
    timed "$preset certify --layout ${layout[$preset]} ($tables, direct values at $nodes nodes)" \
      "$BT" certify "$WORK/$preset.h5" --table "$tables" --layout "${layout[$preset]}" \
      --reference-nodes "$nodes" --store -q
    add_cpu
    sed -nE 's/.* table ([a-zA-Z_0-9]+) in .*interpolation: (max [^;]*); (RMS [^;]*)(; [0-9]+ nodes[^;]*)?;.*direct values. ([0-9.e+-]+),.*/  \1: \2, \3\4; direct values'"'"' estimate \5/p' "$WORK/log.txt"
  done
  printf '%s total: %.1f s wall, %.1f s CPU\n' "$preset" "$total_wall" "$total_cpu"
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
