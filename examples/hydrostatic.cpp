// Hydrostatic tank (2D or 3D) with the default classic scene: prints the time-averaged pressure per
// depth bin against rho g d, and the residual speeds. Usage: hydrostatic [--3d] [--full] [--quiet]
//   --quiet: the quiet configuration (quiet_defaults<D>, scheme::quiet_params<D>(): mixed source, corrected
//            gradient, one-sided-band velocity filter; docs/solver.md), which meets issue #4's residual
//            speeds.
#include <cstdio>
#include <cstring>

#include "cases/hydrostatic.hpp"

template <int D, class Scene>
int run(bool full, bool quiet) {
  mpskit::cases::hydrostatic_config<D> cfg;
  if (quiet) cfg.params = mpskit::scheme::quiet_params<D>();
  if (D == 3) {
    cfg.depth = cfg.width = 0.05;
    cfg.l0 = full ? 0.0025 : 0.005;
  } else {
    cfg.l0 = full ? 0.0025 : 0.005;
  }
  const auto r = mpskit::cases::run_hydrostatic<Scene>(cfg);
  std::printf(
      "hydrostatic %dD%s: H = %.3f m, l0 = %.4f m, %ld particles (%ld fluid), %ld steps, %.1f s, %.2f PPE "
      "it/step\n",
      D, quiet ? " (quiet configuration)" : "", cfg.depth, cfg.l0, long(r.particles), long(r.fluid), r.steps,
      r.wall_seconds, double(r.ppe_iterations) / double(r.steps));
  std::printf("  surface height %.4f m; residual speed RMS %.2e, max %.2e sqrt(gH)\n", r.surface_height,
              r.rms_speed, r.max_speed);
  std::printf(
      "  depth bins (time average over [%g, %g] sqrt(H/g)):\n   depth/m  p/Pa  rho g d/Pa  err/(rho g H)\n",
      cfg.t_begin, cfg.t_end);
  const double g = 9.81, rho = 1000.0;
  for (std::size_t b = 0; b < r.bin_depth.size(); ++b)
    if (r.bin_samples[b])
      std::printf("   %.4f  %8.2f  %8.2f  %+.4f\n", r.bin_depth[b], r.bin_pressure[b],
                  rho * g * r.bin_depth[b],
                  (r.bin_pressure[b] - rho * g * r.bin_depth[b]) / (rho * g * cfg.depth));
  std::printf("  max bin error below the top two layers: %.4f of rho g H\n", r.max_bin_error);
  std::printf(
      "  wall loads (time averaged): bottom / fluid weight = %.4f; side / (rho g H^2/2) = %.4f (H = %.4f m "
      "by volume)\n",
      r.bottom_force_ratio, r.side_force_ratio, r.mass_depth);
  return 0;
}

int main(int argc, char** argv) {
  bool d3 = false, full = false, quiet = false;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--3d")) d3 = true;
    else if (!std::strcmp(argv[a], "--full")) full = true;
    else if (!std::strcmp(argv[a], "--quiet")) quiet = true;
    else { std::fprintf(stderr, "usage: %s [--3d] [--full] [--quiet]\n", argv[0]); return 2; }
  }
  if (quiet)
    return d3 ? run<3, mpskit::quiet_defaults<3>>(full, true) : run<2, mpskit::quiet_defaults<2>>(full, true);
  return d3 ? run<3, mpskit::defaults<3>>(full, false) : run<2, mpskit::defaults<2>>(full, false);
}
