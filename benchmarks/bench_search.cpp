// Neighbour-search micro-benchmarks (issue 2): cell-list build + state reorder, CSR list build (uniform
// and mixed radii), a classic MPS Laplacian sweep over the stored list, and nanoflann kd-tree radius
// queries. 2D jittered square lattice (spacing l0, jitter uniform in ±0.1 l0 per axis, fixed seed),
// effective radius re = 3.1 l0. Sizes 1e4, 1e5, 1e6 (nominal; the lattice is side² with side = round(√n)).
//
// Threads: every loop runs through exec::par; the number of threads is OpenMP's default, i.e. set it
// with OMP_NUM_THREADS (benchmarks/run_search.sh runs the binary once with 1 and once with 2). The
// `threads` counter records what was used. Times are wall-clock (UseRealTime) because the work runs on
// OpenMP threads. Results and flags: docs/performance.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/kernel/classic.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/search/cell_list.hpp"
#include "mpskit/search/kdtree.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

namespace {

using mpskit::index_t;
using mpskit::points;
namespace search = mpskit::search;
namespace exec = mpskit::exec;

constexpr double l0 = 0.01;        // lattice spacing (m)
constexpr double re_ratio = 3.1;   // re = 3.1 l0 (classic MPS Laplacian radius)
constexpr double re = re_ratio * l0;
constexpr double jitter = 0.1;     // ± jitter in l0

// Seed of the jitter, of the shuffled order and of the mixed-radius lengths; MPSKIT_BENCH_SEED overrides.
std::uint64_t seed() {
  static const std::uint64_t s = [] {
    const char* e = std::getenv("MPSKIT_BENCH_SEED");
    return e ? std::strtoull(e, nullptr, 10) : std::uint64_t{20261122};
  }();
  return s;
}

// Time per item: Google Benchmark divides a rate counter by the (real) time and kInvert turns it into
// seconds per item, printed with an SI prefix (e.g. "per_pair=2.5ns"; JSON holds seconds).
benchmark::Counter time_per(double items_per_iteration, benchmark::IterationCount iterations) {
  return benchmark::Counter(items_per_iteration * double(iterations),
                            benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void common_counters(benchmark::State& st, index_t n) {
  st.counters["n"] = double(n);
  st.counters["threads"] = double(mpskit::max_threads());
}

// Jittered lattice in lattice (row-major) order.
points<2> lattice_raw(index_t nominal) {
  const index_t side = static_cast<index_t>(std::llround(std::sqrt(double(nominal))));
  std::mt19937_64 rng(seed());
  std::uniform_real_distribution<double> u(-jitter * l0, jitter * l0);
  points<2> x(2, side * side);
  for (index_t b = 0; b < side; ++b)
    for (index_t a = 0; a < side; ++a) {
      const index_t i = a + side * b;
      x(0, i) = double(a) * l0 + u(rng);
      x(1, i) = double(b) * l0 + u(rng);
    }
  return x;
}

// The lattice in cell order (as a simulation holds it after the previous step's reorder), cached.
const points<2>& lattice(index_t nominal) {
  static std::map<index_t, points<2>> cache;
  auto it = cache.find(nominal);
  if (it != cache.end()) return it->second;
  points<2> x = lattice_raw(nominal);
  search::cell_list<2> cells;
  cells.build(exec::seq{}, x, re * 1.1);
  points<2> y(2, x.cols());
  for (index_t s = 0; s < x.cols(); ++s) y.col(s) = x.col(cells.order()[static_cast<std::size_t>(s)]);
  return cache.emplace(nominal, std::move(y)).first->second;
}

// Per-particle lengths L uniform in [l0, 3 l0] (radius ratio 3), cached.
const Eigen::VectorXd& mixed_lengths(index_t nominal) {
  static std::map<index_t, Eigen::VectorXd> cache;
  auto it = cache.find(nominal);
  if (it != cache.end()) return it->second;
  const index_t n = lattice(nominal).cols();
  std::mt19937_64 rng(seed() + 1);
  std::uniform_real_distribution<double> u(l0, 3.0 * l0);
  Eigen::VectorXd L(n);
  for (index_t i = 0; i < n; ++i) L[i] = u(rng);
  return cache.emplace(nominal, std::move(L)).first->second;
}

// ---- (1) cell-list build + state reorder ------------------------------------------------------------
// Arg 0: nominal n; arg 1: 0 = input already in cell order (steady state of a simulation), 1 = input in
// a random order (first step; the positions are restored outside the timed region each iteration);
// arg 2: 1 = also state.reorder(cells.order()) (all core fields of particle_state<2>).
void cell_build(benchmark::State& st) {
  const index_t nominal = st.range(0);
  const bool shuffled = st.range(1) != 0, reorder = st.range(2) != 0;
  points<2> x0 = lattice(nominal);
  const index_t n = x0.cols();
  if (shuffled) {
    std::vector<index_t> p(static_cast<std::size_t>(n));
    std::iota(p.begin(), p.end(), index_t{0});
    std::shuffle(p.begin(), p.end(), std::mt19937_64(seed() + 2));
    points<2> y(2, n);
    for (index_t k = 0; k < n; ++k) y.col(k) = x0.col(p[static_cast<std::size_t>(k)]);
    x0 = y;
  }
  mpskit::particle_state<2> state(n);
  state.x() = x0;
  search::cell_list<2> cells;
  for (auto _ : st) {
    if (shuffled) {
      st.PauseTiming();
      state.x() = x0;
      st.ResumeTiming();
    }
    cells.build(exec::par{}, state.x(), re * 1.1);
    if (reorder) {
      mpskit::resize_report r = state.reorder(cells.order());
      benchmark::DoNotOptimize(r.reordered);
    }
    benchmark::ClobberMemory();
  }
  common_counters(st, n);
  st.counters["per_particle"] = time_per(double(n), st.iterations());
}

// ---- (2) CSR build, uniform radius -------------------------------------------------------------------
// Arg 1: skin in per mille (0 or 100). Build radius re (1 + skin); ns per stored (directed) pair.
void csr_build(benchmark::State& st) {
  const points<2>& x = lattice(st.range(0));
  const double skin = double(st.range(1)) * 1e-3;
  search::neighbour_list<2> nl;
  for (auto _ : st) {
    nl.build(exec::par{}, x, search::uniform_radius{re}, {skin, {}});
    benchmark::ClobberMemory();
  }
  common_counters(st, x.cols());
  st.counters["pairs_per_particle"] = double(nl.pairs()) / double(x.cols());
  st.counters["per_pair"] = time_per(double(nl.pairs()), st.iterations());
  st.counters["per_particle"] = time_per(double(x.cols()), st.iterations());
}

// ---- (5) CSR build, mixed radii: R_i = 3.1 L_i, L_i uniform in [l0, 3 l0] -----------------------------
void csr_build_mixed(benchmark::State& st) {
  const points<2>& x = lattice(st.range(0));
  const Eigen::VectorXd& L = mixed_lengths(st.range(0));
  const double skin = double(st.range(1)) * 1e-3;
  search::neighbour_list<2> nl;
  for (auto _ : st) {
    nl.build(exec::par{}, x, search::per_particle_radius{&L, re_ratio}, {skin, {}});
    benchmark::ClobberMemory();
  }
  common_counters(st, x.cols());
  st.counters["pairs_per_particle"] = double(nl.pairs()) / double(x.cols());
  st.counters["per_pair"] = time_per(double(nl.pairs()), st.iterations());
  st.counters["per_particle"] = time_per(double(x.cols()), st.iterations());
}

// ---- (3) sweep: classic MPS Laplacian of a scalar field over the stored list ----------------------------
// List built at re (1 + 0.1 skin); the sweep reads it at re (support 3.1 l0, rule own). ns per pair
// counted as the pairs with r < re (per_pair). Arg 1: 0 = op::mps<2, kernel::classic>::laplacian, 1 = a hand
// loop through list.for_each_neighbour with the same arithmetic (bitwise the same result, checked).
struct sweep_fixture {
  const points<2>* x = nullptr;
  search::neighbour_list<2> nl;
  Eigen::VectorXd phi;
  index_t pairs_in_re = 0;
};

const sweep_fixture& sweep_setup(index_t nominal) {
  static std::map<index_t, sweep_fixture> cache;
  auto it = cache.find(nominal);
  if (it != cache.end()) return it->second;
  sweep_fixture f;
  f.x = &lattice(nominal);
  const index_t n = f.x->cols();
  f.nl.build(exec::seq{}, *f.x, search::uniform_radius{re}, {0.1, {}});
  f.phi.resize(n);
  for (index_t i = 0; i < n; ++i) f.phi[i] = (*f.x)(0, i) * (*f.x)(0, i) + 0.5 * (*f.x)(1, i);  // ∇²φ = 2
  const search::support<search::uniform_radius> sup{{re}, search::radius_rule::own};
  for (index_t i = 0; i < n; ++i)
    f.nl.for_each_neighbour(*f.x, i, sup, [&](index_t, const mpskit::vec<2>&, double) { ++f.pairs_in_re; });
  return cache.emplace(nominal, std::move(f)).first->second;
}

void sweep(benchmark::State& st) {
  const sweep_fixture& f = sweep_setup(st.range(0));
  const bool hand = st.range(1) != 0;
  const points<2>& x = *f.x;
  const index_t n = x.cols();
  const mpskit::op::mps<2, mpskit::kernel::classic> op({l0, 2.1, re_ratio});
  const search::support<search::uniform_radius> sup = op.large_support();
  const double c = 2.0 * 2 / (op.lambda0() * op.n0_large());  // Tanaka 2018 eq. 10 coefficient 2d/(λ0 n0)
  const double rl = op.re_large();
  Eigen::VectorXd lap(n), ref(n);
  // op::mps::laplacian(x, nl, i, VectorXd) is ambiguous between its scalar (Ref<const VectorXd>) and
  // vector (points<D>) overloads: pass an explicit Ref.
  const Eigen::Ref<const Eigen::VectorXd> phi_ref(f.phi);
  const auto by_op = [&](Eigen::VectorXd& out) {
    mpskit::for_each_particle(exec::par{}, n, [&](index_t i) { out[i] = op.laplacian(x, f.nl, i, phi_ref); });
  };
  const auto by_hand = [&](Eigen::VectorXd& out) {
    mpskit::for_each_particle(exec::par{}, n, [&](index_t i) {
      double s = 0.0;
      const double pi = f.phi[i];
      f.nl.for_each_neighbour(x, i, sup, [&](index_t j, const mpskit::vec<2>&, double r2) {
        s += (c * mpskit::kernel::classic::w(std::sqrt(r2), rl)) * (f.phi[j] - pi);
      });
      out[i] = s;
    });
  };
  for (auto _ : st) {
    if (hand) by_hand(lap);
    else by_op(lap);
    benchmark::DoNotOptimize(lap.data());
    benchmark::ClobberMemory();
  }
  by_op(ref);
  if (hand) by_hand(lap);
  common_counters(st, n);
  st.counters["pairs_per_particle"] = double(f.pairs_in_re) / double(n);
  st.counters["per_pair"] = time_per(double(f.pairs_in_re), st.iterations());
  st.counters["hand_minus_op_max"] = (lap - ref).cwiseAbs().maxCoeff();
}

// Mixed-radius sweep: the same Laplacian form read through per_particle_radius (R_i = 3.1 L_i) with the
// pair_mean rule (Tang & Wan's averaged cut-off) on the mixed list; ns per pair inside the support.
void sweep_mixed(benchmark::State& st) {
  const points<2>& x = lattice(st.range(0));
  const Eigen::VectorXd& L = mixed_lengths(st.range(0));
  const index_t n = x.cols();
  const search::per_particle_radius rad{&L, re_ratio};
  search::neighbour_list<2> nl;
  nl.build(exec::par{}, x, rad, {0.1, {}});
  const search::support<search::per_particle_radius> sup{rad, search::radius_rule::pair_mean};
  Eigen::VectorXd phi(n), lap(n);
  for (index_t i = 0; i < n; ++i) phi[i] = x(0, i) * x(0, i) + 0.5 * x(1, i);
  index_t pairs = 0;
  for (index_t i = 0; i < n; ++i)
    nl.for_each_neighbour(x, i, sup, [&](index_t, const mpskit::vec<2>&, double) { ++pairs; });
  for (auto _ : st) {
    mpskit::for_each_particle(exec::par{}, n, [&](index_t i) {
      double s = 0.0;
      const double pi = phi[i], ri = rad(i);
      nl.for_each_neighbour(x, i, sup, [&](index_t j, const mpskit::vec<2>&, double r2) {
        const double rij = 0.5 * (ri + rad(j));
        s += mpskit::kernel::classic::w(std::sqrt(r2), rij) * (phi[j] - pi);
      });
      lap[i] = s;
    });
    benchmark::DoNotOptimize(lap.data());
    benchmark::ClobberMemory();
  }
  common_counters(st, n);
  st.counters["pairs_per_particle"] = double(pairs) / double(n);
  st.counters["per_pair"] = time_per(double(pairs), st.iterations());
}

// ---- (4) nanoflann kd-tree radius queries (search::kdtree<2>) ---------------------------------------------
// One query at re per particle, tree built outside the timed loop; ns per pair found (j ≠ i: the query
// point itself, also returned, is not counted).
void kdtree_query(benchmark::State& st) {
  const points<2>& x = lattice(st.range(0));
  const index_t n = x.cols();
  const search::kdtree<2> tree(x);
  std::vector<index_t> found(static_cast<std::size_t>(n));
  for (auto _ : st) {
    mpskit::for_each_particle(exec::par{}, n, [&](index_t i) {
      thread_local std::vector<index_t> out;
      tree.radius_query(x.col(i), re, out);
      found[static_cast<std::size_t>(i)] = static_cast<index_t>(out.size()) - 1;
    });
    benchmark::ClobberMemory();
  }
  const double pairs = double(std::accumulate(found.begin(), found.end(), index_t{0}));
  common_counters(st, n);
  st.counters["pairs_per_particle"] = pairs / double(n);
  st.counters["per_pair"] = time_per(pairs, st.iterations());
}

void kdtree_build(benchmark::State& st) {
  const points<2>& x = lattice(st.range(0));
  for (auto _ : st) {
    search::kdtree<2> tree(x);
    benchmark::DoNotOptimize(&tree);
  }
  common_counters(st, x.cols());
  st.counters["per_particle"] = time_per(double(x.cols()), st.iterations());
}

constexpr std::int64_t sizes[] = {10000, 100000, 1000000};

void sizes_x(benchmark::internal::Benchmark* b, std::vector<std::int64_t> second) {
  for (std::int64_t n : sizes) {
    if (second.empty()) b->Args({n});
    for (std::int64_t a : second) b->Args({n, a});
  }
  b->UseRealTime()->Unit(benchmark::kMillisecond);
}

}  // namespace

BENCHMARK(cell_build)->ArgNames({"n", "shuffled", "reorder"})->Apply([](benchmark::internal::Benchmark* b) {
  for (std::int64_t n : sizes)
    for (std::int64_t s : {0, 1})
      for (std::int64_t r : {0, 1}) b->Args({n, s, r});
  b->UseRealTime()->Unit(benchmark::kMillisecond);
});
BENCHMARK(csr_build)->ArgNames({"n", "skin_permille"})->Apply([](benchmark::internal::Benchmark* b) {
  sizes_x(b, {0, 100});
});
BENCHMARK(csr_build_mixed)->ArgNames({"n", "skin_permille"})->Apply([](benchmark::internal::Benchmark* b) {
  sizes_x(b, {0, 100});
});
BENCHMARK(sweep)->ArgNames({"n", "hand"})->Apply([](benchmark::internal::Benchmark* b) {
  sizes_x(b, {0, 1});
});
BENCHMARK(sweep_mixed)->ArgNames({"n"})->Apply([](benchmark::internal::Benchmark* b) { sizes_x(b, {}); });
BENCHMARK(kdtree_query)->ArgNames({"n"})->Apply([](benchmark::internal::Benchmark* b) { sizes_x(b, {}); });
BENCHMARK(kdtree_build)->ArgNames({"n"})->Apply([](benchmark::internal::Benchmark* b) { sizes_x(b, {}); });

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("mpskit_flags", MPSKIT_BENCH_FLAGS);
  benchmark::AddCustomContext("mpskit_seed", std::to_string(seed()));
  benchmark::AddCustomContext("mpskit_threads", std::to_string(mpskit::max_threads()));
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
