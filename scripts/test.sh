#!/usr/bin/env bash
# Sets up (packages, configure, build) and runs the test suite. Extra arguments go to ctest,
# e.g. scripts/test.sh -L analytic
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build all
ctest --test-dir build --output-on-failure -j2 -LE slow "$@"
