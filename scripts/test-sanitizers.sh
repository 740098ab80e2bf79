#!/usr/bin/env bash
# The whole test suite built with AddressSanitizer and UndefinedBehaviorSanitizer by clang, in a
# second build folder, with the libFuzzer target and its one-minute run (label fuzz). Without the
# label `slow`, as scripts/test.sh (`ctest --test-dir build-asan -L slow` runs those), and
# without `cluster`: the Slurm test checks Slurm's orchestration, not crosslink's memory, and the
# sanitized binary takes it past five minutes (sharding and merging run sanitized in
# Cli.MergedShardsWriteTheSweepOfOneRun), and without `browser`: a headless Chromium reading the
# report checks its script, not crosslink's memory (the C++ that writes the page runs sanitized
# in the other compare tests); they took 290 s of the sanitized run's test time (2026-12-02).
# Nor `accuracy`: an engine's accuracy at a step far below its default (10^5 steps or more) or at
# a setting another test runs too, whose code paths the default-step tests run sanitized; the
# four took 68 s of its test time (2026-12-02); and the exact dynamics over A01's 2000 s, whose
# integrators the other dynamics cases run sanitized (126 s, 2026-12-03). Nor the Python module:
# a sanitized extension needs the sanitizer's runtime preloaded into Python, and the library it
# calls runs sanitized in every other test. Nor `mujoco3`: MuJoCo 3 (WebAssembly) against 2.2.2
# on the exports, whose writing runs sanitized in the export tests.
# Extra arguments go to ctest, e.g. scripts/test-sanitizers.sh -L fuzz; BUILD_ONLY=1 configures
# and builds without testing (.ci/run starts the build so, beside the Release build and suite).
# Usage: scripts/test-sanitizers.sh [ctest arguments]   (folder: build-asan)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build-asan}
FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -gline-tables-only"

GENERATOR=()  # Ninja for a new folder, as scripts/setup.sh
[ -f "$BUILD_DIR/CMakeCache.txt" ] || ! command -v ninja >/dev/null || GENERATOR=(-G Ninja)
CC=clang CXX=clang++ cmake -S . -B "$BUILD_DIR" "${GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_FLAGS="$FLAGS" -DCMAKE_CXX_FLAGS="$FLAGS" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCROSSLINK_FUZZ=ON -DCROSSLINK_BUILD_BENCH=OFF -DCROSSLINK_TEST_OPTIMIZATION=-O0 \
  -DCROSSLINK_PYTHON=OFF
cmake --build "$BUILD_DIR" -j2
[ -z "${BUILD_ONLY:-}" ] || exit 0

# Every report is an error; leaks too (detect_leaks is on by default on Linux x86_64).
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# A third-party library's allocations crosslink cannot free, each with why (scripts/lsan.supp).
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/scripts/lsan.supp:print_suppressions=0}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j2 -LE "slow|cluster|browser|accuracy|mujoco3" "$@"
