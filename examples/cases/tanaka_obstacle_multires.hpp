#pragma once
// Tanaka's dam break with the 10 × 10 mm obstacle (§5.6.2, validation-cases.md A7) refined around the block
// by splitting and merging (§4.4): the scene, the target diameter and the front comparison shared by the main
// example (examples/multires_dam_break.cpp), its test (label dam_break_multires) and the speed-against-error
// reporter (benchmarks/report_obstacle_multires.cpp). docs/resolution.md "The main example".
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "mpskit/resolution/split_merge.hpp"

namespace mpskit::cases {

/// lsmps_defaults<2> with splitting and merging.
struct obstacle_multires_scene : lsmps_defaults<2> {
  using resolution = mpskit::resolution::split_merge<>;
};

/// The wall options of the speed-against-error reporter's default (and of label dam_break_multires's T = 2.4
/// test until 2026-12-03) (Neumann-point copy rows, wall-only shifting, the active set for p ≥ 0;
/// docs/lsmps_scheme.md deviations 11 and 13); the main example's default until 2026-12-03 (now
/// scheme::lsmps_impact_params<2>()). With the library's default rows the obstacle case fails at t ≈ 0.11 s
/// even at single resolution.
inline constexpr const char* obstacle_walls = "neumann_points_wall_only_active_set";

/// The obstacle runs' parameters with the wall variant `walls` (a name of tanaka_wall_variants; unknown names
/// are refused).
inline scheme::lsmps_params<2> obstacle_params(const std::string& walls = obstacle_walls) {
  scheme::lsmps_params<2> p;
  tanaka_wall_variant_named(walls, "obstacle_params").apply(p);
  return p;
}

/// Sets p's target diameter to L/ratio within r0 of the block's centre, a linear ramp to 1.05 L at r1 (ours:
/// the paper's Fig. 27b is not in the text; 1.05 L so that coarse particles outside never merge), and
/// wall_contact = 0.75 (a split beside a wall keeps a child in contact, docs/resolution.md). L = c.L. Refused
/// unless c has an obstacle, ratio ≥ 1 and 0 ≤ r0 < r1 (m).
inline void refine_around_block(scheme::lsmps_params<2>& p, const tanaka_dam_break_config& c, double ratio,
                                double r0, double r1) {
  if (!c.has_obstacle()) fail("refine_around_block: the configuration has no obstacle");
  if (!(ratio >= 1.0 && std::isfinite(ratio))) fail("refine_around_block: ratio ", ratio, ": must be >= 1");
  if (!(r0 >= 0.0 && r1 > r0 && std::isfinite(r1)))
    fail("refine_around_block: r0 = ", r0, " m, r1 = ", r1, " m: need 0 <= r0 < r1");
  const vec<2> centre(c.obstacle_centre, 0.5 * c.obstacle_height);
  const double L = c.L, Lf = c.L / ratio;
  p.resolution.target_diameter = [=](const vec<2>& x) {
    return Lf + std::clamp(((x - centre).norm() - r0) / (r1 - r0), 0.0, 1.0) * (1.05 * L - Lf);
  };
  p.resolution.wall_contact = 0.75;
}

/// A front compared with a reference's: |h/h0 ÷ (h/h0)_ref − 1| at the reference's samples inside the run's
/// sampled interval.
struct front_difference {
  double rms = std::nan("");     ///< root mean square (NaN when nothing was compared)
  double max = std::nan("");     ///< largest
  double T_max = std::nan("");   ///< where the largest is
  double T_last = std::nan("");  ///< the last reference sample compared
  int samples = 0;
};

/// The run's front at the reference's sample times T ≤ T_limit, linear between its own samples (both sample
/// at the first step at or after each multiple of 0.05 T, so their times differ by up to a step). `series`:
/// the front over every counted particle (Z, default) or over the largest connected body (Z_body, spray left
/// out).
inline front_difference compare_fronts(
    const tanaka_dam_break_result& run, const tanaka_dam_break_result& ref,
    double T_limit = std::numeric_limits<double>::infinity(),
    std::vector<double> tanaka_dam_break_result::*series = &tanaka_dam_break_result::Z) {
  const std::vector<double>& T = run.T;
  const std::vector<double>& Z = run.*series;
  const std::vector<double>& Z_ref = ref.*series;
  if (Z.size() != T.size() || Z_ref.size() != ref.T.size())
    fail("compare_fronts: a front series has ", Z.size(), " and ", Z_ref.size(), " samples for ", T.size(),
         " and ", ref.T.size(), " times");
  front_difference d;
  double sum = 0.0;
  for (std::size_t k = 0; k < ref.T.size() && T.size() >= 2; ++k) {
    const double t = ref.T[k];
    if (t < T.front() || t > T.back() || t > T_limit) continue;
    const std::size_t j = std::clamp<std::size_t>(
        static_cast<std::size_t>(std::upper_bound(T.begin(), T.end(), t) - T.begin()), 1, T.size() - 1);
    const double a = (t - T[j - 1]) / (T[j] - T[j - 1]);
    const double e = std::abs(((1.0 - a) * Z[j - 1] + a * Z[j]) / Z_ref[k] - 1.0);
    if (!std::isfinite(e)) continue;
    sum += e * e;
    if (!(e <= d.max)) d.max = e, d.T_max = t;  // also the first (d.max NaN)
    ++d.samples;
    d.T_last = t;
  }
  if (d.samples > 0) d.rms = std::sqrt(sum / d.samples);
  return d;
}

}  // namespace mpskit::cases
