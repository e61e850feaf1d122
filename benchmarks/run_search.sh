#!/usr/bin/env bash
# Builds and runs the search micro-benchmarks (benchmarks/bench_search.cpp) with 1 and 2 OpenMP threads,
# 5 repetitions each, and writes results, compiler version, flags and machine to
# benchmarks/results/search-<date>.txt (raw JSON beside it). See docs/performance.md.
#
#   benchmarks/run_search.sh [extra benchmark args, e.g. --benchmark_filter=sweep]
#
# Environment: BUILD_DIR (default build-benchmarks), CXX_FLAGS (default "-O2 -DNDEBUG": release code,
# IEEE math, no -ffast-math; use "-O2" to measure with assertions on, as CI built until 2026-12-07, or
# "-O3" as CI builds since), THREADS (default
# "1 2"), REPETITIONS (default 5), JOBS (default 1: the machine is shared).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
build="${BUILD_DIR:-$root/build-benchmarks}"
flags="${CXX_FLAGS:--O2 -DNDEBUG}"
threads="${THREADS:-1 2}"
reps="${REPETITIONS:-5}"
jobs="${JOBS:-1}"
stamp="$(date -u +%Y-%m-%dT%H%M%SZ)"
mkdir -p "$here/results"
out="$here/results/search-$stamp.txt"

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=$flags" \
  -DMPSKIT_BUILD_BENCHMARKS=ON -DMPSKIT_BUILD_TESTS=OFF -DMPSKIT_BUILD_EXAMPLES=OFF >/dev/null
cmake --build "$build" --target bench_search -j "$jobs" >/dev/null

{
  echo "# mpskit search benchmarks, $stamp"
  echo "commit: $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)$(git -C "$root" diff --quiet -- include benchmarks 2>/dev/null || echo ' (+ uncommitted changes)')"
  echo "compiler: $(g++ --version | head -1)"
  echo "flags: CMAKE_BUILD_TYPE=Release CMAKE_CXX_FLAGS_RELEASE='$flags' (+ -fopenmp via mpskit::openmp)"
  echo "machine: nproc=$(nproc), $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo)"
  echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "threads: set with OMP_NUM_THREADS (every loop runs through exec::par); repetitions: $reps"
  echo
} >"$out"

for t in $threads; do
  json="$here/results/search-$stamp-t$t.json"
  echo "## OMP_NUM_THREADS=$t" >>"$out"
  # display_aggregates_only: the console shows median/mean/stddev/cv; the JSON keeps every repetition
  # so the summary below can give the min–max spread.
  OMP_NUM_THREADS=$t "$build/benchmarks/bench_search" --benchmark_repetitions="$reps" \
    --benchmark_display_aggregates_only=true --benchmark_out="$json" --benchmark_out_format=json "$@" \
    2>&1 | tee -a "$out"
  echo >>"$out"
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$out"

if command -v python3 >/dev/null; then
  python3 "$here/summarize_search.py" "$here/results/search-$stamp" $threads | tee -a "$out"
fi
echo "written: $out"
