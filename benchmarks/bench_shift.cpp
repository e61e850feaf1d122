// Tanaka 2018 particle shifting (regularize/tanaka_shift.hpp, eqs. 93–100): cost of one displacement
// evaluation per particle on jittered periodic lattices (±0.15 L, ∇c random, every 4th particle
// tangential-only), list built once outside the timed loop with per_particle_radius{&L, 3.1}.
// Results with the flags used are recorded in docs/regularize.md.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "mpskit/regularize/tanaka_shift.hpp"
#include "mpskit/search/neighbour_list.hpp"

using namespace mpskit;

namespace {

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

template <int D>
struct fixture {
  points<D> x, grad_c, n, dx;
  Eigen::VectorXd L;
  search::neighbour_list<D> nl;
  std::vector<std::uint8_t> tangential, active;
  explicit fixture(int m) {
    const double l0 = 0.01;
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> U(-0.15, 0.15), G(-40.0, 40.0);
    index_t count = 1;
    for (int a = 0; a < D; ++a) count *= m;
    x.resize(D, count);
    grad_c.resize(D, count);
    n.setZero(D, count);
    for (index_t k = 0; k < count; ++k) {
      index_t r = k;
      for (int a = 0; a < D; ++a) {
        x(a, k) = (static_cast<double>(r % m) + 0.5 + U(rng)) * l0;
        grad_c(a, k) = G(rng);
        r /= m;
      }
      n.col(k) = grad_c.col(k).normalized();
    }
    L = Eigen::VectorXd::Constant(count, l0);
    search::domain<D> dom;
    dom.periodic.fill(true);
    dom.hi = vec<D>::Constant(m * l0);
    nl.build(exec::seq{}, x, search::per_particle_radius{&L, 3.1}, search::build_options<D>{0.0, dom});
    tangential.assign(static_cast<std::size_t>(count), 0);
    for (std::size_t k = 0; k < tangential.size(); k += 4) tangential[k] = 1;
    active.assign(static_cast<std::size_t>(count), 1);
  }
};

template <int D, class E>
void run(benchmark::State& state) {
  static std::map<int, std::unique_ptr<fixture<D>>> cache;  // one fixture per size, built once
  std::unique_ptr<fixture<D>>& slot = cache[static_cast<int>(state.range(0))];
  if (!slot) slot = std::make_unique<fixture<D>>(static_cast<int>(state.range(0)));
  fixture<D>& f = *slot;
  const regularize::tanaka_shift_params p;
  for (auto _ : state) {
    const regularize::tanaka_shift_report r = regularize::tanaka_shift_displacement<D>(
        E{}, f.x, f.L, f.nl, [](index_t) { return true; }, f.grad_c, f.n, f.tangential, f.active, p, f.dx);
    benchmark::DoNotOptimize(r.moved);
  }
  state.SetItemsProcessed(state.iterations() * f.x.cols());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}

void bm_tanaka_shift_2d_seq(benchmark::State& s) { run<2, exec::seq>(s); }
void bm_tanaka_shift_2d_par(benchmark::State& s) { run<2, exec::par>(s); }
void bm_tanaka_shift_3d_seq(benchmark::State& s) { run<3, exec::seq>(s); }
void bm_tanaka_shift_3d_par(benchmark::State& s) { run<3, exec::par>(s); }

}  // namespace

BENCHMARK(bm_tanaka_shift_2d_seq)->Arg(100)->Arg(316)->Unit(benchmark::kMillisecond);  // 1e4, 1e5 particles
BENCHMARK(bm_tanaka_shift_2d_par)->Arg(316)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_tanaka_shift_3d_seq)->Arg(30)->Unit(benchmark::kMillisecond);  // 27 000 particles
BENCHMARK(bm_tanaka_shift_3d_par)->Arg(30)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
