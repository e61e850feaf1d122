// Robustness as a pass rate (docs/lsmps_scheme.md "Robustness over an ensemble of spacings"): Tanaka's dam
// break (cases/tanaka_dam_break_run.hpp, issue #7) through the far-wall impact, run at each of a list of
// spacings with one configuration, one CSV row per run. Whether one run gets through the impact changes
// chaotically with the spacing and any option (a different particle fails at a different stage each time), so
// a single run says little about a configuration; the share of an ensemble of spacings that reaches T_end
// does.
//
//   OMP_NUM_THREADS=1 build/bench/benchmarks/bench_impact_ensemble --L 3,3.25,3.5 [--T 3.2] [--walls NAME]
//       [--bound LAMBDA] [--taper LAMBDA] [--max-condition C] [--courant A]
//       [--filter-strength EPS] [--shift-limit ALPHA_S] [--collision ALPHA1] [--collide-isolated]
//       [--shift-isolated] [--surface-copies-zero] [--surface-copies-zero-below C] [--collide-before-ppe]
//       [--fallback] [--header]
//
// --walls: a wall variant of cases::tanaka_wall_variants (default two_point_wall_only_active_set, the
//          example's);
// --bound / --taper: regularize::boundary_filter_params::max_amplification / taper_amplification (default
//         inf);
// --max-condition: op::lsmps_params::max_condition (default 1e8); --courant: time_step_params::courant α_C
// (default Tanaka's 0.1; the runner's Δt_max = α_C L / √(2 g H) follows it); --filter-strength: the boundary
// filter's ε per step (default 0.05); --shift-limit: the shifting's α_S of eq. 100, |δx| ≤ α_S L per step
// (default Tanaka's 0.01); --collision: lsmps_params::collision.alpha1, the collision stage's contact
// distance in L_ij (default 0: off; docs/lsmps_scheme.md deviation 17); --collide-isolated,
// --shift-isolated: lsmps_params::collision.isolated and shift_isolated_penalty (with --walls
// two_point_wall_only_active_set_own_loop_copies_conditioned_limited --collision 0.5 both give
// scheme::lsmps_impact_params<2>()); --surface-copies-zero: lsmps_params::surface_copies_zero (copies of
// surface particles p = 0, the paper's reading of deviation 3); --surface-copies-zero-below C:
// lsmps_params::surface_copies_zero_below (only copies of surface particles with c < C p = 0);
// --collide-before-ppe: lsmps_params::collide_before_ppe (the collision stage before the PPE); --fallback:
// the PPE solver ppe::with_fallback<bicgstab_jacobi, sparse_lu> (docs/run.md) in place of the default
// BiCGSTAB-Jacobi alone. The blow-up bound is the case's, max |u| ≤ 50 √(gH). A failed run's message goes to
// stderr. benchmarks/run_impact_ensemble.sh runs the spacings of an ensemble on several processes and counts.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_fallback_scene.hpp"
#include "reporter.hpp"

using namespace mpskit;

int main(int argc, char** argv) {
  try {
    std::vector<double> spacings;
    double T_end = 3.2, bound = std::numeric_limits<double>::infinity(), taper = bound, max_condition = 0.0;
    double courant = 0.1, filter_eps = 0.05, shift_limit = 0.01, collision = 0.0, scz_below = 0.0;
    std::string walls_name = "two_point_wall_only_active_set";
    bool header = false, fallback = false, collide_isolated = false, shift_isolated = false,
         surface_copies_zero = false, collide_before_ppe = false;
    for (int a = 1; a < argc; ++a) {
      const bool v = a + 1 < argc;
      if (!std::strcmp(argv[a], "--L") && v) spacings = bench::parse_numbers("--L (mm)", argv[++a], 1e-6);
      else if (!std::strcmp(argv[a], "--T") && v) T_end = bench::parse_number("--T", argv[++a], 1e-9);
      else if (!std::strcmp(argv[a], "--walls") && v) walls_name = argv[++a];
      else if (!std::strcmp(argv[a], "--bound") && v) bound = bench::parse_number("--bound", argv[++a], 1.0);
      else if (!std::strcmp(argv[a], "--taper") && v) taper = bench::parse_number("--taper", argv[++a], 1.0);
      else if (!std::strcmp(argv[a], "--max-condition") && v)
        max_condition = bench::parse_number("--max-condition", argv[++a], 1.0);
      else if (!std::strcmp(argv[a], "--courant") && v)
        courant = bench::parse_number("--courant", argv[++a], 1e-6);
      else if (!std::strcmp(argv[a], "--filter-strength") && v)
        filter_eps = bench::parse_number("--filter-strength", argv[++a], 0.0);
      else if (!std::strcmp(argv[a], "--shift-limit") && v)
        shift_limit = bench::parse_number("--shift-limit", argv[++a], 1e-9);
      else if (!std::strcmp(argv[a], "--collision") && v)
        collision = bench::parse_number("--collision", argv[++a], 0.0);
      else if (!std::strcmp(argv[a], "--surface-copies-zero-below") && v)
        scz_below = bench::parse_number("--surface-copies-zero-below", argv[++a], 0.0);
      else if (!std::strcmp(argv[a], "--collide-before-ppe"))
        collide_before_ppe = true;
      else if (!std::strcmp(argv[a], "--header")) header = true;
      else if (!std::strcmp(argv[a], "--fallback")) fallback = true;
      else if (!std::strcmp(argv[a], "--collide-isolated"))
        collide_isolated = true;
      else if (!std::strcmp(argv[a], "--shift-isolated"))
        shift_isolated = true;
      else if (!std::strcmp(argv[a], "--surface-copies-zero"))
        surface_copies_zero = true;
      else
        fail("bench_impact_ensemble: unexpected argument '", argv[a],
             "' (see the file's comment for the usage)");
    }
    if (collide_isolated && collision == 0.0)  // nothing collides without the stage: not recorded as on
      fail("bench_impact_ensemble: --collide-isolated needs the collision stage on (--collision ALPHA1 > 0)");
    if (header)
      std::printf(
          "walls,bound,taper,max_condition,courant,filter_strength,shift_limit,L_mm,reached,T_last,steps,"
          "guarded,"
          "max_u_sqrt_gH,T_max_u,p_min_rho_g_H,min_pair_ratio,wall_s,own_loop_checked,own_loop_dirichlet,"
          "own_loop_one_point,own_loop_solves,fallback,ppe_fallbacks,ppe_breakdown_restarts,shift_velocity_"
          "clipped,collision_alpha1,collisions,ppe_cold_restarts,"
          "collide_isolated,shift_isolated,surface_copies_zero,surface_copies_zero_below,collide_before_"
          "ppe\n");
    const cases::tanaka_wall_variant& walls =
        cases::tanaka_wall_variant_named(walls_name, "bench_impact_ensemble --walls");
    for (const double L_mm : spacings) {
      cases::tanaka_dam_break_config c;
      c.L = 1e-3 * L_mm;
      c.validate();
      scheme::lsmps_params<2> p;
      walls.apply(p);
      p.boundary_filter.max_amplification = bound;
      p.boundary_filter.taper_amplification = taper;
      if (max_condition > 0.0) p.op.max_condition = max_condition;
      p.time.courant = courant;  // these three validated by the scheme (0 < α_C < 1, 0 ≤ ε ≤ 1, α_S > 0)
      p.boundary_filter.strength = filter_eps;
      p.shift.alpha_S = shift_limit;
      p.collision.alpha1 = collision;  // validated by the scheme ([0, 1.5])
      p.collision.isolated = collide_isolated;
      p.shift_isolated_penalty = shift_isolated;
      p.surface_copies_zero = surface_copies_zero;
      p.surface_copies_zero_below = scz_below;  // these two validated by the scheme
      p.collide_before_ppe = collide_before_ppe;
      const double sqrt_gH = std::sqrt(c.g * c.column_height),
                   T_per_s = std::sqrt(2.0 * c.g / c.column_width);
      double u_max = 0.0, T_u = 0.0;
      const auto observe = [&](const auto& sim) {
        const auto& st = sim.state();
        for (index_t i = 0; i < st.n_real(); ++i) {
          const double u = st.u().col(i).norm();
          if (u > u_max) u_max = u, T_u = sim.time() * T_per_s;
        }
      };
      const auto t0 = std::chrono::steady_clock::now();
      const cases::tanaka_dam_break_result r =
          fallback ? cases::run_tanaka_dam_break<cases::tanaka_fallback_scene>(c, T_end, p, true, observe)
                   : cases::run_tanaka_dam_break(c, T_end, p, true, observe);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf(
          "%s,%g,%g,%g,%g,%g,%g,%g,%d,%.4f,%ld,%ld,%.3f,%.3f,%.4g,%.3f,%.1f,%ld,%ld,%ld,%ld,%d,%ld,%ld,%ld,%"
          "g,%ld,%ld,%d,%d,%d,%g,%d\n",
          walls.name.c_str(), bound, taper, max_condition > 0.0 ? max_condition : p.op.max_condition, courant,
          filter_eps, shift_limit, L_mm, r.failed ? 0 : 1, r.failed ? r.T_failed : T_end, r.steps, r.guarded,
          u_max / sqrt_gH, T_u, r.p_min / r.rho_g_h, r.min_pair_ratio, wall, r.own_loop_checked,
          r.own_loop_dirichlet, r.own_loop_one_point, r.own_loop_solves, fallback ? 1 : 0, r.ppe_fallbacks,
          r.ppe_breakdown_restarts, r.shift_velocity_clipped, collision, r.collisions, r.ppe_cold_restarts,
          int(collide_isolated), int(shift_isolated), int(surface_copies_zero), scz_below,
          int(collide_before_ppe));
      std::fflush(stdout);
      if (r.failed) std::fprintf(stderr, "L = %g mm, T = %.4f: %s\n", L_mm, r.T_failed, r.failure.c_str());
    }
    return 0;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
