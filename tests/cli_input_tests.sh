#!/usr/bin/env bash
# End-to-end tests of input limits (issue 15, defects 4-7): sample counts and
# tolerances out of range, Phong beyond its defined roughness, where a spec's
# output goes, and the memory/disk estimate made before computing.  Every
# refusal must exit 2, name what is wrong, and leave no output file.
# Usage: cli_input_tests.sh BRDFTAB SOURCE_DIR
set -u
# The script may be run from anywhere, with relative paths.
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=cli_lib.sh
source "$HERE/cli_lib.sh"
cli_setup "$1" "$2"

expect_no_file() {  # expect_no_file PATH DESCRIPTION
  if [ -e "$1" ]; then bad "$2: $1 exists"; else ok; fi
}

# small.toml of the issue: rough dielectric, eta 1.5, alpha 0.3, theta_i and
# theta_o in [0, 89] with 4 nodes, one brdf table.
cat >small.toml <<'EOF'
model = "rough-dielectric"
[parameters]
eta = 1.5
alpha = 0.3
[[axes]]
name = "theta_i"
range = [0, 89]
count = 4
[[axes]]
name = "theta_o"
range = [0, 89]
count = 4
[[tables]]
quantity = "brdf"
[output]
path = "small.h5"
EOF
# An albedo table (Monte Carlo) on one axis: the integration settings matter.
cat >mc.toml <<'EOF'
model = "rough-dielectric"
[parameters]
eta = 1.5
alpha = 0.3
[[axes]]
name = "theta_i"
range = [0, 89]
count = 4
[[tables]]
quantity = "albedo_r"
[output]
path = "mc.h5"
EOF

# --- defect 4: sample counts above 2^32 - 1, --samples 0, --tolerance 0 -------
EVAL_MC=("$BT" eval rough-dielectric albedo_r theta_i=30 alpha=0.3 eta=1.5 --method mc --json)
expect_exit 2 "eval --samples 2^44" -- "${EVAL_MC[@]}" --samples 17592186044416
expect_grep "--samples 17592186044416 is out of range; allowed: integers in \[1, 4294967295\]" \
  err.txt "eval --samples 2^44 names the option and the range"
expect_exit 2 "eval --samples 2^44 + 4096" -- "${EVAL_MC[@]}" --samples 17592186044420
expect_exit 2 "eval --samples 2^32" -- "${EVAL_MC[@]}" --samples 4294967296
expect_exit 2 "eval --samples 0" -- "${EVAL_MC[@]}" --samples 0
expect_grep "--samples 0 is out of range; allowed: integers in \[1, 4294967295\]" err.txt \
  "eval --samples 0 names the range"
# CLI11 reads -3 as 2^64 - 3: refused, and named as typed.
expect_exit 2 "eval --samples -3" -- "${EVAL_MC[@]}" --samples -3
expect_grep "--samples -3 is out of range" err.txt "eval --samples -3 named as typed"
expect_exit 2 "eval --max-samples 2^44" -- "${EVAL_MC[@]}" --tolerance 0.01 \
  --max-samples 17592186044416
expect_grep "--max-samples 17592186044416 is out of range" err.txt "--max-samples named"
expect_exit 2 "eval --max-samples 0" -- "${EVAL_MC[@]}" --tolerance 0.01 --max-samples 0
expect_exit 2 "eval --tolerance 0" -- "${EVAL_MC[@]}" --tolerance 0
expect_grep "--tolerance 0 is out of range; allowed: \(0, 1\)" err.txt "--tolerance 0 named"
expect_exit 2 "eval --tolerance 1" -- "${EVAL_MC[@]}" --tolerance 1
expect_exit 2 "eval --tolerance -0.1" -- "${EVAL_MC[@]}" --tolerance -0.1
# The largest count is accepted as a value (not run: a tiny one is).
expect_exit 0 "eval --samples 4096" -- "${EVAL_MC[@]}" --samples 4096
expect_grep '"samples":4096' out.txt "eval ran 4096 samples"

expect_exit 2 "generate --samples 2^44" -- "$BT" generate mc.toml -q --samples 17592186044416
expect_grep "--samples 17592186044416 is out of range" err.txt "generate names --samples"
expect_no_file mc.h5 "generate --samples 2^44 wrote no table"
expect_exit 2 "generate --tolerance 0" -- "$BT" generate mc.toml -q --tolerance 0
expect_no_file mc.h5 "generate --tolerance 0 wrote no table"
sed -e 's/^\[output\]$/[integration]\nsamples = 17592186044416\n[output]/' mc.toml >mc_big.toml
expect_exit 2 "spec samples = 2^44" -- "$BT" generate mc_big.toml -q
expect_grep "mc_big.toml:[0-9]+:[0-9]+: key 'integration.samples': .*\[1, 4294967295\]" err.txt \
  "spec samples = 2^44 names file:line:key and the range"
sed -e 's/^\[output\]$/[integration]\ntolerance = 0.01\nmax_samples = 17592186044416\n[output]/' \
  mc.toml >mc_big2.toml
expect_exit 2 "spec max_samples = 2^44" -- "$BT" generate mc_big2.toml -q
expect_grep "key 'integration.max_samples'" err.txt "spec max_samples named"
expect_no_file mc.h5 "no table from the refused specs"

# --- defect 5: Phong is defined for alpha < 1 only -----------------------------
PHONG=("$BT" eval rough-dielectric albedo_avg eta=1.5 distribution=phong --samples 256)
for alpha in 1.0 1 4 1.5; do
  expect_exit 2 "phong albedo_avg alpha=$alpha" -- "${PHONG[@]}" alpha=$alpha
  expect_grep "alpha = [0-9.]+ is out of range for distribution = phong; allowed: \(0, 1\)" \
    err.txt "phong alpha=$alpha: names alpha, its value and the range"
done
expect_exit 2 "phong brdf alpha=1 (closed form)" -- "$BT" eval rough-dielectric brdf theta_i=30 \
  theta_o=30 alpha=1 eta=1.5 distribution=phong
expect_exit 0 "phong alpha=0.99 is accepted" -- "${PHONG[@]}" alpha=0.99
expect_exit 0 "ggx alpha=4 is still accepted" -- "$BT" eval rough-dielectric albedo_avg eta=1.5 \
  alpha=4 distribution=ggx --samples 256
# generate: an alpha axis crossing 1 with Phong is refused before computing.
cat >phong.toml <<'EOF'
model = "rough-dielectric"
[parameters]
eta = 1.5
distribution = "phong"
[[axes]]
name = "alpha"
range = [0.5, 1.5]
count = 3
[[tables]]
quantity = "albedo_avg"
[integration]
samples = 256
[output]
path = "phong.h5"
EOF
expect_exit 2 "generate phong alpha up to 1.5" -- "$BT" generate phong.toml -q
expect_grep "alpha = 1 is out of range for distribution = phong" err.txt \
  "generate names the first Phong cell out of range"
expect_no_file phong.h5 "no Phong table written"
expect_grep "phong.toml: table 'albedo_avg': alpha = 1 is out of range" err.txt \
  "the refusal names the spec file and the table"
expect_no_file phong.h5.checkpoint "a refused cell leaves no checkpoint behind"
# The same for a closed form, whose cells are checked while its launches are
# built (after the output's checkpoint exists), and with the checkpoint of an
# earlier refused run absent, a later run reports no old checkpoint.
cat >phong-bsdf.toml <<'EOF'
model = "rough-dielectric"
[parameters]
eta = 1.5
distribution = "phong"
[[axes]]
name = "theta_i"
range = [0, 80]
count = 3
[[axes]]
name = "theta_o"
range = [0, 80]
count = 3
[[axes]]
name = "alpha"
range = [0.5, 1.5]
count = 3
[[tables]]
quantity = "bsdf"
[output]
path = "phong.h5"
EOF
expect_exit 2 "generate phong bsdf, alpha up to 1.5" -- "$BT" generate phong-bsdf.toml -q
expect_grep "phong-bsdf.toml: table 'bsdf': alpha = 1 is out of range" err.txt \
  "closed form: the refusal names the spec file and the table"
expect_no_file phong.h5 "closed form: no Phong table written"
expect_no_file phong.h5.checkpoint "closed form: a refused cell leaves no checkpoint behind"
expect_exit 2 "generate phong bsdf again" -- "$BT" generate phong-bsdf.toml -q
if grep -q "add --resume" err.txt; then bad "a second refused run found a checkpoint of the first"; else ok; fi
# validate recomputes through the same engine: a file claiming Phong at
# alpha = 1 (a GGX table relabelled) is refused as well.
cat >ggx.toml <<'EOF'
model = "rough-dielectric"
[parameters]
eta = 1.5
alpha = 1.0
distribution = "ggx"
[[axes]]
name = "theta_i"
range = [0, 80]
count = 3
[[tables]]
quantity = "albedo_r"
[integration]
samples = 256
[output]
path = "ggx.h5"
EOF
expect_exit 0 "generate ggx alpha = 1" -- "$BT" generate ggx.toml -q
"$PY" - ggx.h5 <<'PYEOF' && ok || bad "relabel ggx.h5 as phong"
import json, sys, h5py
with h5py.File(sys.argv[1], "r+") as f:
    g = f["albedo_r"]
    p = json.loads(g.attrs["parameters"])
    assert p["distribution"] == "ggx"
    p["distribution"] = "phong"
    g.attrs["parameters"] = json.dumps(p)
PYEOF
expect_exit 2 "validate a Phong table at alpha = 1" -- "$BT" validate ggx.h5 --table albedo_r --points 20 -q
expect_grep "alpha = 1 is out of range for distribution = phong" err.txt \
  "validate names alpha and the Phong range"

# --- defect 6: a spec's output.path is relative to the spec's directory ------
mkdir -p specs/sub
sed -e 's/path = "small.h5"/path = "here.h5"/' small.toml >specs/sub/rel.toml
sed -e 's/path = "small.h5"/path = "..\/up.h5"/' small.toml >specs/sub/up.toml
sed -e "s|path = \"small.h5\"|path = \"$WORK/abs.h5\"|" small.toml >specs/sub/abs.toml
expect_exit 0 "generate specs/sub/rel.toml" -- "$BT" generate specs/sub/rel.toml
[ -f specs/sub/here.h5 ] && ok || bad "relative output.path resolved against the spec directory"
expect_no_file here.h5 "nothing written to the current directory"
expect_grep "^writing $WORK/specs/sub/here.h5\$" err.txt "generate says where it will write"
expect_grep "^wrote specs/sub/here.h5\$" out.txt "generate says where it wrote"
# The "writing" line comes before the progress of the first table.
"$PY" - err.txt <<'PYEOF' && ok || bad "'writing' is printed before computing"
import sys
lines = open(sys.argv[1]).read().splitlines()
w = [k for k, l in enumerate(lines) if l.startswith("writing ")]
p = [k for k, l in enumerate(lines) if l.startswith("[1/1]")]
sys.exit(0 if len(w) == 1 and p and w[0] < p[0] else 1)
PYEOF
expect_exit 0 "generate specs/sub/up.toml" -- "$BT" generate specs/sub/up.toml -q
[ -f specs/up.h5 ] && ok || bad "'..' resolved against the spec directory"
expect_grep "^writing $WORK/specs/up.h5\$" err.txt "generate prints the resolved '..' path"
expect_exit 0 "generate specs/sub/abs.toml" -- "$BT" generate specs/sub/abs.toml -q
[ -f abs.h5 ] && ok || bad "absolute output.path kept"
# -o stays relative to the current directory.
expect_exit 0 "generate -o" -- "$BT" generate specs/sub/rel.toml -q -o cwd.h5
[ -f cwd.h5 ] && ok || bad "-o relative to the current directory"
# A run refused before computing (settings, memory) prints no "writing".
expect_exit 2 "refused run" -- "$BT" generate specs/sub/rel.toml -q --samples 0
if grep -q "^writing " err.txt; then bad "a refused run printed 'writing'"; else ok; fi

# --- defect 7: memory and disk estimated before computing ---------------------
expect_exit 0 "generate --max-memory 8G" -- "$BT" generate small.toml -q --max-memory 8G
expect_exit 2 "generate --max-memory 1M" -- "$BT" generate small.toml -q --max-memory 1M -o m.h5
expect_grep "need about [0-9.]+ [KMG]iB of memory for 16 cells .*above --max-memory 1.00 MiB" \
  err.txt "--max-memory refusal gives the numbers"
expect_no_file m.h5 "no table past --max-memory"
expect_exit 2 "generate --max-memory junk" -- "$BT" generate small.toml -q --max-memory 8Q
expect_grep "--max-memory '8Q' is not a byte count" err.txt "--max-memory junk named"
# The issue's 65536 x 65535 cells (4.3e9): refused at once, not after
# starting (bad_alloc), with the estimate and what is available.
sed -e 's/^count = 4$/count = 65536/' small.toml >huge.toml
sed -i -e '0,/count = 65536/! s/count = 65536/count = 65535/' huge.toml
sed -i -e 's/path = "small.h5"/path = "huge.h5"/' huge.toml
# Tables are streamed to the file in chunks of cells, so memory is bounded by
# a chunk, not by the table: the 4.29G cells need a few hundred MiB, and
# --max-memory below that refuses them at once, with the numbers.
start=$(date +%s)
expect_exit 2 "generate 65536 x 65535 cells, --max-memory 100M" -- "$BT" generate huge.toml -q \
  --max-memory 100M
expect_grep "need about [0-9.]+ MiB of memory for 4.29G cells .*above --max-memory 100.00 MiB" \
  err.txt "huge table: the estimate (a chunk, not the table) and --max-memory"
[ $(($(date +%s) - start)) -lt 30 ] && ok || bad "huge table refused quickly"
expect_no_file huge.h5 "no huge table written"
# --max-memory replaces MemAvailable as the limit; then the disk check: an
# albedo table of 65536 x 65535 cells stored as float64 needs ~340 GiB on disk
# (value, stderr, samples and the checkpoint).  Run only where the work
# directory's file system has less free space (else the run would compute).
cat >disk.toml <<'EOF'
model = "rough-dielectric"
[parameters]
alpha = 0.3
[[axes]]
name = "theta_i"
range = [0, 89]
count = 65536
[[axes]]
name = "eta"
range = [1.1, 2.0]
count = 65535
[[tables]]
quantity = "albedo_r"
[output]
path = "disk.h5"
type = "float64"
EOF
if "$PY" -c 'import os, sys; s = os.statvfs("."); sys.exit(0 if s.f_bavail * s.f_frsize < 3.0e11 else 1)'; then
  expect_exit 2 "generate 4.3e9 cells with --max-memory 100000T" -- "$BT" generate disk.toml -q \
    --max-memory 100000T
  expect_grep "disk.h5: the tables need about [0-9.]+ GiB on disk before compression for 4.29G cells .*but only .* is free on its file system" \
    err.txt "disk refusal gives the numbers"
  expect_no_file disk.h5 "no table past the free disk space"
else
  echo "note: more than 300 GB free here; the disk refusal is not exercised"
fi
# generate --help documents the option.
expect_exit 0 "generate --help" -- "$BT" generate --help
expect_grep "--max-memory" out.txt "generate --help documents --max-memory"
expect_grep "MemAvailable" out.txt "generate --help explains the memory check"

cli_summary
