// Full-step throughput of the semi-implicit classic scheme on the Koshizuka & Oka dam break, scaled to
// ~1e4 / 1e5 / 1e6 particles (l0 from the target count), issue 4's benchmark. Two PPE settings:
//   quasi-compressible: α_c chosen so that ρ α_c/Δt² is ~6 % of the Laplacian diagonal (as the open
//                       codes compared in issue 4), solver tolerance 1e-8;
//   strict:             α_c = 0, tolerance 1e-8.
// Each configuration: warm-up steps, then `steps` timed steps (first 2% of T ~ column collapse), repeated
// `reps` times; prints the median and the spread of particle-steps per second and mean PPE iterations.
// Usage: bench_throughput_dam_break [--sizes 1e4,1e5] [--steps N] [--reps R]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cases/cli.hpp"
#include "cases/dam_break.hpp"

using namespace mpskit;

namespace {
struct sample {
  double rate;
  double iters;
};

sample run(double target_particles, double compressibility, int warmup, int steps) {
  cases::dam_break_config cfg;
  // Fluid 2a², walls ~ 3 layers around 4a × 2.5a: particles ≈ (2 a² + 3 l0 (4a + 2·2.5a)) / l0².
  cfg.l0 = cfg.a * std::sqrt(2.0 / target_particles);
  auto p = cfg.params;
  p.l0 = cfg.l0;
  p.compressibility = compressibility;
  p.solver.tolerance = 1e-8;
  p.time.mode = scheme::time_step_mode::fixed;
  p.time.dt_fixed = 0.1 * cfg.l0 / std::sqrt(2.0 * 9.81 * 2.0 * cfg.a);  // Courant 0.1 at the dam-break speed
  p.time.dt_max = p.time.dt_fixed;
  if (compressibility < 0) {  // quasi-compressible: shift = 6 % of the Laplacian diagonal
    const op::mps<2> o(op::mps_params{cfg.l0});
    const double diag = 2.0 * 2 / (o.lambda0() * o.n0_large()) * o.n0_large();  // Σ a_ij on the lattice
    p.compressibility = 0.06 * diag * p.time.dt_fixed * p.time.dt_fixed / p.rho;
  }
  simulation<defaults<2>> sim(
      p, cases::tank_state<2>(vec<2>(cfg.a, 2 * cfg.a), vec<2>(4 * cfg.a, 2.5 * cfg.a), cfg.l0));
  for (int k = 0; k < warmup; ++k) sim.step();
  const long it0 = sim.counters().ppe_iterations;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) sim.step();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return {double(sim.state().n_real()) * steps / wall, double(sim.counters().ppe_iterations - it0) / steps};
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<double> sizes{1e4, 1e5};
  int steps = 20, reps = 3;
  const auto usage = [&]() {
    std::fprintf(stderr, "usage: %s [--sizes 1e4,1e5,1e6] [--steps N] [--reps R]\n", argv[0]);
    return 2;
  };
  try {
    for (int a = 1; a < argc; ++a) {
      if (!std::strcmp(argv[a], "--sizes") && a + 1 < argc)
        sizes = mpskit::cases::parse_numbers("--sizes", argv[++a], 1.0);
      else if (!std::strcmp(argv[a], "--steps") && a + 1 < argc)
        steps = mpskit::cases::parse_integer("--steps", argv[++a], 1);
      else if (!std::strcmp(argv[a], "--reps") && a + 1 < argc)
        reps = mpskit::cases::parse_integer("--reps", argv[++a], 1);
      else return usage();
    }
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return usage();
  }
  std::printf(
      "dam break throughput, %s, %d thread(s); defaults<2> (quadratic kernel, TCPI source, NPCD, collision, "
      "CG-IC)\n",
      MPSKIT_BENCH_FLAGS, max_threads());
  std::printf("%10s %-18s %12s %12s %12s %8s\n", "particles", "PPE", "median p-s/s", "min", "max", "PPE it");
  for (double n : sizes)
    for (int strict = 0; strict < 2; ++strict) {
      std::vector<sample> s;
      for (int r = 0; r < reps; ++r) s.push_back(run(n, strict ? 0.0 : -1.0, 5, steps));
      std::sort(s.begin(), s.end(), [](const sample& x, const sample& y) { return x.rate < y.rate; });
      std::printf("%10.0e %-18s %12.4g %12.4g %12.4g %8.1f\n", n,
                  strict ? "strict (a_c = 0)" : "quasi-compr. 6 %", s[s.size() / 2].rate, s.front().rate,
                  s.back().rate, s[s.size() / 2].iters);
      std::fflush(stdout);
    }
  return 0;
}
