// Tanaka 2018's LSMPS scheme (scheme/lsmps_semi_implicit.hpp) on the cases of issue #7: Taylor–Green
// vortex (periodic), hydrostatic tank with polygon walls, dam break.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>

#include "cases/taylor_green.hpp"

using namespace mpskit;

TEST_SUITE("taylor_green") {
  TEST_CASE("inviscid Taylor-Green vortex, periodic in x and y (Tanaka 2018 §5.4, eqs. 102-104)") {
    cases::taylor_green_config c25, c50;
    c25.n = 25;
    c50.n = 50;
    const auto r25 = cases::run_taylor_green(c25);
    const auto r50 = cases::run_taylor_green(c50);
    for (const auto* r : {&r25, &r50})
      std::printf("taylor_green N=%lld: steps %ld, E/E0-1 %.3e (max %.3e), momentum %.2e, p error %.3f, u error %.3e, "
                  "pinned %ld, iterations %ld, %.1f s\n",
                  static_cast<long long>(std::llround(std::sqrt(double(r->particles)))), r->steps, r->energy_drift,
                  r->max_energy_drift, r->momentum_ratio, r->pressure_error, r->velocity_error, r->pinned,
                  r->ppe_iterations, r->wall_seconds);
    CHECK(r50.pinned == r50.steps);  // one floating part (the periodic box) per step, pinned
  }
}
