#pragma once
// Tanaka's dam break (§5.6.1, cases/tanaka_dam_break.hpp) as a 3D slab (ours: the paper's case is 2D): the
// vessel's profile in the x–z plane (z vertical, gravity along −z), x ∈ [0, 400] mm, extruded along y over
// [0, B] between two end walls, B = layers × L; the column 100 × B × 200 mm against the left wall x = 0. The
// walls are the polygons of cases/polygon_tank.hpp (vertical left wall, open top unless closed_top). In a slab
// with slip walls the flow is plane, so its front is the 2D run's up to the discretisation: the test of
// scheme::lsmps_impact_params<3> (label dam_break_lsmps) compares the two. The front Z = (max x + L_i/2 of the
// non-isolated fluid)/h0 and T = t √(2g/h0) are the 2D case's, measured from the left wall.
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
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// The slab: walls and fluid particles (volume L³ each).
struct tanaka_slab {
  geometry::polygon_set<3> walls;  ///< left, floor, right, two end walls (and the lid with closed_top)
  points<3> x;                     ///< fluid particle positions (m)
  double L = 0.0, B = 0.0;         ///< spacing and slab depth (m)
  index_t size() const { return x.cols(); }
};

/// Builds the slab of `layers` particle layers along y from the 2D case's numbers. Refused: bad numbers (as
/// tanaka_dam_break_config::validate), layers < 1, an obstacle (not built in 3D), a column or vessel that is not a
/// whole number of spacings (the lattice would not fill it: the 2D case's L = h0/N readings).
inline tanaka_slab make_tanaka_slab(const tanaka_dam_break_config& c, int layers) {
  c.validate();
  validator v("make_tanaka_slab");
  v.require(layers >= 1, "layers", mpskit::detail::concat("is ", layers, ", must be >= 1"));
  v.require(!c.has_obstacle(), "obstacle", "the slab has no obstacle (the 2D case builds it)");
  const auto whole = [&](double len) { return std::abs(len / c.L - std::round(len / c.L)) < 1e-9 * (len / c.L); };
  v.require(whole(c.column_width) && whole(c.column_height), "L",
            mpskit::detail::concat("is ", c.L, ": the column ", c.column_width, " x ", c.column_height,
                                   " m must be whole numbers of L"));
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
  tanaka_slab s{geometry::polygon_set<3>(detail::tank_mesh_3d(tc, faces)), points<3>(), c.L, tc.B};
  s.x = fill_half_spacing<3>(s.walls, vec<3>::Zero(), vec<3>(c.column_width, tc.B, c.column_height), c.L);
  return s;
}

/// What run_tanaka_slab measured.
struct tanaka_slab_result {
  std::vector<double> T, Z;  ///< front samples (as tanaka_dam_break_result: every 0.05 in T)
  double p_min = 0.0;        ///< lowest fluid pressure over all steps (Pa)
  double rho_g_h = 0.0;      ///< ρ g H of the column (Pa)
  double u_max = 0.0;        ///< largest fluid |u| after any step (m/s)
  double min_pair_ratio = 1e300;  ///< smallest fluid r_ij/L_ij after any step (min_pair_ratios)
  index_t particles = 0;
  long steps = 0, guarded = 0, left_domain = 0, active_set_unfinished = 0, active_set_rows = 0, collisions = 0;
  double wall_seconds = 0.0;
  bool failed = false;  ///< with catch_failure: the scheme threw at T_failed (failure: its message)
  double T_failed = std::numeric_limits<double>::quiet_NaN();
  std::string failure;
};

/// Runs the slab to T = T_end with the scheme options `p` (the case sets ν, g, Δt_max, the blow-up bound and the
/// removal box over the vessel's x range and the slab's y range, as set_tanaka_case_params does in 2D). With
/// catch_failure an mpskit::error of the scheme ends the run and is recorded; otherwise it propagates. `observe(sim)`
/// is called after every step (output, progress).
template <class Scene = lsmps_defaults<3>, class Observer = no_tanaka_observer>
tanaka_slab_result run_tanaka_slab(const tanaka_dam_break_config& c, int layers, double T_end,
                                   scheme::lsmps_params<3> p = {}, bool catch_failure = false,
                                   Observer&& observe = {}) {
  const tanaka_slab s = make_tanaka_slab(c, layers);
  p.nu = c.mu / c.rho;
  p.rho = c.rho;
  p.g << 0.0, 0.0, -c.g;
  p.time.dt_max = p.time.courant * c.L / std::sqrt(2.0 * c.g * c.column_height);
  p.time.max_speed = c.max_speed_factor * std::sqrt(c.g * c.column_height);
  if (c.remove_outside) {
    p.remove_outside.lo.head<2>() = vec<2>(0.0, 0.0);
    p.remove_outside.hi.head<2>() = vec<2>(c.vessel_right - c.vessel_left, s.B);
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
      const auto& V = st.template get<field::volume>();
      double front = -std::numeric_limits<double>::infinity();
      for (index_t i = 0; i < n; ++i)  // x + L_i/2 of the non-isolated fluid (L_i = cbrt V_i)
        if ((fl[static_cast<std::size_t>(i)] & flag::isolated) == 0)
          front = std::max(front, st.x()(0, i) + 0.5 * std::cbrt(V[i]));
      r.T.push_back(T);
      r.Z.push_back(front / c.column_width);
    }
  } catch (const mpskit::error& e) {
    if (!catch_failure) throw;
    r.failed = true;
    r.T_failed = sim.time() * T_of_t;
    r.failure = e.what();
  }
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& k = sim.counters();
  r.steps = k.steps;
  r.guarded = k.guarded;
  r.left_domain = k.left_domain;
  r.active_set_unfinished = k.active_set_unfinished;
  r.active_set_rows = k.active_set_rows;
  r.collisions = k.collisions;
  return r;
}

}  // namespace mpskit::cases
