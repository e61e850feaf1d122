// The PPE's floating parts (ppe/floating_parts.hpp): the union-find check every_part_anchored against the
// transpose-and-search search_floating_parts that find_floating_parts ran alone before the check, on the
// pattern of a 2D LSMPS pressure matrix: an n × n lattice, every pair within 2.1 L coupled (13 entries per
// inner row), the top row Dirichlet ("anchored": the free-surface case, where the check answers alone) or no
// row Dirichlet ("floating": the periodic or closed case, where find_floating_parts pays the check and the
// search). Results with the flags used are recorded in docs/performance.md "Floating parts".
#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "mpskit/ppe/floating_parts.hpp"

using namespace mpskit;

namespace {

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

struct fixture {
  ppe::matrix A;
  std::vector<std::uint8_t> top, none;
  explicit fixture(index_t n) {
    std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
    const auto at = [n](index_t i, index_t j) { return i * n + j; };
    for (index_t i = 0; i < n; ++i)
      for (index_t j = 0; j < n; ++j)
        for (index_t di = -2; di <= 2; ++di)
          for (index_t dj = -2; dj <= 2; ++dj) {
            const index_t k = i + di, l = j + dj;
            if (k < 0 || l < 0 || k >= n || l >= n || di * di + dj * dj > 4) continue;
            t.emplace_back(at(i, j), at(k, l), di == 0 && dj == 0 ? -12.0 : 1.0);
          }
    A.resize(n * n, n * n);
    A.setFromTriplets(t.begin(), t.end());
    top.assign(static_cast<std::size_t>(n * n), 0);
    none = top;
    for (index_t j = 0; j < n; ++j) top[static_cast<std::size_t>(at(n - 1, j))] = 1;
  }
};

fixture& get(benchmark::State& state) {
  static std::map<index_t, std::unique_ptr<fixture>> cache;  // one fixture per size, built once
  std::unique_ptr<fixture>& slot = cache[static_cast<index_t>(state.range(0))];
  if (!slot) slot = std::make_unique<fixture>(static_cast<index_t>(state.range(0)));
  return *slot;
}

const auto key = [](index_t r) { return r; };

void bm_anchored_check(benchmark::State& state) {
  fixture& f = get(state);
  for (auto _ : state) benchmark::DoNotOptimize(ppe::every_part_anchored(f.A, f.top));
  state.SetItemsProcessed(state.iterations() * f.A.rows());
  state.SetLabel(MPSKIT_BENCH_FLAGS);
}
void bm_anchored_search(benchmark::State& state) {
  fixture& f = get(state);
  for (auto _ : state) benchmark::DoNotOptimize(ppe::search_floating_parts(f.A, f.top, false, key).size());
  state.SetItemsProcessed(state.iterations() * f.A.rows());
}
void bm_floating_find(benchmark::State& state) {
  fixture& f = get(state);
  for (auto _ : state) benchmark::DoNotOptimize(ppe::find_floating_parts(f.A, f.none, false, key).size());
  state.SetItemsProcessed(state.iterations() * f.A.rows());
}
void bm_floating_search(benchmark::State& state) {
  fixture& f = get(state);
  for (auto _ : state) benchmark::DoNotOptimize(ppe::search_floating_parts(f.A, f.none, false, key).size());
  state.SetItemsProcessed(state.iterations() * f.A.rows());
}

}  // namespace

// 40² = 1600 rows (the 4 mm dam break's order), 160² = 25 600 (its 1 mm)
BENCHMARK(bm_anchored_check)->Arg(40)->Arg(160)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_anchored_search)->Arg(40)->Arg(160)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_floating_find)->Arg(40)->Arg(160)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_floating_search)->Arg(40)->Arg(160)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
