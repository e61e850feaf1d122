// Eigen's own threads held to one for systems below exec::parallel_min_items (core/exec.hpp,
// eigen_threads_scope; docs/solver.md, deviation 7): wall time of the 2D pressure-driven Poiseuille channel
// with a 2:1 size ratio (examples/cases/poiseuille.hpp, the second case of the `poiseuille_multires` label:
// 800 → 1900 particles, BiCGSTAB–Jacobi on ≈ 1900 unknowns) run with two OpenMP threads, with the hold (the
// default) and without it (solver_params::parallel_min_rows = 0: Eigen's sparse × dense product goes
// parallel, as before), on an idle machine and with one busy-looping thread competing for the two cores (a
// stand-in for another process on a shared machine). Runs alternate between the settings within each
// repetition, so drift hits them alike, and which runs first alternates between repetitions, after an
// unmeasured warm-up run; printed: the median wall time per setting and the median over repetitions of the
// ratio of "without" to "with" measured in the same repetition, and the errors (identical: the hold changes
// no result). Run from the repository root:
//
//   OMP_NUM_THREADS=2 build/bench/benchmarks/bench_eigen_threads --repetitions 4
//
// Options: --repetitions R (default 4: an even count balances the order), --t-end T (s; default 0.03).
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <thread>
#include <vector>

#include "cases/poiseuille.hpp"
#include "reporter.hpp"

using namespace mpskit;
using mpskit::bench::median;

namespace {

struct sample {
  double seconds = 0.0, error = 0.0;
};

sample run(bool held, double t_end) {
  cases::poiseuille_config c;
  if (!held) c.params.solver.parallel_min_rows = 0;  // Eigen threads every system (the behaviour before)
  c.length = 0.02;
  c.t_end = t_end;
  c.probe_times = {};
  const double Lf = 0.25e-3, H = c.H, Lc = c.L;
  c.dt = 0.1 * 0.24e-3 * 0.24e-3 / (c.mu / c.rho);
  const auto target = cases::a2_target(H, Lf, Lc);
  c.params.resolution.target_diameter = target;
  c.boundary_spacing = [=](const vec<2>& x) { return std::min(Lc, target(x)); };
  const auto r = cases::run_poiseuille_pressure<cases::poiseuille_pressure_multires_scene>(c);
  return {r.wall_seconds, r.end.max_error};
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  o.repetitions = 4;
  o.t_end = 0.03;
  if (!o.parse(argc, argv, "bench_eigen_threads")) return 2;
  const int reps = o.repetitions;
  const double t_end = o.t_end;
  std::printf("bench_eigen_threads (%s), %d OpenMP threads, %d repetitions, t_end %.3f s\n",
              MPSKIT_BENCH_FLAGS, max_threads(), reps, t_end);
  for (const bool loaded : {false, true}) {
    std::atomic<bool> stop{false};
    std::thread competitor;
    if (loaded)
      competitor = std::thread([&stop] {
        volatile unsigned long spin = 0;
        while (!stop.load(std::memory_order_relaxed)) spin = spin + 1;
      });
    run(true, 0.25 * t_end);  // warm-up, not measured
    std::vector<double> with, without, ratio;
    double e_with = 0.0, e_without = 0.0;
    for (int r = 0; r < reps; ++r) {
      // The order alternates between repetitions (held first in even ones): the first run after a change of
      // load was measured 19 % slower than the second with nothing else different (OMP_NUM_THREADS=1, where
      // both settings are the same code path).
      sample h, u;
      if (r % 2 == 0) {
        h = run(true, t_end);
        u = run(false, t_end);
      } else {
        u = run(false, t_end);
        h = run(true, t_end);
      }
      with.push_back(h.seconds);
      without.push_back(u.seconds);
      ratio.push_back(u.seconds / h.seconds);
      e_with = h.error;
      e_without = u.error;
      std::printf("  %s repetition %d: held %.2f s, not held %.2f s\n", loaded ? "loaded" : "idle", r,
                  h.seconds, u.seconds);
      std::fflush(stdout);
    }
    if (loaded) {
      stop = true;
      competitor.join();
    }
    std::printf(
        "| %s | held: median %.2f s | not held: median %.2f s | not held / held (median of ratios) %.2f | "
        "error %.6f / %.6f |\n",
        loaded ? "one competing thread" : "idle", median(with), median(without), median(ratio), e_with,
        e_without);
  }
  return 0;
}
