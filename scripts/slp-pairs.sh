#!/usr/bin/env bash
# slp-pairs.sh: which lines of a kernel clang's SLP vectoriser packs into
# 2- or 4-wide vectors inside PoCL.  Such packs make PoCL's loop vectoriser
# refuse the work-item loop ("loop not vectorized: instruction return type
# cannot be vectorized"; docs/contributing.md, "What keeps PoCL's work-item
# loop scalar").  Two ways to ask:
#
#   scripts/slp-pairs.sh --pocl [--no-slp] BRDFTAB MODEL QUANTITY [KERNEL_DIR]
#     The real thing: runs `BRDFTAB bench --quick` on that case with PoCL's
#     vectoriser remarks on and debug lines in the program (build option -g),
#     then reads the work-group functions PoCL left in a fresh cache.  Prints
#     the loop vectoriser's verdicts (count, reason) and, for each kernel, the
#     number of 4-wide double instructions (a vectorised work-item loop has
#     thousands) and every source line of 2-wide ones (SLP's packs), by file.
#     The engine turns PoCL's SLP off; this mode turns it back on
#     (-D BT_POCL_SLP=1) to show what it would pack.  With --no-slp it keeps
#     the engine's setting and lists instead, per kernel, the source lines of
#     the loads the loop vectoriser would have to predicate at 4 lanes (masked
#     gathers, which AVX2 lacks: the loop then stays scalar), using LLVM's
#     opt (opt-15 or opt-14) for the target in $POCL_LLVM_CPU_NAME (default:
#     this CPU).  KERNEL_DIR is passed as --kernel-dir (try an edited copy of
#     kernels/ without rebuilding).
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
usage() { sed -n '2,36p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
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

# predicated_loads IR: source lines of the loads in the loop vectoriser's
# pred.load blocks (loads it could only emit as masked gathers), most first.
predicated_loads() {
  python3 - "$1" <<'EOF'
import re
import sys

ll = open(sys.argv[1]).read()
locations = {m.group(1): (int(m.group(2)), m.group(3))
             for m in re.finditer(r'^!(\d+) = !DILocation\(line: (\d+), column: \d+, scope: !(\d+)', ll, re.M)}
blocks = {m.group(1): m.group(2)
          for m in re.finditer(r'^!(\d+) = distinct !DILexicalBlock(?:File)?\(scope: !(\d+)', ll, re.M)}
functions = {m.group(1): (m.group(2), m.group(3))
             for m in re.finditer(r'^!(\d+) = distinct !DISubprogram\(name: "([^"]+)".*?file: !(\d+)', ll, re.M)}
files = {m.group(1): m.group(2) for m in re.finditer(r'^!(\d+) = !DIFile\(filename: "([^"]+)"', ll, re.M)}
count = {}
block = ""
for line in ll.splitlines():
    label = re.match(r'^([\w.]+):', line)
    if label:
        block = label.group(1)
        continue
    if not block.startswith("pred.load.if") or " = load " not in line:
        continue
    m = re.search(r'!dbg !(\d+)', line)
    key = ("(no line)", 0, "?")
    if m and m.group(1) in locations:
        number, scope = locations[m.group(1)]
        while scope in blocks:
            scope = blocks[scope]
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
  shift
  slp="-D BT_POCL_SLP=1"
  if [ "${1:-}" = "--no-slp" ]; then
    slp=""
    shift
    opt=$(command -v opt-15 || command -v opt-14 || true)
    [ -n "$opt" ] || { echo "slp-pairs: --no-slp needs opt-15 or opt-14 (apt-get install llvm-15)" >&2; exit 2; }
  fi
  [ $# -lt 3 ] && usage
  brdftab=$1 model=$2 quantity=$3
  extra=()
  [ $# -ge 4 ] && extra=(--kernel-dir "$4")
  if ! BRDFTAB_KERNEL_OPTIONS="-g $slp" POCL_VECTORIZER_REMARKS=1 POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1 \
      POCL_CACHE_DIR="$work/cache" "$brdftab" bench --quick --no-peak --model "$model" \
      --quantity "$quantity" "${extra[@]}" > "$work/run.log" 2>&1; then
    echo "slp-pairs: the bench run failed:" >&2
    tail -20 "$work/run.log" >&2
    exit 1
  fi
  echo "loop vectoriser (all work-group functions built):"
  grep -o 'loop not vectorized: [a-z ]*\|vectorized loop (vectorization width: [0-9]*\|vectorization is not beneficial' "$work/run.log" \
    | sed 's/loop\(kernels\|generated\)$/loop/' | sort | uniq -c | sed 's/^/  /' || echo "  no remark"
  # Every build of each kernel (one per work-group size; "smallgrid" ones
  # for launches of a single work group).
  find "$work/cache" -name parallel.bc | sort | while read -r bc; do
    kernel=$(basename "$(dirname "$(dirname "$bc")")")
    build=$(basename "$(dirname "$bc")")
    clang-15 -S -emit-llvm -Xclang -disable-llvm-passes -x ir "$bc" -o "$work/k.ll" 2>/dev/null
    wide=$(grep -c '<4 x double>' "$work/k.ll" || true)
    if [ -z "$slp" ]; then
      echo "kernel $kernel ($build): $wide lines with <4 x double>; loads to predicate at 4 lanes by source line:"
      cpu=${POCL_LLVM_CPU_NAME:-native}
      "$opt" -opaque-pointers -mcpu="$cpu" -passes=loop-vectorize -force-vector-width=4 -S "$work/k.ll" \
        -o "$work/kv.ll" 2>/dev/null || "$opt" -mcpu="$cpu" -passes=loop-vectorize \
        -force-vector-width=4 -S "$work/k.ll" -o "$work/kv.ll"
      predicated_loads "$work/kv.ll"
    else
      echo "kernel $kernel ($build): $wide lines with <4 x double>; 2-wide packs by source line:"
      vector_lines "$work/k.ll" "_pocl_kernel_$kernel" 2
    fi
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
