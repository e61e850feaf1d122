#pragma once
// Tanaka's dam break (§5.6.1, cases/tanaka_dam_break.hpp) as a 3D slab (ours: the paper's case is 2D): the
// vessel's profile in the x–z plane (z vertical, gravity along −z), x ∈ [0, 400] mm, extruded along y over
// [0, B], B = layers × L; the column 100 × B × 200 mm against the left wall x = 0. The walls are the polygons
// of cases/polygon_tank.hpp (vertical left wall, open top unless closed_top). Along y the slab is periodic
// (the
// default: the flow is plane, so its front is the 2D run's up to the discretisation; the test of
// scheme::lsmps_impact_params<3> in label dam_break_slab compares the two) or closed by two end walls
// (no-slip walls, as every wall of the scheme: their copies carry the wall's velocity, and the one-sided-band
// filter drags the layers beside them far more than ν would; docs/lsmps_scheme.md "The impact
// configuration"). A periodic slab needs a period above twice the search radius (7.44 L with the defaults: 8
// layers). The front Z = (max x + L_i/2 of the non-isolated fluid)/h0 and T = t √(2g/h0) are the 2D case's,
// measured from the left wall.
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "cases/polygon_tank.hpp"
#include "cases/run_measures.hpp"
#include "cases/tanaka_dam_break.hpp"
#include "cases/tanaka_dam_break_run.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/io/probes.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// How the slab ends along y.
enum class slab_sides {
  periodic,  ///< y periodic with period B (search::domain): no end walls, a plane flow
  walls      ///< two end walls at y = 0 and y = B (no-slip: see the file comment)
};

/// The slab: walls and fluid particles (volume L³ each).
struct tanaka_slab {
  /// left, floor, right (+ the lid: closed_top; + end walls: slab_sides::walls)
  geometry::polygon_set<3> walls;
  points<3> x;              ///< fluid particle positions (m)
  double L = 0.0, B = 0.0;  ///< spacing and slab depth (m)
  double W = 0.0, H = 0.0;  ///< vessel width and wall height (m): the box [0, W] × [0, B] × [0, H]
  slab_sides sides = slab_sides::periodic;
  index_t size() const { return x.cols(); }
};

/// Builds the slab of `layers` particle layers along y from the 2D case's numbers. Refused: bad numbers (as
/// tanaka_dam_break_config::validate), layers < 1, an obstacle (not built in 3D), a column that is not a
/// whole number of spacings (the lattice would not fill it: the 2D case's L = h0/N readings), walls lower
/// than the column plus L.
inline tanaka_slab make_tanaka_slab(const tanaka_dam_break_config& c, int layers,
                                    slab_sides sides = slab_sides::periodic) {
  c.validate();
  validator v("make_tanaka_slab");
  v.require(layers >= 1, "layers", mpskit::detail::concat("is ", layers, ", must be >= 1"));
  v.require(!c.has_obstacle(), "obstacle", "the slab has no obstacle (the 2D case builds it)");
  const auto whole = [&](double len) {
    return std::abs(len / c.L - std::round(len / c.L)) < 1e-9 * (len / c.L);
  };
  v.require(whole(c.column_width) && whole(c.column_height), "L",
            mpskit::detail::concat("is ", c.L, ": the column ", c.column_width, " x ", c.column_height,
                                   " m must be whole numbers of L"));
  v.require(c.vessel_height >= c.column_height + c.L, "vessel_height",
            mpskit::detail::concat("is ", c.vessel_height, ", must be >= column_height + L = ",
                                   c.column_height + c.L));
  v.throw_if_any();
  polygon_tank_config tc;
  tc.W = c.vessel_right - c.vessel_left;
  tc.H = c.column_height;
  tc.tank_height = c.vessel_height;
  tc.angle_deg = 90.0;
  tc.L = c.L;
  tc.B = layers * c.L;
  tc.lid = c.closed_top;
  tc.validate(3);
  std::vector<tank_face> faces;
  geometry::polygon_mesh<3> mesh = detail::tank_mesh_3d(tc, faces);
  if (sides == slab_sides::periodic) {  // drop the end caps (the last four triangles, faces front and back)
    std::vector<index_t> keep;
    for (std::size_t e = 0; e < faces.size(); ++e)
      if (faces[e] != tank_face::front && faces[e] != tank_face::back)
        keep.push_back(static_cast<index_t>(e));
    Eigen::Matrix<index_t, 3, Eigen::Dynamic> el(3, static_cast<index_t>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k)
      el.col(static_cast<index_t>(k)) = mesh.elements.col(keep[k]);
    mesh.elements = el;
  }
  tanaka_slab s{
      geometry::polygon_set<3>(std::move(mesh)), points<3>(), c.L, tc.B, tc.W, tc.tank_height, sides};
  s.x = fill_half_spacing<3>(s.walls, vec<3>::Zero(), vec<3>(c.column_width, tc.B, c.column_height), c.L);
  return s;
}

/// What run_tanaka_slab measured.
struct tanaka_slab_result : tanaka_run_counts {
  std::vector<double> T, Z;  ///< front samples (as tanaka_dam_break_result: every 0.05 in T)
  std::vector<double> Z_body;  ///< the same over the largest connected body (io::largest_body, link 1.5)
  double p_min = 0.0;        ///< lowest fluid pressure over all steps (Pa)
  double rho_g_h = 0.0;      ///< ρ g H of the column (Pa)
  double u_max = 0.0;        ///< largest fluid |u| after any step (m/s)
  double min_pair_ratio = 1e300;  ///< smallest fluid r_ij/L_ij after any step (min_pair_ratios)
  index_t particles = 0;
  double wall_seconds = 0.0;
  bool failed = false;  ///< with catch_failure: the scheme threw at T_failed (failure: its message)
  double T_failed = std::numeric_limits<double>::quiet_NaN();
  std::string failure;
};

/// Runs the slab to T = T_end with the scheme options `p` (the case sets ρ, ν, g, Δt_max, the blow-up bound
/// and the removal box over the vessel's x range by set_tanaka_case_params, as in 2D; the periodic y axis, or
/// with end walls the removal over their tops). With catch_failure an mpskit::error of the scheme ends the
/// run and is recorded; otherwise it propagates. `observe(sim)` is called after every step (output,
/// progress).
template <class Scene = lsmps_defaults<3>, class Observer = no_tanaka_observer>
tanaka_slab_result run_tanaka_slab(const tanaka_dam_break_config& c, int layers, double T_end,
                                   scheme::lsmps_params<3> p = {}, slab_sides sides = slab_sides::periodic,
                                   bool catch_failure = false, Observer&& observe = {}) {
  const tanaka_slab s = make_tanaka_slab(c, layers, sides);
  set_tanaka_case_params<3>(c, p, 0.0, s.W);  // as the 2D runner, the left wall at x = 0
  if (sides == slab_sides::periodic) {
    p.domain.periodic = {false, true, false};
    p.domain.lo = vec<3>::Zero();
    p.domain.hi = vec<3>(s.W, s.B, s.H);
  }
  if (c.remove_outside && sides == slab_sides::walls) {  // over the end walls' tops too
    p.remove_outside.lo[1] = 0.0;
    p.remove_outside.hi[1] = s.B;
  }
  scheme::lsmps_state<3> s0(s.size());
  s0.x() = s.x;
  s0.u().setZero();
  s0.template get<field::volume>().setConstant(c.L * c.L * c.L);
  simulation<Scene> sim(p, std::move(s0), &s.walls);
  tanaka_slab_result r;
  r.rho_g_h = c.rho * c.g * c.column_height;
  r.particles = s.size();
  const double T_of_t = std::sqrt(2.0 * c.g / c.column_width);
  double next = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    while (sim.time() * T_of_t < T_end) {
      sim.step();
      observe(sim);
      const auto& st = sim.state();
      const index_t n = st.n_real();
      const auto& P = st.template get<field::pressure>();
      for (index_t i = 0; i < n; ++i) r.p_min = std::min(r.p_min, P[i]);
      if (n > 0) r.u_max = std::max(r.u_max, st.u().leftCols(n).colwise().norm().maxCoeff());
      r.min_pair_ratio = std::min(r.min_pair_ratio, min_pair_ratios(st, p.domain).all);
      const double T = sim.time() * T_of_t;
      if (T < next) continue;
      next += 0.05;
      const auto& fl = st.flags();
      const Eigen::VectorXd d =
          st.template get<field::volume>().head(n).unaryExpr([](double v) { return std::cbrt(v); });
      const auto counted = [&](index_t i) { return (fl[static_cast<std::size_t>(i)] & flag::isolated) == 0; };
      // The largest connected body (spray left out; across the periodic side through the minimum image).
      const std::vector<char> body = io::largest_body(st.x(), d, n, counted, p.domain);
      const auto in_body = [&](index_t i) { return body[static_cast<std::size_t>(i)] != 0; };
      r.T.push_back(T);
      // the left wall at x = 0
      r.Z.push_back(tanaka_surge_front(st.x(), d, n, counted, 0.0) / c.column_width);
      r.Z_body.push_back(tanaka_surge_front(st.x(), d, n, in_body, 0.0) / c.column_width);
    }
  } catch (const mpskit::error& e) {
    if (!catch_failure) throw;
    r.failed = true;
    r.T_failed = sim.time() * T_of_t;
    r.failure = e.what();
  }
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.read_counts(sim.counters());
  return r;
}

}  // namespace mpskit::cases
