#pragma once
// Dam break of Tanaka, Cardoso & Bahai (2018) §5.6.1 (validation-cases.md A6), for the LSMPS solver
// with polygon walls (issue #7, label dam_break_lsmps): vessel 400 mm wide, x ∈ [−200, 200] mm, bottom
// at y = 0; water column 100 mm wide × 200 mm high against the left wall, x ∈ [−200, −100] mm.
// The vessel height is not in the paper: the side walls are 300 mm tall (1.5 × the column) with an
// open top (tanaka_dam_break_config::closed_top adds a lid, ours, for runs past the run-up at the far
// wall). Probe: pressure at (195 mm, 5 mm). Front: h = max x of the counted (non-isolated) fluid
// particles + L_i/2, measured from the left wall x = −200 mm; h* = h/h0 against t* = t √(2g/h0) with
// h0 = 100 mm, the same (T, Z) as cases/dam_break.hpp (Z = front/a, T = t √(2g/a), front including
// the half extent l0/2), so read_front_series and front_band there compare it with
// ../shared/data/dam_break_front (Martin & Moyce 1952, Koshizuka & Oka 1996).
// With an obstacle (§5.6.2, validation-cases.md A7; tanaka_obstacle_config()): a block on the floor,
// 10 × 10 mm at mid-vessel (the paper says "mid-vessel"; centred on x = 0 is our reading), column
// 100 × 250 mm, probe 5 mm above the block's top centre.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "cases/polygon_tank.hpp"
#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/wall/polygon_layers.hpp"

namespace mpskit::cases {

/// Numbers of Tanaka's dam break (SI units; paper values from validation-cases.md A6).
struct tanaka_dam_break_config {
  double L = 0.001;  ///< particle diameter = spacing (paper single resolution: 1 mm); accepted (0, 0.1]
  double vessel_left = -0.2;   ///< left wall x (m)
  double vessel_right = 0.2;   ///< right wall x (m)
  double vessel_height = 0.3;  ///< side-wall height (m; not in the paper, 1.5 × column height)
  /// A lid at vessel_height (ours; the paper's vessel is open). Over the open 300 mm walls the run-up at the
  /// far wall throws particles out of the vessel from t ≈ 0.37 s; remove_outside (default) removes them,
  /// without it they fall for ever outside (ballistic: no floor there) and a run to 2 s grows its largest
  /// speed without bound.
  bool closed_top = false;
  /// Particles whose centre leaves the vessel's width, x outside [vessel_left, vessel_right] (over an open
  /// side wall: nothing else can leave, the guard keeps them inside the walls), are removed at the next
  /// step's start and counted (lsmps_params::remove_outside, ours; tanaka_dam_break_result::left_domain).
  /// false: they fall for ever outside (no floor there; until 2026-12-03 the only behaviour).
  bool remove_outside = true;
  double column_width = 0.1;      ///< h0 (m): the column spans [vessel_left, vessel_left + h0]
  double column_height = 0.2;     ///< column height (m)
  double rho = 1000.0;            ///< density (kg/m³)
  double mu = 0.001;              ///< dynamic viscosity (Pa s)
  double g = 9.8;                 ///< gravity magnitude (m/s², the paper's 9.8)
  double obstacle_width = 0.0;    ///< block on the floor (m; 0 with obstacle_height 0: none; §5.6.2: 10 mm)
  double obstacle_height = 0.0;   ///< its height (m; §5.6.2: 10 mm)
  double obstacle_centre = 0.0;   ///< x of its centre (m; §5.6.2 "mid-vessel", our reading x = 0)
  /// Blow-up bound of run_tanaka_dam_break: max |u| ≤ max_speed_factor √(g H) (time_step_params::max_speed;
  /// ours). 50: the fastest splash of a run that went on to finish was 27 m/s = 19 √(gH) (4 mm, bounded
  /// filter); the unbounded 4 mm run is stopped at T = 2.965 with its runaway particle at 74.7 m/s
  /// (docs/solver.md). Infinity: no bound.
  double max_speed_factor = 50.0;
  /// True when the vessel has a block on its floor.
  bool has_obstacle() const { return obstacle_width > 0.0 || obstacle_height > 0.0; }
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("tanaka_dam_break_config");
    v.positive("L", L).finite("vessel_left", vessel_left).finite("vessel_right", vessel_right);
    v.positive("vessel_height", vessel_height).positive("column_width", column_width);
    v.positive("column_height", column_height).positive("rho", rho).non_negative("mu", mu).positive("g", g);
    v.require(vessel_right > vessel_left, "vessel_right", "must exceed vessel_left");
    v.require(column_width <= vessel_right - vessel_left, "column_width", "must fit in the vessel");
    v.require(column_height < vessel_height, "column_height", "must be below vessel_height");
    if (std::isfinite(L) && L > 0.0 && !(L <= column_width && L <= column_height))
      v.require(false, "L",
                mpskit::detail::concat("is ", L, ", must be <= min(column_width, column_height)"));
    v.non_negative("obstacle_width", obstacle_width).non_negative("obstacle_height", obstacle_height);
    v.finite("obstacle_centre", obstacle_centre);
    v.require(max_speed_factor > 0.0, "max_speed_factor",
              mpskit::detail::concat("is ", max_speed_factor, ", must be > 0 (infinity: no bound)"));
    if (has_obstacle()) {
      v.require(obstacle_width > 0.0 && obstacle_height > 0.0, "obstacle_width",
                "and obstacle_height must both be > 0 (or both 0: no obstacle)");
      v.require(
          obstacle_centre - 0.5 * obstacle_width >= vessel_left + column_width, "obstacle_centre",
          mpskit::detail::concat("puts the block's left face at ", obstacle_centre - 0.5 * obstacle_width,
                                 ", inside the column (which ends at ", vessel_left + column_width, ")"));
      v.require(obstacle_centre + 0.5 * obstacle_width < vessel_right, "obstacle_centre",
                "puts the block's right face at or beyond the right wall");
      v.require(obstacle_height < vessel_height, "obstacle_height", "must be below vessel_height");
    }
    v.throw_if_any();
  }
};

/// Surge front h (m) = max over the first n particles with counted(i) of x_i + L_i/2 along the first axis,
/// minus x_left (the left wall); NaN when no particle is counted. For the 2D case (tanaka_dam_break::front)
/// and the 3D slab (cases/tanaka_dam_break_slab.hpp).
template <int D, class Counted>
double tanaka_surge_front(const points<D>& pos, const Eigen::VectorXd& diam, index_t n,
                          const Counted& counted, double x_left) {
  if (n > pos.cols() || n > diam.size())
    fail("tanaka_surge_front: n = ", n, " exceeds the positions (", pos.cols(), ") or diameters (",
         diam.size(), ")");
  double f = -std::numeric_limits<double>::infinity();
  for (index_t i = 0; i < n; ++i)
    if (counted(i)) f = std::max(f, pos(0, i) + 0.5 * diam[i]);
  return std::isfinite(f) ? f - x_left : std::nan("");
}

/// The dam break set-up: walls, fluid particles, probe and front helpers.
struct tanaka_dam_break {
  tanaka_dam_break_config config;  ///< the numbers it was built from
  /// open-top vessel: left wall, floor, right wall (normals into the vessel)
  geometry::polygon_set<2> walls;
  points<2> x;     ///< fluid particle positions (m)
  double L = 0.0;  ///< particle diameter (m)

  static constexpr index_t paper_particles = 19969;       ///< single-resolution count in the paper (§5.6.1)
  static constexpr double paper_peak_pressure = 4433.01;  ///< Pa, single resolution, sampled every 100 steps
  static constexpr double paper_peak_pressure_multi = 4699.80;  ///< Pa, multi-resolution

  /// Number of fluid particles.
  index_t size() const { return x.cols(); }
  /// Per-particle diameters (all L).
  Eigen::VectorXd diameters() const { return Eigen::VectorXd::Constant(x.cols(), L); }
  /// h0: the initial column width (m).
  double h0() const { return config.column_width; }
  /// Pressure probe at (195 mm, 5 mm): 5 mm from the right wall and the floor (vessel_right − 5 mm).
  vec<2> probe() const { return vec<2>(config.vessel_right - 0.005, 0.005); }
  /// §5.6.2's probe, 5 mm above the block's top centre (pressure and velocity; needs an obstacle).
  vec<2> obstacle_probe() const {
    if (!config.has_obstacle()) fail("tanaka_dam_break::obstacle_probe: the vessel has no obstacle");
    return vec<2>(config.obstacle_centre, config.obstacle_height + 0.005);
  }
  /// t* = t √(2g/h0) (Tanaka Fig. 26a; Koshizuka & Oka's T).
  double t_star(double t) const { return t * std::sqrt(2.0 * config.g / h0()); }
  /// Front h (m) = max over the first n particles with counted(i) of x_i + L_i/2, minus the left wall x;
  /// NaN when no particle is counted. counted(i): non-isolated real fluid (c_i ≥ α_c).
  template <class Counted>
  double front(const points<2>& pos, const Eigen::VectorXd& diam, index_t n, const Counted& counted) const {
    return tanaka_surge_front(pos, diam, n, counted, config.vessel_left);
  }
  /// h* = h/h0 (Fig. 26a; Z of cases/dam_break.hpp).
  template <class Counted>
  double front_star(const points<2>& pos, const Eigen::VectorXd& diam, index_t n,
                    const Counted& counted) const {
    return front(pos, diam, n, counted) / h0();
  }
};

/// The numbers of §5.6.2 (dam break with a small obstacle): column 100 × 250 mm, block 10 × 10 mm at x = 0;
/// the vessel's side walls 375 mm tall (1.5 × the column, as without the obstacle).
inline tanaka_dam_break_config tanaka_obstacle_config(double L = 0.001) {
  tanaka_dam_break_config c;
  c.L = L;
  c.column_height = 0.25;
  c.vessel_height = 0.375;
  c.obstacle_width = 0.01;
  c.obstacle_height = 0.01;
  c.obstacle_centre = 0.0;
  return c;
}

/// The vessel's walls: geometry::tank's polyline (left, top) → (left, 0) → (right, 0) → (right, top), left
/// normals into the vessel; with an obstacle the floor goes over the block (up its left face, across its top,
/// down its right face), so the block's faces are walls with two convex and two concave corners. closed_top
/// adds the lid (right, top) → (left, top), whose left normal points down, into the vessel: a closed loop.
inline geometry::polygon_mesh<2> tanaka_dam_break_walls(const tanaka_dam_break_config& c) {
  if (!c.has_obstacle() && !c.closed_top)
    return geometry::tank(vec<2>(c.vessel_left, 0.0), vec<2>(c.vessel_right, c.vessel_height));
  std::vector<vec<2>> v{{c.vessel_left, c.vessel_height}, {c.vessel_left, 0.0}};
  if (c.has_obstacle()) {
    const double a = c.obstacle_centre - 0.5 * c.obstacle_width,
                 b = c.obstacle_centre + 0.5 * c.obstacle_width;
    // push_back, not insert(end, {...}): GCC 12 at -O3 reports a false -Warray-bounds in the inlined range
    // insert.
    v.push_back(vec<2>(a, 0.0));
    v.push_back(vec<2>(a, c.obstacle_height));
    v.push_back(vec<2>(b, c.obstacle_height));
    v.push_back(vec<2>(b, 0.0));
  }
  v.push_back(vec<2>(c.vessel_right, 0.0));
  v.push_back(vec<2>(c.vessel_right, c.vessel_height));
  std::vector<std::array<index_t, 2>> el;
  for (index_t k = 0; k + 1 < static_cast<index_t>(v.size()); ++k) el.push_back({k, k + 1});
  if (c.closed_top) el.push_back({static_cast<index_t>(v.size()) - 1, 0});
  return geometry::detail::make_mesh<2>(v, el);  // an open chain as geometry::tank builds its own, or closed
}

/// Builds the vessel (tanaka_dam_break_walls) and fills the column with the lattice vessel_left + (k + ½) L,
/// (m + ½) L kept where the signed distance to the walls is ≥ L/2 (1e-12 L rounding allowance): with L
/// dividing h0 and the column height this is exactly (h0/L) × (column_height/L) particles.
inline tanaka_dam_break make_tanaka_dam_break(const tanaka_dam_break_config& c = {}) {
  c.validate();
  geometry::polygon_set<2> walls(tanaka_dam_break_walls(c));
  const vec<2> origin(c.vessel_left, 0.0);
  points<2> x = fill_half_spacing<2>(walls, origin, vec<2>(c.vessel_left + c.column_width, c.column_height),
                                     c.L, origin);
  return tanaka_dam_break{c, std::move(walls), std::move(x), c.L};
}

}  // namespace mpskit::cases
