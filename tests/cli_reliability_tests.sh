#!/usr/bin/env bash
# Reliability of the CLI under hostile conditions: a damaged two-table file
# whose first table fails cleanly and whose second crashes libhdf5; a write
# that fails (file size limit, a full tmpfs where one can be mounted); an
# hfunction characteristic function without an H-function; out-of-range
# --seed; two runs writing one output at once; and the statement of
# `brdftab models` about Phong albedos above 1, checked against evaluation.
# Usage: cli_reliability_tests.sh BRDFTAB SOURCE_DIR
set -u
# The script may be run from anywhere, with relative paths.
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=cli_lib.sh
source "$HERE/cli_lib.sh"
cli_setup "$1" "$2"
SMALL="$WORK/small"  # a tmpfs mount point, when the machine lets us mount one
trap 'mountpoint -q "$SMALL" 2>/dev/null && umount "$SMALL"; rm -rf "$WORK"' EXIT

if ! { [ -x "$PY" ] && "$PY" -c "import h5py" 2>/dev/null; }; then
  echo "SKIP: $PY with h5py is needed to build the damaged file and compare tables"
  exit 0
fi

# expect_refused DESCRIPTION PATTERN -- command...: exit 2 and PATTERN in stderr.
expect_refused() {
  local what=$1 pattern=$2
  shift 3
  expect_exit 2 "$what" -- "$@"
  expect_grep "$pattern" err.txt "$what: message"
}

# --- 1. a damaged two-table file: one table fails cleanly, one crashes ------
# Two closed-form tables, brdf and btdf (read in that order).  In the global
# heap that holds the string attributes, the object of brdf's `axes` gets an
# index no object has (brdf then fails cleanly: its axes are not JSON), and
# the length of the object of btdf's `device` grows by 0x47 << 24 bytes
# (libhdf5 1.10 then dies with SIGSEGV in H5HG_read while reading btdf).
sed -e 's/^model = .*/model = "rough-dielectric"/' "$DATA/rough_dielectric_brdf_btdf.toml" >two.toml
printf '[output]\npath = "two.h5"\n' >>two.toml
expect_exit 0 "generate two.h5" -- "$BT" generate two.toml -q
cat >damage.py <<'EOF'
import sys
import h5py
source, target, which = sys.argv[1], sys.argv[2], sys.argv[3]
with h5py.File(source, "r") as f:
    first, second = sorted(f.keys())
    first_axes = f[first].attrs["axes"].encode()
    second_device = f[second].attrs["device"].encode()
b = bytearray(open(source, "rb").read())
heap = b.find(b"GCOL")
assert heap >= 0, "no global heap"
size = int.from_bytes(b[heap + 8:heap + 16], "little")
objects = []  # (offset of the object's header, its data)
at = heap + 16
while at + 16 <= heap + size:
    index = int.from_bytes(b[at:at + 2], "little")
    length = int.from_bytes(b[at + 8:at + 16], "little")
    if index == 0:  # the free space
        break
    objects.append((at, bytes(b[at + 16:at + 16 + length])))
    at += 16 + (length + 7) // 8 * 8
axes = [o for o, data in objects if data == first_axes]
device = [o for o, data in objects if data == second_device]
assert axes and len(device) == 2, (len(axes), len(device))
b[axes[0]:axes[0] + 2] = (0xFF).to_bytes(2, "little")  # an index no object has
if which == "both":
    b[device[1] + 11] = 0x47  # byte 3 of the 8-byte length
open(target, "wb").write(b)
EOF
"$PY" damage.py two.h5 damaged.h5 both && ok || bad "could not damage two.h5"
"$PY" damage.py two.h5 one_bad.h5 axes && ok || bad "could not damage two.h5 (axes only)"
# The file is hostile: read without the guard, libhdf5 crashes on btdf.
(
  BRDFTAB_READ_TIMEOUT=0 "$BT" query damaged.h5 --table btdf theta_i=30 theta_o=140 >/dev/null
  echo $? >rc.txt
) 2>/dev/null  # also the shell's report of the crash
rc=$(cat rc.txt)
[ "$rc" -gt 128 ] && ok ||
  bad "damaged.h5 no longer crashes libhdf5 unguarded (exit $rc): the test's file needs rebuilding"
for cmd in "query damaged.h5 --table btdf theta_i=30 theta_o=140" \
  "query damaged.h5 --table btdf theta_i=30 theta_o=140 --cubic" \
  "validate damaged.h5 --table btdf --points 2" \
  "export damaged.h5 --table btdf --exr d.exr" \
  "plot damaged.h5 --table btdf --slice theta_i=30 -o d.png" \
  "info damaged.h5"; do
  # shellcheck disable=SC2086
  BRDFTAB_READ_TIMEOUT=20 expect_refused "damaged two tables: $cmd" "'damaged.h5'" -- \
    timeout 120 "$BT" $cmd
done
[ ! -e d.exr ] && [ ! -e d.png ] && ok || bad "damaged two tables: an output was written"
# One table fails cleanly, the other is intact: the file is refused whole
# (the other table would be read unguarded).
expect_refused "one bad table: query of the intact one" "table 'brdf'.*refused whole" -- \
  "$BT" query one_bad.h5 --table btdf theta_i=30 theta_o=140
expect_exit 0 "intact two.h5: query" -- "$BT" query two.h5 --table btdf theta_i=30 theta_o=140

# --- 2. a write that fails: exit 1, no crash, output intact, resume ---------
# 1600-cell albedo tables on the host backend (no OpenCL kernel cache to
# write); a state file is about 110 KB, the output about 90 KB.
sed -e 's/^path = .*/path = "big.h5"/' -e 's/count = [35]$/count = 40/' \
  "$DATA/rough_dielectric_albedo.toml" >big.toml
GEN=(generate big.toml -q --device host --samples 64)
expect_exit 0 "generate the previous output" -- "$BT" "${GEN[@]}"
cp big.h5 big.previous
expect_exit 0 "generate the reference (seed 9)" -- "$BT" "${GEN[@]}" --seed 9 -o fresh.h5
# Under `ulimit -f` a write past the limit fails with EFBIG (SIGXFSZ
# ignored), in the output's temporary file or in the checkpoint.
for kib in 4 8 12 16 20 24; do
  rm -rf big.h5.checkpoint
  (
    trap '' XFSZ
    ulimit -f "$kib"
    exec "$BT" "${GEN[@]}" --seed 9 >out.txt 2>err.txt
  )
  rc=$?
  [ "$rc" -eq 1 ] && ok || { bad "ulimit -f $kib: exit $rc, expected 1"; cat err.txt; }
  expect_grep "error: (cannot write|HDF5)" err.txt "ulimit -f $kib: the write error is reported"
  cmp -s big.h5 big.previous && ok || bad "ulimit -f $kib: the previous output changed"
  ls big.h5.tmp-* >/dev/null 2>&1 && bad "ulimit -f $kib: a temporary file is left" || ok
done
# The last failed run left its checkpoint; --resume completes the same tables.
expect_exit 0 "resume after the failed write" -- "$BT" "${GEN[@]}" --seed 9 --resume
"$PY" - big.h5 fresh.h5 <<'EOF' && ok || bad "resumed tables differ from an uninterrupted run"
import sys
import h5py
import numpy as np
with h5py.File(sys.argv[1], "r") as a, h5py.File(sys.argv[2], "r") as b:
    assert sorted(a) == sorted(b)
    for t in a:
        for d in ("value", "stderr"):
            assert np.array_equal(a[t][d][...], b[t][d][...]), (t, d)
EOF
# A full file system, where this machine lets us mount a 2 MiB tmpfs (root
# outside most containers): free space between the size check's estimate and
# what the run needs makes the output's or the checkpoint's write fail.
mkdir -p "$SMALL"
if mount -t tmpfs -o size=2m tmpfs "$SMALL" 2>/dev/null; then
  full=0
  for kb in $(seq 1700 10 1900); do
    rm -rf "${SMALL:?}"/*
    head -c "${kb}000" /dev/zero >"$SMALL/fill" 2>/dev/null
    "$BT" "${GEN[@]}" -o "$SMALL/out.h5" >out.txt 2>err.txt
    rc=$?
    case $rc in
      0 | 2) ok ;;  # it fitted, or the size check refused it up front
      1) ok; full=$((full + 1)) ;;
      *) bad "tmpfs with $kb kB used: exit $rc"; cat err.txt ;;
    esac
    ls "$SMALL"/out.h5.tmp-* >/dev/null 2>&1 && bad "tmpfs with $kb kB used: a temporary file is left" || ok
  done
  [ "$full" -gt 0 ] && ok || bad "no run on the tmpfs ran out of space (adjust the sweep)"
  echo "tmpfs: $full of 21 runs ran out of space, each with exit 1"
  # The disk fills while a checkpoint is written (larger budgets, a state
  # every 0.2 s); once space is freed, --resume completes the same tables.
  SLOW_GEN=(generate big.toml -q --device host --samples 4096 --checkpoint-interval 0.2)
  expect_exit 0 "generate the reference (4096 samples)" -- "$BT" "${SLOW_GEN[@]}" -o fresh4096.h5
  rm -rf "${SMALL:?}"/*
  head -c 1780000 /dev/zero >"$SMALL/fill"
  expect_exit 1 "tmpfs full while checkpointing" -- "$BT" "${SLOW_GEN[@]}" -o "$SMALL/out.h5"
  expect_grep "cannot write" err.txt "tmpfs full while checkpointing: the write error is reported"
  rm -f "$SMALL/fill"
  expect_exit 0 "resume on the tmpfs once space is freed" -- "$BT" "${SLOW_GEN[@]}" \
    -o "$SMALL/out.h5" --resume
  "$PY" - "$SMALL/out.h5" fresh4096.h5 <<'PYEOF' && ok || bad "tmpfs: resumed tables differ"
import sys
import h5py
import numpy as np
with h5py.File(sys.argv[1], "r") as a, h5py.File(sys.argv[2], "r") as b:
    for t in b:
        for d in ("value", "stderr"):
            assert np.array_equal(a[t][d][...], b[t][d][...]), (t, d)
PYEOF
  umount "$SMALL"
else
  echo "skipped: a tmpfs cannot be mounted here (the ulimit checks above still ran)"
fi

# --- 3. hfunction: a characteristic function without an H-function ---------
for q in "H mu=0.5" "moment n=1" "H_inf"; do
  # shellcheck disable=SC2086
  expect_refused "hfunction $q, psi_0 = 0.6" "psi_0 = 0.6.*allowed: at most 1" -- \
    "$BT" eval hfunction $q psi=poly psi_0=0.6
  grep -qiE "nan|inf" out.txt && bad "hfunction $q, psi_0 = 0.6: printed a value" || ok
done
# psi_0 = 0.5 is the limit: conservative isotropic scattering, whose
# H(0.5) = 2.0128 (Chandrasekhar, Radiative Transfer, table of H for
# albedo 1).
expect_exit 0 "hfunction H, psi_0 = 0.5" -- "$BT" eval hfunction H psi=poly psi_0=0.5 mu=0.5
"$PY" - out.txt <<'EOF' && ok || bad "hfunction H(0.5) at psi_0 = 0.5 is not 2.0128"
import re, sys
v = float(re.search(r"H = ([0-9.eE+-]+)", open(sys.argv[1]).read()).group(1))
assert abs(v - 2.0128) < 1e-4, v
EOF
# Psi1-like coefficients, negative on [0, 1], keep their H-function.
expect_exit 0 "hfunction H, negative Psi" -- "$BT" eval hfunction H psi=poly psi_0=-0.3 \
  psi_1=0.6 psi_2=-0.3 mu=0.5
cat >hf.toml <<'EOF'
model = "hfunction"
[parameters]
psi = "poly"
mu = 0.5
[[axes]]
name = "psi_0"
range = [0.4, 0.6]
count = 3
[[tables]]
quantity = "H"
[output]
path = "hf.h5"
EOF
expect_refused "generate hfunction across psi_0 = 0.5" "psi_0 = 0.6.*allowed: at most 1" -- \
  "$BT" generate hf.toml -q
[ ! -e hf.h5 ] && ok || bad "generate hfunction across psi_0 = 0.5 wrote hf.h5"

# --- 4. --seed out of range: refused, never clamped -------------------------
EVAL_MC=(eval rough-dielectric albedo_r theta_i=30 alpha=0.5 eta=1.5 --method mc --samples 64)
for s in -1 18446744073709551616 99999999999999999999999 abc 1e3 ""; do
  expect_refused "eval --seed '$s'" "--seed '$s' .*allowed: integers in \[0, 18446744073709551615\]" -- \
    "$BT" "${EVAL_MC[@]}" --seed "$s"
done
expect_refused "generate --seed -1" "--seed '-1' is out of range" -- \
  "$BT" generate big.toml -q --device host --samples 64 --seed -1 -o seed.h5
[ ! -e seed.h5 ] && ok || bad "generate --seed -1 wrote seed.h5"
expect_refused "validate --seed -1" "--seed '-1' is out of range" -- \
  "$BT" validate big.h5 --table albedo_r --points 2 --seed -1
expect_exit 0 "generate --seed 2^64 - 1" -- "$BT" generate big.toml -q --device host \
  --samples 64 --seed 18446744073709551615 -o seed.h5
"$PY" - seed.h5 <<'EOF' && ok || bad "--seed 18446744073709551615 is not the stored seed"
import sys
import h5py
with h5py.File(sys.argv[1], "r") as f:
    assert int(f["albedo_r"].attrs["seed"]) == 2**64 - 1, f["albedo_r"].attrs["seed"]
EOF

# --- 5. two writers of one output --------------------------------------------
SLOW=(generate big.toml -q --device host --samples 4096)
rm -f busy.h5
"$BT" "${SLOW[@]}" -o busy.h5 >first_out.txt 2>first_err.txt &
first=$!
for _ in $(seq 1 200); do [ -e busy.h5.lock ] && break; sleep 0.05; done
[ -e busy.h5.lock ] && ok || bad "the first writer holds no busy.h5.lock"
expect_refused "second generate of busy.h5" \
  "output 'busy.h5' is being written by another running brdftab \(process $first\)" -- \
  "$BT" "${GEN[@]}" -o busy.h5
expect_refused "second generate of busy.h5, --resume" "being written by another" -- \
  "$BT" "${GEN[@]}" -o busy.h5 --resume
wait "$first"
rc=$?
[ "$rc" -eq 0 ] && ok || { bad "the first writer: exit $rc"; cat first_err.txt; }
[ ! -e busy.h5.lock ] && ok || bad "busy.h5.lock left after the run"
expect_exit 0 "info of the first writer's file" -- "$BT" info busy.h5
"$PY" - busy.h5 <<'EOF' && ok || bad "busy.h5 is not the first writer's (4096 samples)"
import sys
import h5py
with h5py.File(sys.argv[1], "r") as f:
    assert int(f["albedo_r"].attrs["samples_requested"]) == 4096
EOF
# A writer killed with SIGKILL leaves its lock file; the next run takes it.
"$BT" "${SLOW[@]}" -o killed.h5 >/dev/null 2>&1 &
victim=$!
for _ in $(seq 1 200); do [ -e killed.h5.lock ] && break; sleep 0.05; done
kill -9 "$victim"
wait "$victim" 2>/dev/null
[ -e killed.h5.lock ] && ok || bad "the killed writer left no lock file (test premise)"
expect_exit 0 "run after a killed writer" -- "$BT" "${GEN[@]}" -o killed.h5
[ ! -e killed.h5.lock ] && ok || bad "killed.h5.lock left after the next run"
# export and scene take the same lock (held here by flock(1), which locks
# as brdftab does; -o: flock itself holds it, not the sleep).
flock -o out.exr.lock sleep 30 &
holder=$!
for _ in $(seq 1 100); do [ -e out.exr.lock ] && break; sleep 0.05; done
expect_refused "export while out.exr is locked" "output 'out.exr' is being written by another" -- \
  "$BT" export two.h5 --table brdf --exr out.exr
[ ! -e out.exr ] && ok || bad "export wrote out.exr while it was locked"
kill "$holder"
wait "$holder" 2>/dev/null
expect_exit 0 "export after the lock is released" -- "$BT" export two.h5 --table brdf --exr out.exr
[ ! -e out.exr.lock ] && ok || bad "out.exr.lock left after export"
flock -o scene.tables.h5.lock sleep 30 &
holder=$!
for _ in $(seq 1 100); do [ -e scene.tables.h5.lock ] && break; sleep 0.05; done
expect_refused "scene while its output is locked" "output 'scene.tables.h5' is being written" -- \
  timeout 120 "$BT" scene "$DATA/scenes/materials.toml" -o scene.tables.h5 --no-plan --device host
kill "$holder"
wait "$holder" 2>/dev/null

# --- 6. Phong albedos above 1: stated by `brdftab models`, and true ----------
expect_exit 0 "models" -- "$BT" models
cp out.txt models.txt
expect_grep "phong does not conserve energy" models.txt "models states Phong's albedos above 1"
# Every "<quantity> ... up to V (alpha = A, eta = E, theta_i = T)" and the
# "(V at alpha = A, theta_i = T)" point at eta = 1 are evaluated: the value
# printed by eval rounds to the stated one, and Beckmann and GGX (g1 =
# smith) stay within 1 at the same points.
"$PY" - "$BT" models.txt <<'EOF' && ok || bad "models' Phong figures do not match evaluation"
import re, subprocess, sys
bt, text = sys.argv[1], open(sys.argv[2]).read()
line = next(l for l in text.splitlines() if "phong does not conserve energy" in l)
def value(quantity, theta, alpha, eta, distribution):
    q = ["albedo_r", "albedo_t"] if quantity == "albedo_r + albedo_t" else [quantity]
    total = 0.0
    for name in q:
        out = subprocess.run([bt, "eval", "rough-dielectric", name, f"theta_i={theta}",
                              f"alpha={alpha}", f"eta={eta}", f"distribution={distribution}"],
                             capture_output=True, text=True, check=True).stdout
        total += float(re.search(r"= ([0-9.eE+-]+)", out).group(1))
    return total
claims = []
for m in re.finditer(r"(albedo_r \+ albedo_t|albedo_r|albedo_t) exceeds 1.*?up to ([0-9.]+)"
                     r"(?: at eta = ([0-9.]+))? \(alpha = ([0-9.]+), (?:eta = ([0-9.]+), )?"
                     r"theta_i = ([0-9.]+)\)", line):
    quantity, stated, eta1, alpha, eta2, theta = m.groups()
    claims.append((quantity, stated, alpha, eta1 or eta2, theta))
m = re.search(r"at eta = 1 for every alpha \(([0-9.]+) at alpha = ([0-9.]+), theta_i = ([0-9.]+)\)",
              line)
claims.append(("albedo_t", m.group(1), m.group(2), "1", m.group(3)))
assert len(claims) == 4, claims
for quantity, stated, alpha, eta, theta in claims:
    v = value(quantity, theta, alpha, eta, "phong")
    digits = len(stated.split(".")[1])
    assert round(v, digits) == float(stated) and v > 1, (quantity, stated, v)
    for other in ("beckmann", "ggx"):
        w = value(quantity, theta, alpha, eta, other)
        assert w <= 1 + 1e-9, (quantity, other, w)
    print(f"{quantity} at alpha={alpha} eta={eta} theta_i={theta}: {v:.5f} (stated {stated})")
EOF

cli_summary
