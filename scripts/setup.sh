#!/usr/bin/env bash
# Installs every Debian package crosslink needs (idempotent), then configures and builds.
# Usage: scripts/setup.sh [build-dir [target ...]]   (default: build, and the target crosslink:
# the command line, all the quick start's main job runs; scripts/test.sh builds `all`)
#        scripts/setup.sh --packages   (the packages and the chart scripts only: .ci/run)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${1:-build}
shift || true
TARGETS=("${@:-crosslink}")

PACKAGES=(
  build-essential cmake ninja-build pkg-config git clang-format
  libeigen3-dev libfmt-dev libtomlplusplus-dev nlohmann-json3-dev libcli11-dev libboost-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libmujoco-dev libbullet-dev libbullet-extras-dev libslvs1-dev
  libsimbody-dev  # Simbody 3.7 engine (sim/simbody/; its CMake package)
  libode-dev  # ODE 0.16, double precision (sim/ode/; pkg-config ode)
  clang libclang-rt-14-dev  # scripts/test-sanitizers.sh: ASan, UBSan and libFuzzer
  nodejs chromium  # report/'s chart scripts (npm ci); the report's headless-browser test
  python3  # bench/: writes A02 with N = 160 at build time; scripts/behaviour-diff.py
  # The Python module (python/, docs/python.md) and its tests (tests/python, pytest); the
  # notebook (examples/) executed in them
  python3-dev pybind11-dev python3-numpy python3-pytest
  python3-nbclient python3-nbformat python3-ipykernel python3-matplotlib
  python3-dask python3-distributed  # a sweep's shards as Dask tasks (tests/python/test_dask.py)
  # tests/cluster/slurm_sweep.sh (label cluster): slurmctld, slurmd and the client commands; it
  # pulls munge, whose daemon the test's auth/none Slurm does not use
  slurm-wlm
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO=sudo
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The HTML report's chart scripts (Vega, Vega-Lite, vega-embed) from the npm registry, at the
# versions pinned in report/package-lock.json; read by `crosslink compare --report` at run time.
if ! command -v npm >/dev/null; then  # Debian's nodejs ships npm separately
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO=sudo
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends npm
fi
if [ ! -d report/node_modules ] || [ report/package-lock.json -nt report/node_modules ]; then
  (cd report && npm ci --no-audit --no-fund)
fi

[ "$BUILD_DIR" = --packages ] && exit 0

# Ninja for a new build folder: it compiles a target's files while the libraries it links are
# still being linked, and starts at once where make walks every target's rules; a folder
# configured before keeps its generator.
GENERATOR=()
[ -f "$BUILD_DIR/CMakeCache.txt" ] || ! command -v ninja >/dev/null || GENERATOR=(-G Ninja)
cmake -S . -B "$BUILD_DIR" "${GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Release
cmake --build "$BUILD_DIR" -j2 --target "${TARGETS[@]}"
