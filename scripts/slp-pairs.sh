#!/usr/bin/env bash
# slp-pairs.sh: which lines of a kernel clang's SLP vectoriser packs into
# 2- or 4-wide vectors inside PoCL.  Such packs make PoCL's loop vectoriser
# refuse the work-item loop ("loop not vectorized: instruction return type
# cannot be vectorized"; docs/contributing.md, "What keeps PoCL's work-item
# loop scalar").  Two ways to ask:
#
#   scripts/slp-pairs.sh --pocl BRDFTAB MODEL QUANTITY [KERNEL_DIR]
#     The real thing: runs `BRDFTAB bench --quick` on that case with PoCL's
#     vectoriser remarks on and debug lines in the program (build option -g),
#     then reads the work-group functions PoCL left in a fresh cache.  Prints
#     the loop vectoriser's verdicts (count, reason) and, for each kernel, the
#     number of 4-wide double instructions (a vectorised work-item loop has
#     thousands) and every source line of 2-wide ones (SLP's packs), by file.
#     KERNEL_DIR is passed as --kernel-dir (try an edited copy of kernels/
#     without rebuilding).
#
#   scripts/slp-pairs.sh FLAT.cl [-D NAME=VALUE ...]
#     A quick look with clang-15 alone: FLAT.cl is the program source PoCL
#     compiled (run brdftab with POCL_CACHE_DIR set to an empty folder and
#     POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1 and take the tempfile_*.cl it
#     leaves; POCL_DEBUG=all prints the engine's -D options).  Compiles it at
#     -O2 for skylake-avx512 as PoCL's first round does, with PoCL's
#     built-ins (fmin, fmax, sqrt, ...) mapped to clang's, which PoCL has
#     inlined by the time its own SLP runs.  Prints clang's SLP remarks, then
#     the source lines of vector-typed instructions.  It sees only the first
#     of PoCL's two optimisation rounds: micrograin's g_dist came out clean
#     here and still had 2-wide packs in PoCL, so confirm with
#     --pocl.
#
# Needs clang-15 (PoCL 3.1's LLVM) and python3.
set -euo pipefail
usage() { sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
[ $# -lt 1 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ] && usage
command -v clang-15 >/dev/null || { echo "slp-pairs: clang-15 not found (apt-get install clang-15)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# vector_lines IR [FUNCTION_PREFIX] [WIDTH]: source lines of vector-typed
# instructions (all widths, or only WIDTH-wide), most first.
vector_lines() {
  python3 - "$@" <<'EOF'
import re
import sys

ll = open(sys.argv[1]).read()
prefix = sys.argv[2] if len(sys.argv) > 2 else ""
width = sys.argv[3] if len(sys.argv) > 3 else r"2|4|8|16"
locations = {m.group(1): (int(m.group(2)), m.group(3))
             for m in re.finditer(r'^!(\d+) = !DILocation\(line: (\d+), column: \d+, scope: !(\d+)', ll, re.M)}
functions = {m.group(1): (m.group(2), m.group(3))
             for m in re.finditer(r'^!(\d+) = distinct !DISubprogram\(name: "([^"]+)".*?file: !(\d+)', ll, re.M)}
files = {m.group(1): m.group(2) for m in re.finditer(r'^!(\d+) = !DIFile\(filename: "([^"]+)"', ll, re.M)}
vector = re.compile(r'<(%s) x (double|float|i1|i8|i16|i32|i64)>' % width)
count = {}
current = None
for line in ll.splitlines():
    if line.startswith('define'):
        current = line.split('@', 1)[1].split('(', 1)[0]
    if line.startswith(('@', 'declare')) or current is None or not current.startswith(prefix):
        continue
    if line == '}':
        current = None
        continue
    if not vector.search(line):
        continue
    m = re.search(r'!dbg !(\d+)', line)
    key = ("(no line)", 0, "?")
    if m and m.group(1) in locations:
        number, scope = locations[m.group(1)]
        function, file_id = functions.get(scope, ("?", None))
        key = (files.get(file_id, "?"), number, function)
    count[key] = count.get(key, 0) + 1
for (file, number, function), n in sorted(count.items(), key=lambda kv: -kv[1]):
    print(f"{n:6d}  {file}:{number}  {function}")
if not count:
    print("       none")
EOF
}

if [ "$1" = "--pocl" ]; then
  [ $# -lt 4 ] && usage
  brdftab=$2 model=$3 quantity=$4
  extra=()
  [ $# -ge 5 ] && extra=(--kernel-dir "$5")
  if ! BRDFTAB_KERNEL_OPTIONS="-g" POCL_VECTORIZER_REMARKS=1 POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1 \
      POCL_CACHE_DIR="$work/cache" "$brdftab" bench --quick --no-peak --model "$model" \
      --quantity "$quantity" "${extra[@]}" > "$work/run.log" 2>&1; then
    echo "slp-pairs: the bench run failed:" >&2
    tail -20 "$work/run.log" >&2
    exit 1
  fi
  echo "loop vectoriser (all work-group functions built):"
  grep -o 'loop not vectorized: [a-z ]*\|vectorized loop (vectorization width: [0-9]*' "$work/run.log" \
    | sed 's/loop\(kernels\|generated\)$/loop/' | sort | uniq -c | sed 's/^/  /' || echo "  no remark"
  find "$work/cache" -name parallel.bc | grep -v smallgrid | sort | while read -r bc; do
    kernel=$(basename "$(dirname "$(dirname "$bc")")")
    clang-15 -S -emit-llvm -Xclang -disable-llvm-passes -x ir "$bc" -o "$work/k.ll" 2>/dev/null
    wide=$(grep -c '<4 x double>' "$work/k.ll" || true)
    echo "kernel $kernel: $wide lines with <4 x double>; 2-wide packs by source line:"
    vector_lines "$work/k.ll" "_pocl_kernel_$kernel" 2
  done
  exit 0
fi

src=$1
shift
if [ ! -f "$src" ]; then
  echo "slp-pairs: no file '$src'" >&2
  exit 2
fi
cat > "$work/builtins.h" <<'EOF'
#define fmax(a, b) __builtin_fmax((a), (b))
#define fmin(a, b) __builtin_fmin((a), (b))
#define sqrt(a) __builtin_sqrt(a)
#define fabs(a) __builtin_fabs(a)
#define floor(a) __builtin_floor(a)
#define copysign(a, b) __builtin_copysign((a), (b))
#define trunc(a) __builtin_trunc(a)
#define rint(a) __builtin_rint(a)
EOF
clang-15 -x cl -cl-std=CL1.2 -Xclang -finclude-default-header -include "$work/builtins.h" \
  -march=skylake-avx512 -O2 -gline-tables-only -Dinline= "$@" -Rpass=slp-vectorizer \
  -S -emit-llvm "$src" -o "$work/out.ll" 2>&1 | grep 'remark:' | sed 's/.*remark: /remark: /' || true
vector_lines "$work/out.ll"
