#!/usr/bin/env bash
# Runs bench_impact_ensemble (benchmarks/impact_ensemble.cpp) over an ensemble of spacings on JOBS processes of
# one OpenMP thread each and prints the pass count; rows in benchmarks/results/impact_ensemble/<tag>.csv.
# See docs/lsmps_scheme.md "Robustness over an ensemble of spacings".
#
#   benchmarks/run_impact_ensemble.sh TAG [bench_impact_ensemble options, e.g. --bound 20]
#
# Environment: BUILD_DIR (default build/bench, configured with -DMPSKIT_BUILD_BENCHMARKS=ON), SPACINGS (mm,
# default 3, 3.1, ..., 6 mm: 31 spacings), JOBS (default 2), T_END (default 3.2).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
build="${BUILD_DIR:-$root/build/bench}"
jobs="${JOBS:-2}"
spacings="${SPACINGS:-$(seq 3 0.1 6)}"
tag="${1:?usage: run_impact_ensemble.sh TAG [options]}"
shift
bin="$build/benchmarks/bench_impact_ensemble"
# configured here when the directory is new; built every time (a no-op when up to date, never a stale binary)
[ -f "$build/CMakeCache.txt" ] || cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DMPSKIT_BUILD_BENCHMARKS=ON \
  -DMPSKIT_BUILD_TESTS=OFF -DMPSKIT_BUILD_EXAMPLES=OFF >/dev/null
cmake --build "$build" --target bench_impact_ensemble -j 1 >/dev/null
out="$here/results/impact_ensemble"
mkdir -p "$out" "$out/$tag.d"
export OMP_NUM_THREADS=1
# one process per spacing, JOBS at a time; each writes its own row, merged in spacing order below
printf '%s\n' $spacings | xargs -P "$jobs" -I{} sh -c "'$bin' --L {} --T '${T_END:-3.2}' $* > '$out/$tag.d/{}.csv'"
{
  "$bin" --header "$@"
  for L in $spacings; do cat "$out/$tag.d/$L.csv"; done
} > "$out/$tag.csv"
# a run that ended without its row (a crash, not a scheme failure: those are rows with reached = 0) is an error
missing=""
for L in $spacings; do [ -s "$out/$tag.d/$L.csv" ] || missing="$missing $L"; done
if [ -n "$missing" ]; then echo "run_impact_ensemble.sh: no row for L =$missing mm (see $out/$tag.d)" >&2; exit 1; fi
rm -r "$out/$tag.d"
# columns found by their header names (the CSV gained columns before; positions would silently shift)
awk -F, -v tag="$tag" 'NR == 1 { for (k = 1; k <= NF; k++) col[$k] = k; next }
  { n++; ok += $col["reached"]; s = s sprintf(" %s:%s", $col["L_mm"], $col["reached"] ? "ok" : sprintf("F%.2f", $col["T_last"])) }
  END { printf "%s: %d of %d reached T_end;%s\n", tag, ok, n, s }' "$out/$tag.csv"
