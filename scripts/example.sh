#!/usr/bin/env bash
# README quick start, first command: installs what is missing, builds the main example optimised and
# runs it; its output goes to out/ (arguments are passed to the example).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build/examples -DCMAKE_BUILD_TYPE=Release -DMPSKIT_BUILD_TESTS=OFF >/dev/null
cmake --build build/examples -j "$jobs" --target neighbour_demo
mkdir -p out
./build/examples/neighbour_demo "$@"
