#pragma once
// Plane Poiseuille flow (Tanaka 2018 §5.2 / validation-cases.md A2 and D1) with Tanaka's LSMPS scheme: a
// 2D channel between polygon walls at y = 0 and y = H (wall::imaginary), periodic in x through the
// search, no free surface, driven from rest by the body force G/ρ (the periodic equivalent of the
// pressure drop G = Δp/ℓ). Measured: the row-averaged velocity profile against the start-up series
// (D1) at probe times and at the end.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <vector>

#include "cases/run_measures.hpp"
#include "mpskit/boundary/pressure.hpp"
#include "mpskit/resolution/graded_lattice.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// The scene: LSMPS defaults without free-surface detection (a closed channel: every particle is inner and
/// the periodic channel's PPE has no Dirichlet row, so it is pinned; scheme docs, deviation 1).
struct poiseuille_scene : lsmps_defaults<2> {
  using surface = mpskit::scheme::no_surface;
};

/// The pressure-driven channel: pressure inflow/outflow faces at both ends (Tanaka §4.5.2), walls in y.
struct poiseuille_pressure_scene : lsmps_defaults<2> {
  using surface = mpskit::scheme::no_surface;
  using boundary = mpskit::boundary::pressure;
};

/// The same two channels with splitting and merging (Tanaka §4.4; issue #9's poiseuille_multires).
struct poiseuille_multires_scene : poiseuille_scene {
  using resolution = mpskit::resolution::split_merge<>;
};
struct poiseuille_pressure_multires_scene : poiseuille_pressure_scene {
  using resolution = mpskit::resolution::split_merge<>;
};

/// Tanaka A2's layout (§5.2, Fig. 9; the function is ours, the figure is not in the text): L* = Lf within
/// 1.5 mm of a wall, a linear ramp to 1.05 Lc at 3.5 mm (the coarse Lc kept in the centre; 1.05 so that Lc
/// does not merge), for a channel with walls at y = 0 and y = H.
inline std::function<double(const vec<2>&)> a2_target(double H, double Lf, double Lc) {
  return [=](const vec<2>& x) {
    const double d = std::min(x[1], H - x[1]);
    return Lf + std::clamp((d - 1.5e-3) / 2e-3, 0.0, 1.0) * (1.05 * Lc - Lf);
  };
}

/// Plane Poiseuille start-up from rest (validation-cases.md D1): u(y, t) = G/(2μ) y(H − y) −
/// 4 G H²/(μ π³) Σ_{n odd} sin(nπy/H)/n³ exp(−n²π²νt/H²).
struct poiseuille_exact {
  double G = 1000.0;   ///< pressure gradient −∂p/∂x (Pa/m)
  double H = 0.01;     ///< channel width (m)
  double mu = 0.1;     ///< dynamic viscosity (Pa s)
  double rho = 1000.0; ///< density (kg/m³)
  /// Steady profile G/(2μ) y (H − y).
  double steady(double y) const { return G / (2.0 * mu) * y * (H - y); }
  /// u_max = G H² / (8 μ).
  double u_max() const { return G * H * H / (8.0 * mu); }
  /// The series at time t (terms until they are below 1e-16 u_max; at t = 0 the series converges as 1/n³).
  double velocity(double y, double t) const {
    const double pi = std::numbers::pi, nu = mu / rho;
    double sum = 0.0;
    for (int n = 1; n < 20001; n += 2) {
      const double term =
          std::sin(n * pi * y / H) / (double(n) * n * n) * std::exp(-n * n * pi * pi * nu * t / (H * H));
      sum += term;
      if (std::abs(1.0 / (double(n) * n * n)) * std::exp(-n * n * pi * pi * nu * t / (H * H)) < 1e-16) break;
    }
    return steady(y) - 4.0 * G * H * H / (mu * pi * pi * pi) * sum;
  }
};

/// Set-up (defaults: Tanaka A2's numbers; the channel length only has to exceed twice the build radius).
struct poiseuille_config {
  double H = 0.01;          ///< channel width (m), Tanaka A2: 10 mm
  double length = 0.005;    ///< period along x (m); > 2 R_e L (1 + skin) = 3.72 mm at L = 0.5 mm
  double L = 0.5e-3;        ///< particle diameter (m), Tanaka A2: 0.5 mm
  double G = 1000.0;        ///< pressure gradient (Pa/m), body force G/ρ
  double rho = 1000.0;      ///< density (kg/m³)
  double mu = 0.1;          ///< dynamic viscosity (Pa s)
  double t_end = 0.5;       ///< run end (s)
  double dt = 2.5e-4;       ///< fixed Δt (s): the viscous limit 0.1 L²/ν at L = 0.5 mm (Courant gives 4e-4)
  /// Spacing of the pressure-boundary particles along the faces (m): L when empty; multi-resolution runs
  /// give the target diameter (boundary::pressure_boundary's spacing constructor).
  std::function<double(const vec<2>&)> boundary_spacing;
  std::vector<double> probe_times{0.05, 0.1};  ///< times at which the transient is compared with the series
  /// Start from the L lattice graded to params.resolution.target_diameter (resolution::graded_lattice)
  /// instead of the L lattice, which a multi-resolution scene would split in its first steps
  /// (docs/resolution.md, "Graded start"). Flow along x only (axis 0).
  bool graded_start = false;
  int axis = 0;  ///< flow (periodic) axis: 0 = x (walls in y), 1 = y (walls in x; the same channel mirrored)
  scheme::lsmps_params<2> params{};  ///< scheme numbers (rho, nu, g, domain, Δt are set from the above)
};

/// Profile error at one time.
struct poiseuille_probe {
  double t = 0.0;            ///< simulated time (s)
  double max_error = 0.0;    ///< max over rows of |ū_row − u(y_row, t)| / u_max
  double rms_error = 0.0;    ///< RMS over rows of the same
  double max_cross = 0.0;    ///< max |v| / u_max (should be ~0)
};

/// What a run measured.
struct poiseuille_result {
  std::vector<poiseuille_probe> probes;  ///< at probe_times
  poiseuille_probe end;                  ///< at t_end, against the series (≈ steady)
  double steady_error = 0.0;             ///< max over rows |ū_row − u_steady(y_row)| / u_max at t_end
  double centre_velocity = 0.0;          ///< ū of the row(s) nearest the centre line at t_end (m/s)
  long steps = 0;                        ///< steps taken
  long guarded = 0;                      ///< wall-crossing guard activations
  long pinned = 0;                       ///< pinned PPE parts
  long ppe_iterations = 0;               ///< total solver iterations
  double wall_seconds = 0.0;             ///< wall time of the run
  index_t particles = 0;                 ///< fluid particles
  index_t particles_end = 0;        ///< fluid particles at t_end (differs with split/merge or in/outflow)
  double L_min = 0.0, L_max = 0.0;  ///< smallest and largest diameter V^(1/2) at t_end (m)
  long splits = 0, merges = 0;      ///< resolution events (scenes with split_merge)
};

/// The channel's walls: two segments y = 0 (normal +y) and y = H (normal −y), extended by `overhang`
/// beyond the period box [x_lo, x_hi] so that every particle (x wrapped into the box) has the foot of its
/// perpendicular inside a segment (no copies at segment ends near the periodic seam).
inline geometry::polygon_mesh<2> channel_mesh(double x_lo, double x_hi, double H, double overhang) {
  geometry::polygon_mesh<2> m;
  m.vertices.resize(2, 4);
  m.vertices.col(0) = vec<2>(x_lo - overhang, 0.0);
  m.vertices.col(1) = vec<2>(x_hi + overhang, 0.0);
  m.vertices.col(2) = vec<2>(x_hi + overhang, H);
  m.vertices.col(3) = vec<2>(x_lo - overhang, H);
  m.elements.resize(2, 2);
  m.elements.col(0) << 0, 1;  // left normal of +x: +y (fluid above the floor)
  m.elements.col(1) << 2, 3;  // left normal of −x: −y (fluid below the lid)
  return m;
}

/// Fluid on the lattice ((i + ½) L, (j + ½) L) over [0, length) × [0, H), at rest.
inline scheme::lsmps_state<2> channel_state(double length, double H, double L) {
  const int nx = static_cast<int>(std::lround(length / L)), ny = static_cast<int>(std::lround(H / L));
  scheme::lsmps_state<2> s(static_cast<index_t>(nx) * ny);
  auto& V = s.get<field::volume>();
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const index_t k = static_cast<index_t>(j) * nx + i;
      s.x().col(k) = vec<2>((i + 0.5) * L, (j + 0.5) * L);
      V[k] = L * L;
    }
  return s;
}

/// The start of a run over [0, length) × [0, H): the L lattice, or with c.graded_start that lattice graded to
/// the target diameter (a target reading the context gets the wall distance min(y, H − y)). A graded particle
/// must keep half its diameter from the walls, as split_merge's children do; a layer beside a wall at an odd
/// generation (a diagonal pair, a quarter cell from the cell's edge: 0.35 of its diameter) does not, and is
/// refused (the channel would start with a gap at the wall) instead of dropped or kept too close.
inline scheme::lsmps_state<2> channel_start(const poiseuille_config& c, double length) {
  if (!c.graded_start) return channel_state(length, c.H, c.L);
  const auto& tf = c.params.resolution.target_diameter;
  if (!tf) fail("poiseuille_config: graded_start needs params.resolution.target_diameter");
  if (c.axis != 0)
    fail("poiseuille_config: graded_start is for the flow along x (axis 0), got axis ", c.axis);
  const double H = c.H;
  const auto g = resolution::graded_lattice(
      vec<2>(0.0, 0.0), vec<2>(length, H), c.L,
      [&](const vec<2>& x) {
        return tf(tf.point(x, [H](const vec<2>& y) { return std::min(y[1], H - y[1]); }));
      },
      [&](const vec<2>& x, double h) { return std::min(x[1], H - x[1]) >= 0.5 * h * (1.0 - 1e-12); });
  if (g.dropped_volume > 0.0)
    fail("poiseuille_config: the graded start leaves ", g.dropped_volume / (length * H) * 100.0,
         " % of the channel's volume "
         "without particles: the target asks for an odd number of splits beside a wall (diagonal pairs "
         "closer than half their diameter to it); choose a target diameter L / 2^(k/2) with k even there");
  scheme::lsmps_state<2> s(static_cast<index_t>(g.size()));
  for (std::size_t q = 0; q < g.size(); ++q) {
    s.x().col(static_cast<index_t>(q)) = g.x[q];
    s.get<field::volume>()[static_cast<index_t>(q)] = g.volume[q];
  }
  return s;
}

/// The channel mirrored on the diagonal (flow along y, walls at x = 0 and x = H): coordinates swapped,
/// elements flipped (a reflection reverses the winding, and the normals must still point to the fluid).
inline void mirror_channel(geometry::polygon_mesh<2>& m, scheme::lsmps_state<2>& s) {
  m.vertices.row(0).swap(m.vertices.row(1));
  for (index_t e = 0; e < m.size(); ++e) m.flip(e);
  s.x().row(0).swap(s.x().row(1));
  s.u().row(0).swap(s.u().row(1));
}

/// Row-averaged profile (rows of width L, as on the initial lattice) against `exact` at time t.
template <class State>
poiseuille_probe profile_error(const State& st, const poiseuille_exact& ex, double L, double t, bool steady,
                               int axis = 0, double a_lo = -1e300, double a_hi = 1e300) {
  const int ay = 1 - axis;  // the cross-channel axis
  const int ny = static_cast<int>(std::lround(ex.H / L));
  std::vector<double> us(ny, 0.0), ys(ny, 0.0);
  std::vector<long> cnt(ny, 0);
  poiseuille_probe pr;
  pr.t = t;
  const double um = ex.u_max();
  for (index_t i = 0; i < st.n_real(); ++i) {
    if (st.x()(axis, i) < a_lo || st.x()(axis, i) > a_hi) continue;  // a slice along the flow
    const double y = st.x()(ay, i);
    const int b = std::clamp(static_cast<int>(std::floor(y / L)), 0, ny - 1);
    us[b] += st.u()(axis, i);
    ys[b] += y;
    ++cnt[b];
    pr.max_cross = std::max(pr.max_cross, std::abs(st.u()(ay, i)) / um);
  }
  double sq = 0.0;
  int rows = 0;
  for (int b = 0; b < ny; ++b) {
    if (cnt[b] == 0) continue;
    const double y = ys[b] / cnt[b], u = us[b] / cnt[b];
    const double ua = steady ? ex.steady(y) : ex.velocity(y, t);
    const double e = std::abs(u - ua) / um;
    pr.max_error = std::max(pr.max_error, e);
    sq += e * e;
    ++rows;
  }
  pr.rms_error = rows > 0 ? std::sqrt(sq / rows) : 0.0;
  return pr;
}

/// Runs the periodic channel with Scene (poiseuille_scene or a variant).
template <class Scene = poiseuille_scene>
poiseuille_result run_poiseuille_periodic(poiseuille_config c) {
  auto p = c.params;
  p.rho = c.rho;
  p.nu = c.mu / c.rho;
  if (c.axis != 0 && c.axis != 1) fail("poiseuille_config: axis = ", c.axis, ", accepted 0 or 1");
  const int ax = c.axis, ay = 1 - c.axis;
  p.g.setZero();
  p.g[ax] = c.G / c.rho;
  p.domain.periodic = {ax == 0, ax == 1};
  p.domain.lo = vec<2>(0.0, 0.0);
  p.domain.hi[ax] = c.length;
  p.domain.hi[ay] = c.H;
  p.time.mode = scheme::time_step_mode::fixed;
  p.time.dt_fixed = c.dt;
  p.time.dt_max = c.dt;
  geometry::polygon_mesh<2> mesh = channel_mesh(0.0, c.length, c.H, 8.0 * c.L);
  scheme::lsmps_state<2> s0 = channel_start(c, c.length);
  if (ax == 1) mirror_channel(mesh, s0);
  const geometry::polygon_set<2> walls(std::move(mesh));
  simulation<Scene> sim(p, std::move(s0), &walls);
  const poiseuille_exact ex{c.G, c.H, c.mu, c.rho};
  poiseuille_result r;
  r.particles = sim.state().n_real();
  const auto t0 = std::chrono::steady_clock::now();
  for (double tp : c.probe_times) {
    sim.run_until(tp);
    r.probes.push_back(profile_error(sim.state(), ex, c.L, sim.time(), false, ax));
  }
  sim.run_until(c.t_end);
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.end = profile_error(sim.state(), ex, c.L, sim.time(), false, ax);
  r.steady_error = profile_error(sim.state(), ex, c.L, sim.time(), true, ax).max_error;
  record_sizes(sim, r);
  {
    const int ny = static_cast<int>(std::lround(c.H / c.L));
    double us = 0.0;
    long cnt = 0;
    for (index_t i = 0; i < sim.state().n_real(); ++i)
      if (static_cast<int>(std::floor(sim.state().x()(ay, i) / c.L)) == ny / 2) {
        us += sim.state().u()(ax, i);
        ++cnt;
      }
    r.centre_velocity = cnt > 0 ? us / cnt : 0.0;
  }
  r.steps = sim.counters().steps;
  r.guarded = sim.counters().guarded;
  r.pinned = sim.counters().pinned_components;
  r.ppe_iterations = sim.counters().ppe_iterations;
  return r;
}

/// What the pressure-driven run measured (beyond the profile).
struct poiseuille_pressure_result : poiseuille_result {
  double pressure_error = 0.0;     ///< RMS over fluid of |p − Δp (1 − x/ℓ)| / Δp at t_end
  double volume_min = 0.0;         ///< min over steps of Σ V / (H ℓ)
  double volume_max = 0.0;         ///< max over steps of Σ V / (H ℓ)
  long inflow = 0, outflow = 0, outflow_behind = 0;  ///< boundary fluxes (particles)
  double inflow_volume = 0.0, outflow_volume = 0.0;  ///< boundary fluxes (m²)
  double ledger_error = 0.0;       ///< |V(t_end) − V(0) − (V_in − V_out)| / V(0): the volume ledger closes
};

/// The same channel driven by a pressure difference Δp = G ℓ between a pressure inflow face at x = 0 and an
/// outflow face at x = ℓ (Tanaka §4.5.2), no body force. The profile is measured on the slice
/// |x − ℓ/2| ≤ 2 L (mid-length).
template <class Scene = poiseuille_pressure_scene>
poiseuille_pressure_result run_poiseuille_pressure(poiseuille_config c,
                                                   const boundary::pressure_params& bp = {}) {
  auto p = c.params;
  p.rho = c.rho;
  p.nu = c.mu / c.rho;
  p.g.setZero();
  p.time.mode = scheme::time_step_mode::fixed;
  p.time.dt_fixed = c.dt;
  p.time.dt_max = c.dt;
  const double ell = c.length, dp = c.G * ell;
  const geometry::polygon_set<2> walls(channel_mesh(0.0, ell, c.H, 4.0 * c.L));
  geometry::polygon_mesh<2> fm;
  fm.vertices.resize(2, 4);
  fm.vertices.col(0) = vec<2>(0.0, c.H);
  fm.vertices.col(1) = vec<2>(0.0, 0.0);  // inlet, left normal +x (into the fluid)
  fm.vertices.col(2) = vec<2>(ell, 0.0);
  fm.vertices.col(3) = vec<2>(ell, c.H);  // outlet, left normal −x
  fm.elements.resize(2, 2);
  fm.elements.col(0) << 0, 1;
  fm.elements.col(1) << 2, 3;
  const auto spacing = [&](const vec<2>& y) { return c.boundary_spacing ? c.boundary_spacing(y) : c.L; };
  const boundary::pressure_boundary<2> pb(geometry::polygon_set<2>(std::move(fm)), {dp, 0.0}, spacing, bp);
  simulation<Scene> sim(p, channel_start(c, ell), &walls, &pb);
  const poiseuille_exact ex{c.G, c.H, c.mu, c.rho};
  poiseuille_pressure_result r;
  r.particles = sim.state().n_real();
  const double v0 = c.H * ell;
  const auto volume = [&] {
    const auto& st = sim.state();
    return st.template get<field::volume>().head(st.n_real()).sum();
  };
  const double V0 = volume();
  r.volume_min = r.volume_max = V0 / v0;
  const auto observe = [&](const auto& s) {
    (void)s;
    const double v = volume() / v0;
    r.volume_min = std::min(r.volume_min, v);
    r.volume_max = std::max(r.volume_max, v);
  };
  const double lo = 0.5 * ell - 2.0 * c.L, hi = 0.5 * ell + 2.0 * c.L;
  const auto t0 = std::chrono::steady_clock::now();
  for (double tp : c.probe_times) {
    sim.run_until(tp, observe);
    r.probes.push_back(profile_error(sim.state(), ex, c.L, sim.time(), false, 0, lo, hi));
  }
  sim.run_until(c.t_end, observe);
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.end = profile_error(sim.state(), ex, c.L, sim.time(), false, 0, lo, hi);
  r.steady_error = profile_error(sim.state(), ex, c.L, sim.time(), true, 0, lo, hi).max_error;
  record_sizes(sim, r);
  {
    // The particles nearest the centre line within 2 L of mid-length: those within L/4 of the smallest |y
    // − H/2| found there (one row, or two rows 0.5 L from the line on a lattice with an even row count). Not
    // a fixed band around H/2: particles created by inflow sit at the boundary particles' heights, and a band
    // of ±0.5 L missed them all in the 100 mm channel at 0.5 s (centre 0 printed).
    const auto& st = sim.state();
    const auto in_window = [&](index_t i) { return std::abs(st.x()(0, i) - 0.5 * ell) < 2.0 * c.L; };
    double dmin = std::numeric_limits<double>::infinity();
    for (index_t i = 0; i < st.n_real(); ++i)
      if (in_window(i)) dmin = std::min(dmin, std::abs(st.x()(1, i) - 0.5 * c.H));
    double us = 0.0;
    long cnt = 0;
    for (index_t i = 0; i < st.n_real(); ++i)
      if (in_window(i) && std::abs(st.x()(1, i) - 0.5 * c.H) <= dmin + 0.25 * c.L) {
        us += st.u()(0, i);
        ++cnt;
      }
    r.centre_velocity = cnt > 0 ? us / cnt : 0.0;
  }
  const auto& st = sim.state();
  const auto& P = st.template get<field::pressure>();
  double sq = 0.0;
  for (index_t i = 0; i < st.n_real(); ++i) {
    const double e = (P[i] - dp * (1.0 - st.x()(0, i) / ell)) / dp;
    sq += e * e;
  }
  r.pressure_error = std::sqrt(sq / std::max<index_t>(1, st.n_real()));
  const auto& k = sim.counters();
  r.inflow = k.inflow;
  r.outflow = k.outflow;
  r.outflow_behind = k.outflow_behind;
  r.inflow_volume = k.inflow_volume;
  r.outflow_volume = k.outflow_volume;
  r.ledger_error = std::abs(volume() - V0 - k.net_boundary_volume()) / V0;
  r.steps = k.steps;
  r.guarded = k.guarded;
  r.pinned = k.pinned_components;
  r.ppe_iterations = k.ppe_iterations;
  return r;
}

}  // namespace mpskit::cases
