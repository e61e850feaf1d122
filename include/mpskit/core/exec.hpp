#pragma once
/// \file core/exec.hpp
/// \brief The one loop primitive (ARCHITECTURE.md §5): `for_each_particle(exec, n, f)` and a block
/// reduction whose result does not depend on the thread count. Physics code never spells `#pragma omp`.
#include <algorithm>
#include <concepts>
#include <cstddef>
#include <vector>

#include "mpskit/core/dimension.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace mpskit::exec {
/// Sequential execution.
struct seq {};
/// Parallel execution over OpenMP threads (sequential when the consumer does not link mpskit::openmp).
struct par {};
}  // namespace mpskit::exec

namespace mpskit {

/// An execution tag: exec::seq or exec::par.
template <class E>
concept Execution = std::same_as<E, exec::seq> || std::same_as<E, exec::par>;

/// Number of threads exec::par uses now (1 without OpenMP).
inline int max_threads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

/// Below this many items exec::par runs sequentially: a parallel region costs microseconds on an idle
/// machine and a scheduler time slice (milliseconds) on a loaded one (measured: a 1358-particle dam
/// break ran 36× slower with 2 threads than with 1 on a shared 2-core machine). Results do not depend
/// on it: every call writes only its own slot.
inline constexpr index_t parallel_min_items = 4096;

/// Calls f(i) for i in [0, n). Each call must write only slot i (ARCHITECTURE.md §5).
template <Execution E, class F>
void for_each_particle(E, index_t n, F&& f) {
  if constexpr (std::same_as<E, exec::par>) {
#ifdef _OPENMP
    if (n >= parallel_min_items) {
#pragma omp parallel for schedule(static)
      for (index_t i = 0; i < n; ++i) f(i);
      return;
    }
#endif
  }
  for (index_t i = 0; i < n; ++i) f(i);
}

/// Holds Eigen's own OpenMP threads to one while it lives when `items` < `min_items` (by default
/// parallel_min_items, the rule of for_each_particle applied to Eigen): Eigen's sparse matrix × vector
/// product goes parallel above 20 000 non-zeros whatever the rows (a 2D PPE of ≈ 600 unknowns), with a
/// parallel region per product, two per BiCGSTAB iteration. Measured (benchmarks/bench_eigen_threads.cpp,
/// docs/solver.md deviation 7; a 2D channel of 1900 unknowns, two threads): with one other busy thread on the
/// 2-core machine the run took 2.66× as long without the hold; on an idle machine the two do not differ
/// beyond noise (0.98×). The setting is Eigen's, process-wide (Eigen::setNbThreads): it is restored on
/// destruction, a value the caller had pinned equal to omp_get_max_threads() becomes "follow OpenMP" again,
/// and two simulations solving at once on different std::threads share it. Results do not change: each row of
/// the product is one thread's.
class eigen_threads_scope {
 public:
  explicit eigen_threads_scope(index_t items, index_t min_items = parallel_min_items) {
    const int now = Eigen::nbThreads();
    if (items < min_items && now > 1) {
      restore_ = now == max_threads() ? 0 : now;  // 0: Eigen follows omp_get_max_threads() again
      Eigen::setNbThreads(1);
      held_ = true;
    }
  }
  eigen_threads_scope(const eigen_threads_scope&) = delete;
  eigen_threads_scope& operator=(const eigen_threads_scope&) = delete;
  ~eigen_threads_scope() {
    if (held_) Eigen::setNbThreads(restore_);
  }
  bool held() const { return held_; }  ///< whether Eigen was held to one thread

 private:
  int restore_ = 0;
  bool held_ = false;
};

/// Fixed block size of reductions: partial results per block of this many items are combined in
/// block order, so a reduction is bitwise identical for any thread count.
inline constexpr index_t reduction_block = 4096;

/// Calls f(b, begin, end) for each fixed block b of [0, n) (blocks of `block` items).
template <Execution E, class F>
void for_each_block(E, index_t n, index_t block, F&& f) {
  const index_t nb = (n + block - 1) / block;
  if constexpr (std::same_as<E, exec::par>) {
#ifdef _OPENMP
    if (n >= parallel_min_items && nb > 1) {
#pragma omp parallel for schedule(static)
      for (index_t b = 0; b < nb; ++b) f(b, b * block, std::min(n, (b + 1) * block));
      return;
    }
#endif
  }
  for (index_t b = 0; b < nb; ++b) f(b, b * block, std::min(n, (b + 1) * block));
}

/// Deterministic reduction: `init` combined with map(i) over [0, n) through `combine`, summed
/// sequentially inside fixed blocks and then across blocks in order (thread-count independent).
template <Execution E, class T, class Map, class Combine>
T reduce(E e, index_t n, T init, Map&& map, Combine&& combine) {
  const index_t nb = (n + reduction_block - 1) / reduction_block;
  std::vector<T> partial(static_cast<std::size_t>(nb), init);
  for_each_block(e, n, reduction_block, [&](index_t b, index_t lo, index_t hi) {
    T acc = init;
    for (index_t i = lo; i < hi; ++i) acc = combine(acc, map(i));
    partial[static_cast<std::size_t>(b)] = acc;
  });
  T total = init;
  for (const T& p : partial) total = combine(total, p);
  return total;
}

/// Deterministic sum of map(i) over [0, n).
template <Execution E, class Map>
double reduce_sum(E e, index_t n, Map&& map) {
  return reduce(e, n, 0.0, map, [](double a, double b) { return a + b; });
}

}  // namespace mpskit
