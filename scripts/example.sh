#!/usr/bin/env bash
# README quick start, first command: installs what is missing, builds the main example optimised and
# runs it (one thread unless OMP_NUM_THREADS is set): the multi-resolution dam break with the obstacle
# against single resolution. Its output goes to out/multires_dam_break/ (ParaView series, front.csv,
# runs.csv, probe.csv, particles.png, front.png, probe.png) and a summary is printed. Arguments go to the example (--full, --L, ...).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build/examples -DCMAKE_BUILD_TYPE=Release -DMPSKIT_BUILD_TESTS=OFF >/dev/null
cmake --build build/examples -j "$jobs" --target multires_dam_break
mkdir -p out
OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} ./build/examples/examples/multires_dam_break --out out/multires_dam_break "$@"
