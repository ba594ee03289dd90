#!/usr/bin/env bash
# Installs brdftab into a temporary prefix, builds examples/ against it with
# find_package(brdftab), and runs the example on a freshly generated table.
# Usage: install_example_test.sh BUILD_DIR SOURCE_DIR BRDFTAB
set -euo pipefail
BUILD=$1 SRC=$2 BT=$3
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cmake --install "$BUILD" --prefix "$WORK/prefix" >/dev/null
test -f "$WORK/prefix/include/brdftab/lookup/lookup.h"
test -x "$WORK/prefix/bin/brdftab"
cmake -S "$SRC/examples" -B "$WORK/example" -DCMAKE_PREFIX_PATH="$WORK/prefix" \
      -DCMAKE_BUILD_TYPE=Release >"$WORK/configure.txt" 2>&1
# A consumer's configure is quiet about dependencies it does not use (Debian's
# Imath announces a missing Python binding otherwise).
if grep -q "PyImath" "$WORK/configure.txt"; then
  echo "FAIL: consumer configure mentions PyImath:"; cat "$WORK/configure.txt"; exit 1
fi
cmake --build "$WORK/example" -j2 >/dev/null
cat >"$WORK/spec.toml" <<'TOML'
model = "rough-dielectric"
[parameters]
alpha = 0.5
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 9
[[axes]]
name = "theta_o"
range = [0.0, 90.0]
count = 19
[[axes]]
name = "phi_d"
range = [0.0, 180.0]
count = 13
[[tables]]
quantity = "brdf"
TOML
# The installed binary works from any directory (kernels are embedded).
(cd "$WORK" && "$WORK/prefix/bin/brdftab" generate spec.toml -o table.h5 -q >/dev/null)
"$WORK/example/table_example" "$WORK/table.h5" brdf >"$WORK/out.txt"
grep -q "brdf" "$WORK/out.txt"
# An albedo table (no outgoing direction): values printed, sampling skipped, exit 0.
cat >"$WORK/albedo.toml" <<'TOML'
model = "rough-dielectric"
[parameters]
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 3
[[axes]]
name = "alpha"
range = [0.2, 0.6]
count = 2
[[tables]]
quantity = "albedo_r"
[integration]
samples = 64
TOML
(cd "$WORK" && "$WORK/prefix/bin/brdftab" generate albedo.toml -o albedo.h5 -q >/dev/null)
"$WORK/example/table_example" "$WORK/albedo.h5" albedo_r >"$WORK/albedo.txt"
grep -q "no direction-level" "$WORK/albedo.txt"
echo "3 passed, 0 failed"
