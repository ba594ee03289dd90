#!/usr/bin/env bash
# slp-pairs.sh: which lines of a kernel clang's SLP vectoriser packs into
# 2- or 4-wide vectors, as it does inside PoCL.  Such packs make PoCL's
# loop vectoriser refuse the work-item loop ("loop not vectorized:
# instruction return type cannot be vectorized"; docs/contributing.md,
# "What keeps PoCL's work-item loop scalar").
#
# Usage:
#   scripts/slp-pairs.sh FLAT.cl [-D NAME=VALUE ...]
# FLAT.cl is the program source PoCL compiled: run brdftab with
# POCL_CACHE_DIR set to an empty folder and POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1,
# and take the tempfile_*.cl it leaves there.  The -D options are the
# engine's (POCL_DEBUG=all prints them: "building program with options").
#
# Prints clang's SLP remarks, then every source line (file, line, function)
# with vector-typed instructions, most first.  No remark means nothing was
# packed.  Needs clang-15 (PoCL 3.1's LLVM) and python3.
#
# Why not plain clang on FLAT.cl: PoCL links its built-ins (fmin, fmax,
# sqrt, fabs, floor, copysign, ...) before its own passes, so they are
# inlined when SLP runs; compiled alone they stay calls and SLP sees fewer
# pairs (an interfaced-lambertian kernel packed by PoCL gave no remark that
# way).  Mapping them to clang's __builtin_ versions reproduces PoCL's packs.
set -euo pipefail
if [ $# -lt 1 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
src=$1
shift
if [ ! -f "$src" ]; then
  echo "slp-pairs: no file '$src'" >&2
  exit 2
fi
command -v clang-15 >/dev/null || { echo "slp-pairs: clang-15 not found (apt-get install clang-15)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
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
python3 - "$work/out.ll" <<'EOF'
import re
import sys

ll = open(sys.argv[1]).read()
locations = {m.group(1): (int(m.group(2)), m.group(3))
             for m in re.finditer(r'^!(\d+) = !DILocation\(line: (\d+), column: \d+, scope: !(\d+)', ll, re.M)}
functions = {m.group(1): (m.group(2), m.group(3))
             for m in re.finditer(r'^!(\d+) = distinct !DISubprogram\(name: "([^"]+)".*?file: !(\d+)', ll, re.M)}
files = {m.group(1): m.group(2) for m in re.finditer(r'^!(\d+) = !DIFile\(filename: "([^"]+)"', ll, re.M)}
count = {}
for line in ll.splitlines():
    if not re.search(r'<(2|4|8|16) x (double|float|i1|i32|i64)>', line):
        continue
    m = re.search(r'!dbg !(\d+)', line)
    if not m or m.group(1) not in locations:
        continue
    number, scope = locations[m.group(1)]
    function, file_id = functions.get(scope, ("?", None))
    key = (files.get(file_id, "?"), number, function)
    count[key] = count.get(key, 0) + 1
for (file, number, function), n in sorted(count.items(), key=lambda kv: -kv[1]):
    print(f"{n:4d}  {file}:{number}  {function}")
if not count:
    print("no vector-typed instructions")
EOF
