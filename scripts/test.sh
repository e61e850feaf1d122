#!/usr/bin/env bash
# README quick start, second command: installs what is missing, configures an optimised build with
# assertions on (-O3 without -DNDEBUG) and -Werror, builds, and runs every test with ctest.
# -O3 since 2026-12-07 (-O2 before): the same printed numbers, digit for digit, in 0.90-0.97 of the time of
# the four physics suites compared (docs/resolution.md "CI sizes", eighth change).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build/tests -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE=-O3 -DMPSKIT_WERROR=ON \
      -DMPSKIT_BUILD_EXAMPLES=OFF >/dev/null
cmake --build build/tests -j "$jobs"
cd build/tests
ctest --output-on-failure -j "$jobs" "$@"
