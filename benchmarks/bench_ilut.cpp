// ppe::incomplete_lut (ppe/ilut.hpp), through which ppe::bicgstab and ppe::gmres precondition since
// 2026-12-07, against Eigen's IncompleteLUT, which they used before; the factors are the same, bit for bit:
//   kernel: the factorisation alone (AMD ordering included) of a synthetic matrix shaped like a 3D LSMPS PPE
//           (a 14³ grid, each point coupled to the points within 2.1 spacings: up to 32 neighbours, 28.5
//           entries per row on average; random non-symmetric weights, a diagonal 1.02 × the row's
//           off-diagonal sum) with the library's ILUT setting (drop 1e-4, fill 2), the 3D duct's (drop 1e-3,
//           fill 2) and Eigen's defaults (drop 1e-12, fill 10); 5 factorisations per timing;
//   duct:   the 3D duct of label poiseuille_multires (cases::refine_duct_walls, to 0.02 s) with ppe::bicgstab
//           and with the same solver preconditioned by Eigen's IncompleteLUT.
// The two settings alternate within each repetition; printed: median times, the median over repetitions of
// the ratio measured in the same repetition, and whether the two give the same bits (kernel: the factors'
// values, column indices and row starts; duct: the steps, particle counts and errors).
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_ilut --repetitions 5
//
// Options: --repetitions R (default 3), --cases kernel,duct.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "cases/duct.hpp"
#include "reporter.hpp"

using namespace mpskit;
using mpskit::bench::median;
using mpskit::bench::seconds_since;

namespace {

/// The 3D duct's scene with Eigen's IncompleteLUT (the solver before 2026-12-07).
struct eigen_ilut_duct_scene : cases::duct_pressure_multires_scene {
  using solver =
      ppe::detail::eigen_iterative<ppe::detail::bicgstab_interleaved<ppe::detail::lagged_preconditioner<
                                       Eigen::IncompleteLUT<double, std::ptrdiff_t>>>,
                                   false>;
};

/// The factors of either class (protected members).
template <class P>
struct peek : P {
  const ppe::matrix& lu() const { return this->m_lu; }
};

ppe::matrix grid_3d(int g, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> w(0.1, 1.0);
  std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
  const auto id = [g](int i, int j, int k) { return (static_cast<std::ptrdiff_t>(i) * g + j) * g + k; };
  for (int i = 0; i < g; ++i)
    for (int j = 0; j < g; ++j)
      for (int k = 0; k < g; ++k) {
        double sum = 0.0;
        for (int a = -2; a <= 2; ++a)
          for (int b = -2; b <= 2; ++b)
            for (int c = -2; c <= 2; ++c) {
              const int x = i + a, y = j + b, z = k + c;
              if ((a == 0 && b == 0 && c == 0) || a * a + b * b + c * c > 4.41 || x < 0 || y < 0 || z < 0 ||
                  x >= g || y >= g || z >= g)
                continue;
              const double v = w(rng);
              t.emplace_back(id(i, j, k), id(x, y, z), -v);
              sum += v;
            }
        t.emplace_back(id(i, j, k), id(i, j, k), 1.02 * sum);
      }
  ppe::matrix A(std::ptrdiff_t(g) * g * g, std::ptrdiff_t(g) * g * g);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  if (!o.parse(argc, argv, "bench_ilut", {"cases"})) return 2;
  const int reps = o.repetitions;
  const std::string which = o.extra_values.count("cases") ? o.extra_values["cases"] : "kernel,duct";
  std::printf("bench_ilut (%s), %d repetitions\n", MPSKIT_BENCH_FLAGS, reps);
  if (which.find("kernel") != std::string::npos) {
    const ppe::matrix A = grid_3d(14, 5);
    for (const auto& [drop, fill] : {std::pair{1e-4, 2}, std::pair{1e-3, 2}, std::pair{1e-12, 10}}) {
      peek<Eigen::IncompleteLUT<double, std::ptrdiff_t>> e;
      peek<ppe::incomplete_lut> m;
      e.setDroptol(drop);
      e.setFillfactor(fill);
      m.setDroptol(drop);
      m.setFillfactor(fill);
      std::vector<double> te, tm, ratio;
      bool same = true;
      for (int r = 0; r < reps; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        for (int k = 0; k < 5; ++k) e.compute(A);
        te.push_back(seconds_since(t0));
        t0 = std::chrono::steady_clock::now();
        for (int k = 0; k < 5; ++k) m.compute(A);
        tm.push_back(seconds_since(t0));
        ratio.push_back(tm.back() / te.back());
        const ppe::matrix &le = e.lu(), &lm = m.lu();
        same = same && le.nonZeros() == lm.nonZeros() &&
               std::equal(le.outerIndexPtr(), le.outerIndexPtr() + le.rows() + 1, lm.outerIndexPtr()) &&
               std::equal(le.innerIndexPtr(), le.innerIndexPtr() + le.nonZeros(), lm.innerIndexPtr()) &&
               std::memcmp(le.valuePtr(), lm.valuePtr(), sizeof(double) * std::size_t(le.nonZeros())) == 0;
      }
      std::printf(
          "kernel drop %.0e fill %d: %ld rows, %ld entries, factors %ld: Eigen %.4f s, ours %.4f s (5 "
          "factorisations, medians), median ratio %.3f, same factors %s\n",
          drop, fill, long(A.rows()), long(A.nonZeros()), long(e.lu().nonZeros()), median(te), median(tm),
          median(ratio), same ? "yes" : "NO");
      std::fflush(stdout);
    }
  }
  if (which.find("duct") != std::string::npos) {
    cases::duct_config c;
    c.t_end = 0.02;
    cases::refine_duct_walls(c);
    std::vector<double> te, tm, ratio;
    bool same = true;
    for (int r = 0; r < reps; ++r) {
      const auto e = cases::run_duct_impl<eigen_ilut_duct_scene>(c);
      const auto m = cases::run_duct_impl<cases::duct_pressure_multires_scene>(c);
      te.push_back(e.wall_seconds);
      tm.push_back(m.wall_seconds);
      ratio.push_back(m.wall_seconds / e.wall_seconds);
      same = same && e.steps == m.steps && e.particles_end == m.particles_end && e.max_error == m.max_error &&
             e.rms_error == m.rms_error && e.u_max == m.u_max;
      std::printf("  duct repetition %d: Eigen's ILUT %.2f s, ours %.2f s (%ld steps, max error %.5f)\n", r,
                  e.wall_seconds, m.wall_seconds, m.steps, m.max_error);
      std::fflush(stdout);
    }
    std::printf(
        "duct: Eigen's ILUT %.2f s, ours %.2f s (medians), median ratio %.3f, same steps, particles and "
        "errors %s\n",
        median(te), median(tm), median(ratio), same ? "yes" : "NO");
  }
  return 0;
}
