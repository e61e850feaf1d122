// Polygon-wall micro-benchmarks (issue 7): imaginary copies per step (2D tank, 3D box, ~1e5 particles),
// the wall-crossing guard, and the cost of the thin-wall visibility predicate in a neighbour-list build.
// Results with the flags used are recorded in docs/walls.md.
#include <benchmark/benchmark.h>

#include "support/support.hpp"

#include <cstdint>
#include <random>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/wall/crossing_guard.hpp"
#include "mpskit/wall/imaginary.hpp"
#include "mpskit/wall/visibility.hpp"

namespace geo = mpskit::geometry;
using mpskit::index_t;
using mpskit::points;
using mpskit::vec;

namespace {

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

constexpr int m2 = 316;  // 2D: 316² ≈ 1e5 particles in the unit square
constexpr int m3 = 46;   // 3D: 46³ ≈ 9.7e4 particles in the unit cube

/// Cell-centred m^D lattice in the unit box, jittered by ±0.1 h (tests/support's lattice, shifted by h/2).
template <int D>
points<D> lattice(int m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const double h = 1.0 / m;
  points<D> x = mpskit::test::jittered_lattice<D>(m, h, 0.1, rng);
  x.array() += 0.5 * h;
  return x;
}

const auto all = [](index_t) { return true; };

// 2D tank [0,1]² (64 segments per side) plus a double-sided baffle x = 0.5, y in [0, 0.6].
const geo::wall_collection<2>& walls2() {
  static const geo::wall_collection<2> w = [] {
    geo::wall_collection<2> c;
    c.add(geo::polygon_set<2>(geo::tank(vec<2>(0, 0), vec<2>(1, 1), 64)));
    geo::polygon_mesh<2> b;
    b.vertices.resize(2, 2);
    b.vertices << 0.5, 0.5, 0.0, 0.6;
    b.elements.resize(2, 1);
    b.elements << 0, 1;
    c.add(geo::polygon_set<2>(mpskit::wall::double_sided(b)));
    return c;
  }();
  return w;
}

void BM_imaginary_2d(benchmark::State& state) {
  const points<2> x = lattice<2>(m2, 1);
  const Eigen::VectorXd L = Eigen::VectorXd::Constant(x.cols(), 1.0 / m2);
  std::vector<mpskit::wall::imaginary_copy<2>> out;
  for (auto _ : state) {
    mpskit::wall::make_imaginary<2>(x, L, x.cols(), all, walls2(), {}, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["particles"] = double(x.cols());
  state.counters["copies"] = double(out.size());
  state.SetItemsProcessed(state.iterations() * x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}
BENCHMARK(BM_imaginary_2d)->Unit(benchmark::kMillisecond);

void BM_imaginary_3d(benchmark::State& state) {
  static const geo::polygon_set<3> w(geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::inside, 16));
  const points<3> x = lattice<3>(m3, 2);
  const Eigen::VectorXd L = Eigen::VectorXd::Constant(x.cols(), 1.0 / m3);
  std::vector<mpskit::wall::imaginary_copy<3>> out;
  for (auto _ : state) {
    mpskit::wall::make_imaginary<3>(x, L, x.cols(), all, w, {}, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["particles"] = double(x.cols());
  state.counters["copies"] = double(out.size());
  state.SetItemsProcessed(state.iterations() * x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}
BENCHMARK(BM_imaginary_3d)->Unit(benchmark::kMillisecond);

void BM_guard_2d(benchmark::State& state) {
  const points<2> x0 = lattice<2>(m2, 3);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0.0, 0.3 / m2);  // moves of ~0.3 L: a few cross the walls
  points<2> x1 = x0;
  for (index_t i = 0; i < x1.cols(); ++i) x1.col(i) += vec<2>(g(rng), g(rng));
  const Eigen::VectorXd L = Eigen::VectorXd::Constant(x0.cols(), 1.0 / m2);
  points<2> y(2, x0.cols()), u(2, x0.cols());
  index_t guarded = 0;
  for (auto _ : state) {
    y = x1;  // the copy is part of the timing (0.2 ms of memory traffic at 1e5)
    u.setZero();
    guarded = mpskit::wall::guard_crossings<2>(x0, y, u, L, x0.cols(), walls2(), {});
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["guarded"] = double(guarded);
  state.SetItemsProcessed(state.iterations() * x0.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}
BENCHMARK(BM_guard_2d)->Unit(benchmark::kMillisecond);

// Neighbour-list build over real + imaginary particles (R = 3.1 L, pair rule max), without (arg 0) and
// with (arg 1) the wall_visibility predicate (prepare() included).
void BM_build_visibility_2d(benchmark::State& state) {
  const bool visible = state.range(0) != 0;
  points<2> x = lattice<2>(m2, 5);
  const index_t n_real = x.cols();
  Eigen::VectorXd L = Eigen::VectorXd::Constant(n_real, 1.0 / m2);
  std::vector<mpskit::wall::imaginary_copy<2>> c;
  mpskit::wall::make_imaginary<2>(x, L, n_real, all, walls2(), {}, c);
  mpskit::wall::write_ghosts<2>(c, n_real, x, L);
  const mpskit::search::per_particle_radius R{&L, 3.1};
  mpskit::search::neighbour_list<2> nl;
  mpskit::wall::wall_visibility<2, geo::wall_collection<2>> vis{&walls2(), &x, n_real, &c};
  for (auto _ : state) {
    if (visible) {
      vis.prepare(mpskit::exec::seq{}, 3.1 / m2);
      nl.build(mpskit::exec::seq{}, x, R, {}, vis);
    } else {
      nl.build(mpskit::exec::seq{}, x, R);
    }
    benchmark::DoNotOptimize(nl.pairs());
  }
  state.counters["particles"] = double(x.cols());
  state.counters["pairs"] = double(nl.pairs());
  state.SetItemsProcessed(state.iterations() * x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}
BENCHMARK(BM_build_visibility_2d)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
