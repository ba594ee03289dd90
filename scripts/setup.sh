#!/usr/bin/env bash
# Installs the Debian 12 packages brdftab needs to build, test and run, if any
# are missing.  Non-interactive.  When not root, prints the command instead of
# running it (prefix with sudo yourself).
#
# By default: everything the build, the test suite and the Python module need.
#   --build-only  just what building and running the `brdftab` CLI needs (README
#            command 1): no test framework, Python, MPI or HDF5 tools; run
#            again without it before the tests (README command 2)
# Optional groups, installed only when asked:
#   --fuzz   clang and its sanitizer/libFuzzer runtimes (scripts/fuzz.sh)
#   --mitsuba  LLVM 19 for Mitsuba's llvm_* variants, and the venv .venv-mitsuba
#            (Debian's python3 with its numpy/h5py, plus `pip install mitsuba`)
#            that the CTest label `mitsuba` uses (docs/python.md)
# (scripts/sanitize.sh needs nothing more: GCC's ASan/UBSan runtimes come
# with build-essential.)
set -euo pipefail

with_fuzz=0
with_mitsuba=0
build_only=0
for arg in "$@"; do
  case $arg in
    --fuzz) with_fuzz=1 ;;
    --mitsuba) with_mitsuba=1 ;;
    --build-only) build_only=1 ;;
    *) echo "setup: unknown option '$arg' (known: --build-only, --fuzz, --mitsuba)" >&2; exit 2 ;;
  esac
done

packages=(
  build-essential cmake pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-clhpp-headers   # OpenCL on the CPU
  libhdf5-dev                                               # tables
  libopenexr-dev                                            # EXR export (and Imath half)
  libpng-dev                                                # `brdftab plot`
  libpugixml-dev                                            # Mitsuba scene files (`brdftab scene`)
  libtomlplusplus-dev libcli11-dev nlohmann-json3-dev
)
if [ $build_only -eq 0 ]; then
  packages+=(
    hdf5-tools doctest-dev                                  # tests: h5dump/h5diff, the test framework
    python3-h5py python3-numpy                              # format tests read files with h5py
    python3-dev pybind11-dev python3-pybind11 python3-pytest   # Python module brdftab and its tests
    python3-venv                                            # `pip install .` test in a fresh venv
    libopenmpi-dev openmpi-bin                              # the MPI build (docs/cluster.md)
  )
fi
if [ $with_fuzz -eq 1 ]; then
  packages+=(clang libclang-rt-dev)
fi
if [ $with_mitsuba -eq 1 ]; then
  packages+=(python3-pip libllvm19)
fi

# The Mitsuba venv, after the packages (needs python3-venv).
make_mitsuba_venv() {
  [ $with_mitsuba -eq 1 ] || return 0
  local venv
  venv="$(cd "$(dirname "$0")/.." && pwd)/.venv-mitsuba"
  if "$venv/bin/python" -c "import mitsuba" 2>/dev/null; then
    echo "setup: $venv has mitsuba"
    return 0
  fi
  echo "setup: creating $venv with mitsuba (pip)"
  /usr/bin/python3 -m venv --system-site-packages "$venv"
  "$venv/bin/pip" install -q mitsuba
}

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  make_mitsuba_venv
  exit 0
fi

cmd="apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "setup: missing packages: ${missing[*]}"
  echo "setup: run as root:  apt-get update && $cmd"
  exit 1
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
# shellcheck disable=SC2086
apt-get install -y -qq --no-install-recommends ${missing[*]}
make_mitsuba_venv
