// Geometry micro-benchmarks (issue 6): closest-point queries per second on a ~1e5-triangle mesh and
// a 1e4-segment polyline, segment-crossing tests, and hierarchy refit time after a rigid move.
// Results with the flags used are recorded in docs/geometry.md.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/polygon_set.hpp"

namespace geo = mpskit::geometry;
using mpskit::vec;

namespace {

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

// Cylinder of radius 1, height 2: 500 segments × 100 layers × 2 = 100 000 side triangles + 1000 cap
// triangles. Queries: random points in the shell 0.9 < r < 1.1 (particles near the wall).
const geo::polygon_set<3>& mesh3() {
  static const geo::polygon_set<3> s(
      geo::cylinder(vec<3>(0, 0, 0), 1.0, 2.0, 500, 100, true, geo::fluid_side::inside), {},
      geo::prescribed_motion<3>::rotation(vec<3>(0, 0, 0), vec<3>(0, 0, 1.0)));
  return s;
}
// Gear outline with 2500 teeth: 4 vertices per tooth = 10 000 segments.
const geo::polygon_set<2>& mesh2() {
  static const geo::polygon_set<2> s(geo::gear(vec<2>(0, 0), 2.0, 1.9, 2500), {},
                                     geo::prescribed_motion<2>::rotation(vec<2>(0, 0), 1.0));
  return s;
}

template <int D>
std::vector<vec<D>> shell_points(std::size_t n, double r0, double r1, double zmax) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<vec<D>> p(n);
  for (vec<D>& x : p) {
    const double th = 2 * 3.141592653589793 * u(rng), r = r0 + (r1 - r0) * u(rng);
    if constexpr (D == 2) {
      x = vec<2>(r * std::cos(th), r * std::sin(th));
    } else {
      x = vec<3>(r * std::cos(th), r * std::sin(th), zmax * u(rng));
    }
  }
  return p;
}

template <int D>
void run_closest(benchmark::State& state, const geo::polygon_set<D>& s, double max_distance) {
  const std::vector<vec<D>> q = shell_points<D>(4096, 0.9, 1.1, 2.0);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.closest(q[i], max_distance));
    i = (i + 1) & 4095;
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}

void bm_closest_3d_1e5_triangles(benchmark::State& st) { run_closest<3>(st, mesh3(), 1e300); }
void bm_closest_3d_1e5_triangles_within_0p05(benchmark::State& st) { run_closest<3>(st, mesh3(), 0.05); }
void bm_closest_2d_1e4_segments(benchmark::State& st) { run_closest<2>(st, mesh2(), 1e300); }
void bm_query_3d_1e5_triangles(benchmark::State& state) {  // closest + sign + normal + curvature + velocity
  const std::vector<vec<3>> q = shell_points<3>(4096, 0.9, 1.1, 2.0);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(mesh3().query(q[i], 0.05));
    i = (i + 1) & 4095;
  }
  state.SetItemsProcessed(state.iterations());
}
void bm_crosses_3d_1e5_triangles(benchmark::State& state) {  // short pair segments (length ~ 0.03)
  const std::vector<vec<3>> a = shell_points<3>(4096, 0.95, 1.05, 2.0);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> nd(0.0, 0.02);
  std::vector<vec<3>> b(a.size());
  for (std::size_t k = 0; k < a.size(); ++k) b[k] = a[k] + vec<3>(nd(rng), nd(rng), nd(rng));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(mesh3().crosses(a[i], b[i]));
    i = (i + 1) & 4095;
  }
  state.SetItemsProcessed(state.iterations());
}
void bm_refit_3d_1e5_triangles(benchmark::State& state) {  // move_to: transform vertices/normals + refit
  geo::polygon_set<3> s = mesh3();
  double t = 0.0;
  for (auto _ : state) {
    t += 1e-3;
    s.move_to(t);
  }
}
void bm_refit_2d_1e4_segments(benchmark::State& state) {
  geo::polygon_set<2> s = mesh2();
  double t = 0.0;
  for (auto _ : state) {
    t += 1e-3;
    s.move_to(t);
  }
}
void bm_build_3d_1e5_triangles(benchmark::State& state) {
  const geo::polygon_mesh<3> m =
      geo::cylinder(vec<3>(0, 0, 0), 1.0, 2.0, 500, 100, true, geo::fluid_side::inside);
  for (auto _ : state) benchmark::DoNotOptimize(geo::polygon_set<3>(m));
}

}  // namespace

BENCHMARK(bm_closest_3d_1e5_triangles);
BENCHMARK(bm_closest_3d_1e5_triangles_within_0p05);
BENCHMARK(bm_query_3d_1e5_triangles);
BENCHMARK(bm_closest_2d_1e4_segments);
BENCHMARK(bm_crosses_3d_1e5_triangles);
BENCHMARK(bm_refit_3d_1e5_triangles)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_refit_2d_1e4_segments)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_build_3d_1e5_triangles)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
