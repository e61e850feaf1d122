// Channel flows (issue #8): periodic Poiseuille between polygon walls (label poiseuille) and periodic
// unit tests (label periodic).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>

#include "cases/poiseuille.hpp"

using namespace mpskit;

TEST_SUITE("poiseuille") {
  TEST_CASE("channel: periodic Poiseuille between polygon walls, body force G/rho (Tanaka 2018 §5.2, D1)") {
    cases::poiseuille_config c;
    const auto r = cases::run_poiseuille_periodic(c);
    for (const auto& pr : r.probes)
      std::printf("poiseuille periodic t = %.4f s: max err %.4f rms %.4f |v|max %.2e\n", pr.t, pr.max_error,
                  pr.rms_error, pr.max_cross);
    std::printf("poiseuille periodic end t = %.4f: series err %.4f, steady err %.4f, centre %.5f m/s, steps %ld, "
                "guarded %ld, pinned %ld, iterations %ld, %lld particles, %.1f s\n",
                r.end.t, r.end.max_error, r.steady_error, r.centre_velocity, r.steps, r.guarded, r.pinned,
                r.ppe_iterations, static_cast<long long>(r.particles), r.wall_seconds);
    // Issue #8: the profile within 2 % of the analytic steady profile (u_max = G H²/(8μ) = 0.125 m/s). At
    // t = 0.5 s the slowest mode of the start-up (time constant H²/(π²ν) = 0.10 s) still holds 0.7 % of u_max,
    // so the steady comparison measures 0.76 %; against the series it is 0.02 %.
    CHECK(r.steady_error <= 0.02);
    CHECK(r.end.max_error <= 0.01);
    // The start-up transient against the series at 0.05 s and 0.1 s (half and one time constant): measured
    // 0.13 % and 0.17 % of u_max (row averages, 20 rows); 1 % leaves room for rounding and platform.
    REQUIRE(r.probes.size() == 2);
    for (const auto& pr : r.probes) {
      CAPTURE(pr.t);
      CHECK(pr.max_error <= 0.01);
      CHECK(pr.max_cross <= 1e-3);  // measured 2.6e-5: the flow stays parallel
    }
    CHECK(r.guarded == 0);
    CHECK(r.pinned == r.steps);  // the periodic channel's PPE has no Dirichlet row: pinned every step
  }
}
