// Tanaka 2018 surface pieces for LSMPS scenes (surface/packing_ratio.hpp, normals.hpp, geometric.hpp): cost
// of one evaluation per particle on jittered periodic lattices (±0.1 L), list built once outside the timed
// loop with per_particle_radius{&L, 3.1}. Every particle is wanted; normals for geometric are computed once.
// Results with the flags used are recorded in docs/surface.md.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/geometric.hpp"
#include "mpskit/surface/normals.hpp"
#include "mpskit/surface/packing_ratio.hpp"

using namespace mpskit;

namespace {

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

const auto everyone = [](index_t) { return true; };
const auto no_wall = [](index_t) { return false; };

template <int D>
struct fixture {
  points<D> x, n;
  Eigen::VectorXd L, c;
  std::vector<std::uint8_t> degenerate, surface;
  search::neighbour_list<D> nl;
  explicit fixture(int m) {
    const double l0 = 0.01;
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> U(-0.1, 0.1);
    index_t count = 1;
    for (int a = 0; a < D; ++a) count *= m;
    x.resize(D, count);
    for (index_t k = 0; k < count; ++k) {
      index_t r = k;
      for (int a = 0; a < D; ++a) {
        x(a, k) = (static_cast<double>(r % m) + 0.5 + U(rng)) * l0;
        r /= m;
      }
    }
    L = Eigen::VectorXd::Constant(count, l0);
    search::domain<D> dom;
    dom.periodic.fill(true);
    dom.hi = vec<D>::Constant(m * l0);
    nl.build(exec::seq{}, x, search::per_particle_radius{&L, 3.1}, search::build_options<D>{0.0, dom});
    surface::normals(exec::seq{}, x, L, nl, everyone, n, degenerate);
  }
};

template <int D>
fixture<D>& get(int m) {
  static std::map<int, std::unique_ptr<fixture<D>>> cache;  // one fixture per size, built once
  std::unique_ptr<fixture<D>>& slot = cache[m];
  if (!slot) slot = std::make_unique<fixture<D>>(m);
  return *slot;
}

template <int D, class E>
void packing(benchmark::State& state) {
  fixture<D>& f = get<D>(static_cast<int>(state.range(0)));
  const surface::packing_ratio_params p;
  for (auto _ : state) {
    surface::packing_ratio(E{}, f.x, f.L, f.nl, everyone, no_wall, p, f.c);
    benchmark::DoNotOptimize(f.c.data());
  }
  state.SetItemsProcessed(state.iterations() * f.x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}

template <int D, class E>
void normals(benchmark::State& state) {
  fixture<D>& f = get<D>(static_cast<int>(state.range(0)));
  points<D> n;
  std::vector<std::uint8_t> deg;
  for (auto _ : state) {
    surface::normals(E{}, f.x, f.L, f.nl, everyone, n, deg);
    benchmark::DoNotOptimize(n.data());
  }
  state.SetItemsProcessed(state.iterations() * f.x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}

template <int D, class E>
void geometric(benchmark::State& state) {
  fixture<D>& f = get<D>(static_cast<int>(state.range(0)));
  const surface::geometric_params p;
  for (auto _ : state) {
    surface::geometric(E{}, f.x, f.L, f.nl, everyone, f.n, p, f.surface);
    benchmark::DoNotOptimize(f.surface.data());
  }
  state.SetItemsProcessed(state.iterations() * f.x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}

void bm_packing_ratio_2d_seq(benchmark::State& s) { packing<2, exec::seq>(s); }
void bm_packing_ratio_3d_seq(benchmark::State& s) { packing<3, exec::seq>(s); }
void bm_packing_ratio_2d_par(benchmark::State& s) { packing<2, exec::par>(s); }
void bm_normals_2d_seq(benchmark::State& s) { normals<2, exec::seq>(s); }
void bm_normals_3d_seq(benchmark::State& s) { normals<3, exec::seq>(s); }
void bm_normals_2d_par(benchmark::State& s) { normals<2, exec::par>(s); }
void bm_geometric_2d_seq(benchmark::State& s) { geometric<2, exec::seq>(s); }
void bm_geometric_3d_seq(benchmark::State& s) { geometric<3, exec::seq>(s); }
void bm_geometric_2d_par(benchmark::State& s) { geometric<2, exec::par>(s); }

}  // namespace

BENCHMARK(bm_packing_ratio_2d_seq)->Arg(100)->Arg(316)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_packing_ratio_3d_seq)->Arg(30)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_packing_ratio_2d_par)->Arg(316)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_normals_2d_seq)->Arg(100)->Arg(316)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_normals_3d_seq)->Arg(30)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_normals_2d_par)->Arg(316)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_geometric_2d_seq)->Arg(100)->Arg(316)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_geometric_3d_seq)->Arg(30)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(bm_geometric_2d_par)->Arg(316)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
