#!/usr/bin/env bash
# bit_rounding_presets.sh — stored size of a preset with rounded storage
# (docs/spec.md "Rounded storage") against raw float32 and against the
# preset as it is, with the certificates of both.
#
# Usage: bench/bit_rounding_presets.sh BRDFTAB PRESET.toml MEASURE INTERP TABLE=E... [-- WORKDIR]
#   MEASURE  relative | absolute (round_measure, and the certificates' measure)
#   INTERP   linear | cubic (the certificates' interpolation)
#   TABLE=E  round table TABLE for accuracy E (its round_to_accuracy) and
#            certify it against E; `*=E` rounds every table of the spec for E
#            ([output] round_to_accuracy) and certifies the tables named too
# Prints per table the certificates of the plain and the rounded file and the
# kept bits, then for the file: raw float32 bytes (value, and stderr where
# kept: 4 bytes per cell), the plain file, the rounded file and the ratios.
set -u
BT=$(realpath "$1"); PRESET=$(realpath "$2"); MEASURE=$3; INTERP=$4
shift 4
pairs=()
WORK=""
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then WORK=$2; break; fi
  pairs+=("$1"); shift
done
[ -n "$WORK" ] || WORK=$(mktemp -d)
mkdir -p "$WORK" && cd "$WORK" || exit 1
name=$(basename "$PRESET" .toml)
# The preset with the rounding keys: after the `name = "T"` line of each
# [[tables]] entry named, and round_measure (and `*`'s accuracy) in [output].
/usr/bin/python3 - "$PRESET" "$MEASURE" "${pairs[@]}" > "$name-rounded.toml" <<'PY'
import re, sys
text = open(sys.argv[1]).read().splitlines()
measure = sys.argv[2]
acc = dict(p.split("=", 1) for p in sys.argv[3:])
out, in_tables, in_output, done_output = [], False, False, False
for line in text:
    out.append(line)
    s = line.strip()
    if s.startswith("["):
        in_tables = s == "[[tables]]"
        in_output = s == "[output]"
        if in_output:
            out.append(f'round_measure = "{measure}"')
            if "*" in acc:
                out.append(f"round_to_accuracy = {acc['*']}")
            done_output = True
    m = re.match(r'name\s*=\s*"([^"]+)"', s)
    if in_tables and m and m.group(1) in acc:
        out.append(f"round_to_accuracy = {acc[m.group(1)]}")
if not done_output:
    out += ["", "[output]", f'round_measure = "{measure}"'] + ([f"round_to_accuracy = {acc['*']}"] if "*" in acc else [])
print("\n".join(out))
PY
for variant in plain rounded; do
  spec=$PRESET; [ $variant = rounded ] && spec=$name-rounded.toml
  start=$(date +%s.%N)
  "$BT" generate "$spec" -o "$name-$variant.h5" -q > /dev/null || { echo "generate $variant failed"; exit 1; }
  echo "$name $variant: generated in $(echo "$(date +%s.%N) - $start" | bc) s"
done
/usr/bin/python3 - "$BT" "$name" "$MEASURE" "$INTERP" "${pairs[@]}" <<'PY'
import h5py, os, subprocess, sys
bt, name, measure, interp = sys.argv[1:5]
acc = dict(p.split("=", 1) for p in sys.argv[5:])
extra = ["--abs"] if measure == "absolute" else []
raw = 0
for variant in ("plain", "rounded"):
    path = f"{name}-{variant}.h5"
    with h5py.File(path, "r") as f:
        tables = sorted(f)
        if variant == "plain":
            raw = sum(f[t]["value"].size * 4 * (2 if "stderr" in f[t] else 1) for t in tables)
        for t in tables:
            a = f[t].attrs
            E = acc.get(t)
            info = f"keep_bits {a.get('keep_bits', '-')} (rounded for {a.get('rounding_accuracy', '-')}), {a['stored_type']}"
            if E is None:
                print(f"  {variant:7s} {t}: {info}, not certified here")
                continue
            r = subprocess.run([bt, "certify", path, "--table", t, "--accuracy", E, "--interpolation", interp] + extra,
                               capture_output=True, text=True)
            line = (r.stdout.strip().splitlines() or ["?"])[-1]
            print(f"  {variant:7s} {t}: {info}: {line.split(': ', 1)[-1]}")
size = {v: os.path.getsize(f"{name}-{v}.h5") for v in ("plain", "rounded")}
# The value and stderr datasets alone, as stored (without the file's
# metadata: axes, attributes, the spec text of every table).
data = {}
for v in ("plain", "rounded"):
    with h5py.File(f"{name}-{v}.h5", "r") as f:
        data[v] = sum(f[t][d].id.get_storage_size() for t in f for d in ("value", "stderr") if d in f[t])
print(f"{name}: value+stderr datasets as stored: plain {data['plain']} B ({raw / data['plain']:.2f}x smaller than raw), "
      f"rounded {data['rounded']} B ({raw / data['rounded']:.2f}x smaller than raw)")
print(f"{name}: raw float32 {raw} B, plain file {size['plain']} B ({raw / size['plain']:.2f}x smaller than raw), "
      f"rounded file {size['rounded']} B ({raw / size['rounded']:.2f}x smaller than raw, "
      f"{size['plain'] / size['rounded']:.2f}x smaller than plain)")
PY
