#!/usr/bin/env bash
# Sanitizer run (on demand, not part of CI): builds every test suite with AddressSanitizer and
# UndefinedBehaviorSanitizer (-O1 -g; assertions on, and Eigen's bounds checks in every suite, the physics-regression
# ones included: MPSKIT_TEST_EIGEN_CHECKS_EVERYWHERE) in build/sanitize, then runs with ctest the labels that take
# seconds at -O2. The physics-regression labels run 7-16x slower here and are left out unless named, and so is
# consumer (about a minute: it configures and builds two consumer projects, with this build's sanitizer flags):
#   bash scripts/sanitize.sh                           # the default selection (README "Build options")
#   bash scripts/sanitize.sh -L taylor_green_multires  # any ctest arguments replace the selection
# A sanitizer report fails the test (UBSan does not recover; ASan aborts, leaks included).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build/sanitize -DCMAKE_BUILD_TYPE=Debug \
      -DCMAKE_CXX_FLAGS="-O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined" \
      -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" -DMPSKIT_TEST_EIGEN_CHECKS_EVERYWHERE=ON \
      -DMPSKIT_WERROR=ON -DMPSKIT_BUILD_EXAMPLES=OFF >/dev/null
cmake --build build/sanitize -j "$jobs"
cd build/sanitize
heavy='^(hydrostatic|hydrostatic_polygon|dam_break_lsmps|dam_break_slab|multires_hard|taylor_green_multires|dam_break_multires|poiseuille|poiseuille_multires|graded_start|multi_diameter_channel|multi_diameter_channel_multires|projection_stability|consumer)$'
if [ $# -eq 0 ]; then set -- -LE "$heavy"; fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
ctest --output-on-failure -j "$jobs" "$@"
