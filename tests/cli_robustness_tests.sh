#!/usr/bin/env bash
# End-to-end robustness of the commands that read table files (issue 15):
# hostile or damaged files are refused with exit code 2 and a message naming
# the file and the object, never a crash, a hang or a silently different
# answer; an empty output path is an error; validate caps the work a file
# asks for.  Hostile files are crafted with h5py (a writer that shares no
# code with brdftab) and by flipping or zeroing bytes.
# Usage: cli_robustness_tests.sh BRDFTAB SOURCE_DIR
set -u
# The script may be run from anywhere, with relative paths.
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=cli_lib.sh
source "$HERE/cli_lib.sh"
cli_setup "$1" "$2"

# expect_refused DESCRIPTION PATTERN -- command...: exit 2 and PATTERN in stderr.
expect_refused() {
  local what=$1 pattern=$2
  shift 3
  expect_exit 2 "$what" -- "$@"
  expect_grep "$pattern" err.txt "$what: message"
}

# A closed-form table (5 x 5 x 5 cells) and an integral one (albedo, rqmc).
sed -e 's/^path = .*/path = "t.h5"/' "$DATA/rough_dielectric_brdf.toml" >t.toml
sed -e 's/^path = .*/path = "alb.h5"/' "$DATA/rough_dielectric_albedo.toml" >alb.toml
expect_exit 0 "generate t.h5" -- "$BT" generate t.toml -q
expect_exit 0 "generate alb.h5" -- "$BT" generate alb.toml -q
Q=(query --table brdf theta_i=10 theta_o=20 phi_d=30)
expect_exit 0 "query of the intact file" -- "$BT" "${Q[0]}" t.h5 "${Q[@]:1}"
cp out.txt query_intact.txt

# h5py_edit FILE PYTHON: copy t.h5 to FILE and run PYTHON with `f` open r+.
h5py_edit() {
  cp t.h5 "$1"
  "$PY" - "$1" "$2" <<'PYEOF'
import sys
import h5py
import numpy as np
with h5py.File(sys.argv[1], "r+") as f:
    exec(sys.argv[2])
PYEOF
}

# --- 1. numeric attributes stored as arrays (was a stack buffer overflow) ---
h5py_edit fmt.h5 'f.attrs["brdftab_format"] = np.ones(64, "i8")'
expect_refused "array brdftab_format" "'fmt.h5'.*attribute 'brdftab_format'.*64 elements" -- \
  "$BT" info fmt.h5
h5py_edit seed.h5 'f["brdf"].attrs["seed"] = np.array([1, 2], "u8")'
expect_refused "2-element seed" "'seed.h5'.*object '/brdf'.*attribute 'seed'" -- \
  "$BT" "${Q[0]}" seed.h5 "${Q[@]:1}"
h5py_edit min.h5 'f["brdf/theta_i"].attrs["min"] = np.zeros(3)'
expect_refused "array axis min" "object '/brdf/theta_i'.*attribute 'min'" -- "$BT" info min.h5
h5py_edit floor.h5 'f["brdf"].attrs["abs_floor"] = np.zeros(2)'
expect_refused "array abs_floor" "attribute 'abs_floor'" -- "$BT" info floor.h5

# --- 2. cell-count overflow: 4 axes x 65 536 nodes = 2^64 cells -------------
"$PY" - <<'PYEOF'
import h5py
import numpy as np
with h5py.File("huge.h5", "w") as f:
    f.attrs["brdftab_format"] = np.int32(1)
    g = f.create_group("brdf")
    for n in ("theta_i", "theta_o", "phi_d", "alpha"):
        g.create_dataset(n, data=np.arange(65536.0))
    g.attrs["axes"] = '["theta_i", "theta_o", "phi_d", "alpha"]'
    # The value dataset has the axes' shape; never written, so the file is small.
    g.create_dataset("value", shape=(65536,) * 4, dtype="f8", chunks=(1, 1, 1, 65536))
PYEOF
for cmd in "info huge.h5" "query huge.h5 --table brdf theta_i=1 theta_o=1 phi_d=1 alpha=1" \
  "plot huge.h5 --table brdf --slice theta_i=1 --slice theta_o=1 --slice phi_d=1 -o h.png"; do
  # shellcheck disable=SC2086
  expect_refused "overflow: $cmd" "65536 x 65536 x 65536 x 65536" -- "$BT" $cmd
done
# Shape of value differs from the axes' lengths.
h5py_edit shape.h5 'del f["brdf/value"]; f["brdf"].create_dataset("value", data=np.zeros((5, 5, 4), "f4"))'
expect_refused "value shape" "'shape.h5', table 'brdf'.*'value' shape does not match" -- \
  "$BT" info shape.h5

# --- 3. an axis with 0 nodes (export crashed) -------------------------------
h5py_edit empty.h5 'del f["brdf/phi_d"]; f["brdf"].create_dataset("phi_d", data=np.zeros(0))'
expect_refused "0-node axis: export" "axis 'phi_d'.*at least 2" -- \
  "$BT" export empty.h5 --table brdf --slice theta_i=0 --exr e.exr
[ ! -e e.exr ] && ok || bad "0-node axis: export wrote e.exr"

# --- 11. min/max attributes edited away from the node list -----------------
h5py_edit tamper.h5 'f["brdf/theta_i"].attrs["max"] = 60.0'
expect_refused "tampered max" "'tamper.h5'.*axis 'theta_i'.*min/max" -- \
  "$BT" "${Q[0]}" tamper.h5 "${Q[@]:1}"
# Malformed data: exit 2 naming file and table (was exit 1, raw HDF5 text).
h5py_edit strings.h5 'del f["brdf/value"]; f["brdf"].create_dataset("value", data=np.full((5, 5, 5), b"abc"))'
expect_refused "string value" "'strings.h5', table 'brdf'.*value" -- "$BT" info strings.h5

# --- 10a. a flipped bit inside the stored data: Fletcher-32 ----------------
"$PY" - <<'PYEOF'
import shutil
import h5py
shutil.copy("t.h5", "flip.h5")
with h5py.File("flip.h5", "r") as f:
    ds = f["brdf/value"]
    assert ds.fletcher32
    chunk = ds.id.get_chunk_info(0)
    at = chunk.byte_offset + chunk.size // 2
with open("flip.h5", "r+b") as fh:
    fh.seek(at)
    b = fh.read(1)
    fh.seek(at)
    fh.write(bytes([b[0] ^ 0x04]))
PYEOF
expect_refused "flipped data bit" "'flip.h5', table 'brdf'.*[Ff]letcher32" -- \
  "$BT" "${Q[0]}" flip.h5 "${Q[@]:1}"

# --- 10b. damaged metadata: libhdf5 loops; the watchdog ends it -------------
# Zeroing 256 bytes inside the global heap (variable-length strings) makes
# libhdf5 1.10 loop forever in H5HG__protect.
"$PY" - <<'PYEOF'
b = bytearray(open("t.h5", "rb").read())
at = b.find(b"GCOL")
assert at >= 0
b[at + 128:at + 384] = bytes(256)
open("hang.h5", "wb").write(b)
PYEOF
start=$(date +%s)
BRDFTAB_READ_TIMEOUT=2 expect_refused "hang: info" "'hang.h5' did not finish within 2 s" -- \
  timeout 60 "$BT" info hang.h5
[ $(($(date +%s) - start)) -lt 30 ] && ok || bad "hang: the watchdog took too long"
BRDFTAB_READ_TIMEOUT=2 expect_refused "hang: query" "did not finish" -- \
  timeout 60 "$BT" "${Q[0]}" hang.h5 "${Q[@]:1}"
BRDFTAB_READ_TIMEOUT=soon expect_refused "bad BRDFTAB_READ_TIMEOUT" "BRDFTAB_READ_TIMEOUT" -- \
  "$BT" info t.h5
# Random bit flips: every outcome is a clean success or exit 2 (a crash or a
# hang inside libhdf5 is reported by the watchdog as exit 2 too).
bad_exits=0
for seed in $(seq 1 40); do
  "$PY" - "$seed" <<'PYEOF'
import random, sys
r = random.Random(int(sys.argv[1]))
b = bytearray(open("t.h5", "rb").read())
for _ in range(r.randint(1, 8)):
    k = r.randrange(len(b))
    b[k] ^= 1 << r.randrange(8)
open("rand.h5", "wb").write(b)
PYEOF
  BRDFTAB_READ_TIMEOUT=2 timeout 60 "$BT" info --values rand.h5 >/dev/null 2>rand_err.txt
  rc=$?
  if [ "$rc" -ne 0 ] && [ "$rc" -ne 2 ]; then
    bad_exits=$((bad_exits + 1))
    echo "seed $seed: exit $rc"; cat rand_err.txt
  fi
done
[ "$bad_exits" -eq 0 ] && ok || bad "random flips: $bad_exits runs neither succeeded nor exited 2"
# The fuzzer's libhdf5 findings (hang, SIGSEGV, failed open) and the file
# whose `created` is not UTF-8: each is a clean exit 2 from `info`.
FINDINGS="$(realpath "$2")/tests/fuzz/findings/fuzz_table"
for f in "$FINDINGS"/*.h5; do
  [ -e "$f" ] || continue
  BRDFTAB_READ_TIMEOUT=5 expect_exit 2 "fuzz finding $(basename "$f")" -- timeout 60 "$BT" info "$f"
done
# The guard changes nothing for an intact file.
BRDFTAB_READ_TIMEOUT=0 expect_exit 0 "query without the guard" -- "$BT" "${Q[0]}" t.h5 "${Q[@]:1}"
cmp -s out.txt query_intact.txt && ok || bad "query differs without the guard"

# --- 10c. validate caps the work a file declares ----------------------------
cp alb.h5 greedy.h5
"$PY" - <<'PYEOF'
import h5py
import numpy as np
with h5py.File("greedy.h5", "r+") as f:
    f["albedo_r"].attrs["samples_requested"] = np.uint64(2**40)
    f["albedo_r"].attrs["tolerance_requested"] = 1e-12
PYEOF
expect_exit 0 "validate greedy table, capped" -- timeout 300 "$BT" validate greedy.h5 \
  --table albedo_r --points 3 --max-samples 2048 -q
expect_grep "asks for 1099511627776 samples per point; the reference is capped at 2048" out.txt \
  "validate says it capped the work"
expect_exit 0 "validate greedy table, JSON" -- timeout 300 "$BT" validate greedy.h5 \
  --table albedo_r --points 3 --max-samples 2048 -q --json
"$PY" - out.txt <<'PYEOF' && ok || bad "validate JSON: capped reference"
import json, sys
r = json.load(open(sys.argv[1]))["reference"]
assert r["samples_capped"] and r["sample_cap"] == 2048, r
assert r["table_samples_requested"] == 2**40, r
# The engine's first batch is 4096 samples per point; the cap stops it there.
assert r["total_samples"] <= 3 * 4096, r
PYEOF
expect_exit 0 "validate default cap" -- "$BT" validate alb.h5 --table albedo_r --points 2 \
  --samples 512 -q --json
"$PY" - out.txt <<'PYEOF' && ok || bad "validate JSON: default cap 2^22, explicit --samples uncapped"
import json, sys
r = json.load(open(sys.argv[1]))["reference"]
assert r["sample_cap"] == 2**22 and not r["samples_capped"], r
PYEOF

# --- 11. `-o ""` is an error, not a fall-back to the spec's path ------------
rm -f t.h5.bak && cp t.h5 t.h5.bak
printf 'theta_o,phi_d\n20,30\n' >pts.csv
expect_refused 'generate -o ""' "empty path" -- "$BT" generate t.toml -q -o ""
cmp -s t.h5 t.h5.bak && ok || bad 'generate -o "" touched the spec'"'"'s output'
expect_refused 'query -o ""' "empty path" -- "$BT" query t.h5 --table brdf theta_i=10 \
  --points pts.csv -o ""
expect_refused 'plot -o ""' "empty path" -- "$BT" plot t.h5 --table brdf --slice theta_i=10 \
  --slice theta_o=20 -o ""
expect_refused 'export --exr ""' "empty path" -- "$BT" export t.h5 --table brdf \
  --slice phi_d=0 --exr ""
expect_refused 'eval -o ""' "empty path" -- "$BT" eval rough-dielectric brdf theta_i=10 \
  alpha=0.5 eta=1.5 --points pts.csv -o ""

# --- 9. info reads one open file while another run replaces it --------------
# Two valid files with different tables, swapped in by rename as a
# concurrent `generate` would; every `info` must succeed.
cp t.h5 a.h5
cp alb.h5 b.h5
(
  end=$(($(date +%s) + 8))
  while [ "$(date +%s)" -lt "$end" ]; do
    cp a.h5 swap.tmp && mv swap.tmp live.h5
    cp b.h5 swap.tmp && mv swap.tmp live.h5
  done
) &
swapper=$!
cp a.h5 live.h5
info_failures=0
for _ in $(seq 1 60); do
  "$BT" info live.h5 >/dev/null 2>info_err.txt || {
    info_failures=$((info_failures + 1))
    cat info_err.txt
  }
done
wait "$swapper"
[ "$info_failures" -eq 0 ] && ok || bad "info failed $info_failures of 60 times during replacement"

cli_summary
