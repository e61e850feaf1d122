// The interleaved sparse product (ppe/interleaved_product.hpp), through which the BiCGSTAB solvers multiply
// since 2026-12-07, against Eigen's row-major sparse × dense product, which they used before:
//   kernel: y = A x on synthetic matrices shaped like the 2D LSMPS PPE (rows of 20–31 entries within ±60
//           columns of the diagonal, 2203 rows) and like a 3D one (rows of 46–57 entries, 1201 rows); each
//           timing is 400 products;
//   dam3:   Tanaka's 2D dam break at L = 3 mm with lsmps_impact_params (the dam_break_lsmps test's run, 2211
//           particles), to T = 1.5, with the default BiCGSTAB-Jacobi (interleaved) and the same solver
//           multiplying through Eigen's product.
// The two settings alternate within each repetition; printed: median times, the median over repetitions of
// the ratio measured in the same repetition, and whether the two give the same bits (kernel: every entry;
// dam3: the steps, the PPE iterations and every front sample).
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_interleaved_product --repetitions 5
//
// Options: --repetitions R (default 3), --cases kernel,dam3.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "reporter.hpp"

using namespace mpskit;
using mpskit::bench::median;
using mpskit::bench::seconds_since;

namespace {

/// The LSMPS default with its solver multiplying through Eigen's product (the solver before 2026-12-07).
struct eigen_product_scene : lsmps_defaults<2> {
  using solver =
      ppe::detail::eigen_iterative<Eigen::BiCGSTAB<ppe::matrix, Eigen::DiagonalPreconditioner<double>>,
                                   false>;
};

ppe::matrix synthetic(long n, int base, unsigned seed) {
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> d(-60, 60);
  std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
  for (long i = 0; i < n; ++i) {
    t.emplace_back(i, i, 4.0);
    for (int k = 1; k < base + int(i % 12); ++k) {
      const long j = i + d(g);
      if (j >= 0 && j < n && j != i) t.emplace_back(i, j, u(g));
    }
  }
  ppe::matrix A(n, n);
  A.setFromTriplets(t.begin(), t.end(), [](double a, double) { return a; });  // duplicates: the first kept
  A.makeCompressed();
  return A;
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  if (!o.parse(argc, argv, "bench_interleaved_product", {"cases"})) return 2;
  const int reps = o.repetitions;
  const std::string which = o.extra_values.count("cases") ? o.extra_values["cases"] : "kernel,dam3";
  std::printf("bench_interleaved_product (%s), %d repetitions\n", MPSKIT_BENCH_FLAGS, reps);
  if (which.find("kernel") != std::string::npos) {
    for (const auto& [name, n, base] : {std::tuple{"2D-like", 2203L, 20}, std::tuple{"3D-like", 1201L, 46}}) {
      const ppe::matrix A = synthetic(n, base, 11);
      const Eigen::Ref<const ppe::matrix> R(A);  // as Eigen's BiCGSTAB holds it
      Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0), ye(n), yi(n);
      std::vector<double> te, ti, ratio;
      bool same = true;
      for (int r = 0; r < reps; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        for (int k = 0; k < 400; ++k) {
          ye.noalias() = R * x;
          // a dependence: no hoisting
          x[k % n] += 1e-3 * ye[(k * 7) % n] / (1.0 + std::abs(ye[(k * 7) % n]));
        }
        te.push_back(seconds_since(t0));
        x = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0);
        Eigen::VectorXd xe = x;
        t0 = std::chrono::steady_clock::now();
        for (int k = 0; k < 400; ++k) {
          yi.setZero();
          ppe::add_product(A, x.data(), yi.data(), 1.0);
          x[k % n] += 1e-3 * yi[(k * 7) % n] / (1.0 + std::abs(yi[(k * 7) % n]));
        }
        ti.push_back(seconds_since(t0));
        ratio.push_back(ti.back() / te.back());
        // the same sequence through both: the same bits at the end
        for (int k = 0; k < 400; ++k) {
          ye.noalias() = R * xe;
          xe[k % n] += 1e-3 * ye[(k * 7) % n] / (1.0 + std::abs(ye[(k * 7) % n]));
        }
        same = same && std::memcmp(xe.data(), x.data(), sizeof(double) * std::size_t(n)) == 0;
        x = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0);
      }
      std::printf(
          "kernel %s: %ld rows, %ld entries: Eigen %.4f s, interleaved %.4f s (400 products, medians), "
          "median ratio %.3f, same bits %s\n",
          name, n, long(A.nonZeros()), median(te), median(ti), median(ratio), same ? "yes" : "NO");
    }
  }
  if (which.find("dam3") != std::string::npos) {
    cases::tanaka_dam_break_config c;
    c.L = 0.003;
    const scheme::lsmps_params<2> p = scheme::lsmps_impact_params<2>();
    std::vector<double> te, ti, ratio;
    bool same = true;
    for (int r = 0; r < reps; ++r) {
      const auto e = cases::run_tanaka_dam_break<eigen_product_scene>(c, 1.5, p);
      const auto i = cases::run_tanaka_dam_break(c, 1.5, p);
      te.push_back(e.wall_seconds);
      ti.push_back(i.wall_seconds);
      ratio.push_back(i.wall_seconds / e.wall_seconds);
      same = same && e.steps == i.steps && e.ppe_iterations == i.ppe_iterations && e.Z == i.Z;
      std::printf(
          "  dam3 repetition %d: Eigen's product %.2f s, interleaved %.2f s (%ld steps, %ld PPE "
          "iterations)\n",
          r, e.wall_seconds, i.wall_seconds, i.steps, i.ppe_iterations);
      std::fflush(stdout);
    }
    std::printf(
        "dam3: Eigen's product %.2f s, interleaved %.2f s (medians), median ratio %.3f, same steps, "
        "iterations and fronts %s\n",
        median(te), median(ti), median(ratio), same ? "yes" : "NO");
  }
  return 0;
}
