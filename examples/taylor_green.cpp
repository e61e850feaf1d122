// Inviscid Taylor–Green vortex with Tanaka 2018's LSMPS scheme (§5.4; issue #7): prints the energy drift,
// momentum and pressure error beside the paper's ≈ 0.1 % energy error after one cycle.
// Usage: taylor_green [--full] [N] [t_end]   (default 50×50 to 0.5 s; --full: the paper's 200×200 to 1 s)
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "cases/cli.hpp"
#include "cases/taylor_green.hpp"

int main(int argc, char** argv) {
  mpskit::cases::taylor_green_config c;
  int positional = 0;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--full")) {
      c.n = 200;
      c.t_end = 1.0;
    } else {
      try {  // the whole text a number (cases/cli.hpp), not atoi's silent 0
        if (positional++ == 0) c.n = mpskit::cases::parse_integer("taylor_green: N", argv[a], 4);
        else c.t_end = mpskit::cases::parse_number("taylor_green: t_end", argv[a], 1e-12);
      } catch (const mpskit::error& e) {
        std::fprintf(stderr, "%s\nusage: %s [--full] [N] [t_end]\n", e.what(), argv[0]);
        return 2;
      }
    }
  }
  const auto r = mpskit::cases::run_taylor_green(c);
  std::printf("taylor_green %d x %d to t = %.2f s (%ld steps, %.1f s wall, %.1f PPE it/step)\n", c.n, c.n,
              c.t_end, r.steps, r.wall_seconds, double(r.ppe_iterations) / double(r.steps));
  std::printf(
      "  energy E/E0 - 1 = %+.3e at the end (max |.| %.3e); Tanaka 2018 reports about 1e-3 after 1 s at "
      "200 x 200\n",
      r.energy_drift, r.max_energy_drift);
  std::printf(
      "  momentum |sum V u| / sum V|u| <= %.2e; mean-free pressure L2 error vs eq. 104: mean %.3f, max "
      "%.3f\n",
      r.momentum_ratio, r.pressure_error_mean, r.pressure_error);
  std::printf("  velocity L2 error vs eqs. 102-103 at the end: %.3e\n", r.velocity_error);
  return 0;
}
