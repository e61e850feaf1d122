#pragma once
// Start-up flow in a circular pipe (validation-cases.md D1, "Axisymmetric pipe": Szymanski 1932) with
// Tanaka's LSMPS scheme in 3D: a pipe of radius R along z, its wall a triangulated cylinder (wall::imaginary,
// copies with the curvature diameter of eq. 76), periodic along z through the search, driven from rest by the
// body force G/ρ. Measured: ring-averaged axial velocity against the series at probe times.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <vector>

#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// The scene: LSMPS defaults in 3D without free-surface detection.
struct pipe_scene : lsmps_defaults<3> {
  using surface = mpskit::scheme::no_surface;
  // ILUT: BiCGSTAB-Jacobi diverged on the left-null-vector solve (3D, pinned)
  using solver = mpskit::ppe::bicgstab;
};

/// u(r, t) = G/(4μ)(R² − r²) − (2 G R²/μ) Σ_k J0(α_k r/R) / (α_k³ J1(α_k)) exp(−α_k² ν t / R²), α_k the zeros
/// of J0 (validation-cases.md D1).
struct pipe_exact {
  double G = 1000.0, R = 0.005, mu = 0.1, rho = 1000.0;
  double u_max() const { return G * R * R / (4.0 * mu); }  ///< steady centre velocity
  /// k-th positive zero of J0 (k ≥ 1), by Newton from McMahon's estimate (k − ¼)π.
  static double zero_j0(int k) {
    double x = (k - 0.25) * std::numbers::pi;
    for (int it = 0; it < 50; ++it) {
      const double dx = std::cyl_bessel_j(0.0, x) / -std::cyl_bessel_j(1.0, x);  // J0′ = −J1
      x -= dx;
      if (std::abs(dx) < 1e-15 * x) break;
    }
    return x;
  }
  double velocity(double r, double t) const {
    const double nu = mu / rho;
    double sum = 0.0;
    for (int k = 1; k <= 400; ++k) {
      const double a = zero_j0(k);
      const double e = std::exp(-a * a * nu * t / (R * R));
      const double term = std::cyl_bessel_j(0.0, a * r / R) / (a * a * a * std::cyl_bessel_j(1.0, a)) * e;
      sum += term;
      if (t > 0.0 && e < 1e-17) break;
    }
    return G / (4.0 * mu) * (R * R - r * r) - 2.0 * G * R * R / mu * sum;
  }
};

/// Set-up.
struct pipe_config {
  double R = 0.005;      ///< pipe radius (m)
  int per_radius = 8;    ///< particles per radius (issue #8: 8), L = R / per_radius
  int length_in_L = 10;  ///< period along z in L (> 2 R_e (1 + skin) L′/L: 8.5 with the curved-wall copies)
  double G = 1000.0, rho = 1000.0, mu = 0.1;  ///< as the 2D channel
  int segments = 64;                          ///< cylinder facets around the circumference
  double t_end = 0.2;                         ///< run end (s)
  std::vector<double> probe_times{0.05};      ///< also compared at t_end
  scheme::lsmps_params<3> params{};
};

/// Ring-averaged error at one time.
struct pipe_probe {
  double t = 0.0, max_error = 0.0, rms_error = 0.0;  ///< over rings, / u_max
};

struct pipe_result {
  std::vector<pipe_probe> probes;  ///< probe_times, then t_end
  long steps = 0, guarded = 0, small_diameter_events = 0;
  double copies_per_step = 0.0, wall_seconds = 0.0;
  index_t particles = 0;
};

/// The cylinder r = R, z in [z0, z1], triangles wound so that the normal points to the axis (into the fluid).
inline geometry::polygon_mesh<3> cylinder_mesh(double R, double z0, double z1, int m) {
  geometry::polygon_mesh<3> msh;
  msh.vertices.resize(3, 2 * m);
  for (int k = 0; k < m; ++k) {
    const double th = 2.0 * std::numbers::pi * k / m;
    msh.vertices.col(k) = vec<3>(R * std::cos(th), R * std::sin(th), z0);
    msh.vertices.col(m + k) = vec<3>(R * std::cos(th), R * std::sin(th), z1);
  }
  msh.elements.resize(3, 2 * m);
  for (int k = 0; k < m; ++k) {
    const int a = k, b = (k + 1) % m, c = m + (k + 1) % m, d = m + k;
    msh.elements.col(2 * k) << a, c, b;  // (c − a) × (b − a) ∝ ẑ × θ̂ = −r̂: toward the axis
    msh.elements.col(2 * k + 1) << a, d, c;
  }
  return msh;
}

template <class Scene = pipe_scene>
pipe_result run_pipe(pipe_config c) {
  const double L = c.R / c.per_radius, length = c.length_in_L * L;
  auto p = c.params;
  p.rho = c.rho;
  p.nu = c.mu / c.rho;
  p.g = vec<3>(0.0, 0.0, c.G / c.rho);
  p.domain.periodic = {false, false, true};
  p.domain.lo = vec<3>(-c.R, -c.R, 0.0);
  p.domain.hi = vec<3>(c.R, c.R, length);
  const double dt = 0.1 * L * L / p.nu;  // the viscous limit 0.1 L²/ν (Courant is looser here)
  p.time.mode = scheme::time_step_mode::fixed;
  p.time.dt_fixed = p.time.dt_max = dt;
  geometry::polygon_options<3> opt;
  opt.fluid_seed = vec<3>(0.0, 0.0, 0.5 * length);
  const geometry::polygon_set<3> walls(cylinder_mesh(c.R, -4.0 * L, length + 4.0 * L, c.segments), opt);
  // Fluid: the cubic lattice (i + ½) L in x, y, z with signed wall distance ≥ L/2 (as the tanks).
  std::vector<vec<3>> pts;
  const int nr = c.per_radius, nz = c.length_in_L;
  for (int i = -nr; i < nr; ++i)
    for (int j = -nr; j < nr; ++j)
      for (int k = 0; k < nz; ++k) {
        const vec<3> x((i + 0.5) * L, (j + 0.5) * L, (k + 0.5) * L);
        if (walls.signed_distance(x) >= 0.5 * L * (1.0 - 1e-12)) pts.push_back(x);
      }
  scheme::lsmps_state<3> s(static_cast<index_t>(pts.size()));
  for (std::size_t q = 0; q < pts.size(); ++q) s.x().col(static_cast<index_t>(q)) = pts[q];
  s.template get<field::volume>().setConstant(L * L * L);
  simulation<Scene> sim(p, std::move(s), &walls);
  const pipe_exact ex{c.G, c.R, c.mu, c.rho};
  pipe_result r;
  r.particles = sim.state().n_real();
  long copies = 0;
  const auto observe = [&](const auto& st) { copies += st.state().n_ghost(); };
  const auto probe = [&](double t) {
    const auto& st = sim.state();
    std::vector<double> us(nr, 0.0), rs(nr, 0.0);
    std::vector<long> cnt(nr, 0);
    for (index_t i = 0; i < st.n_real(); ++i) {
      const double rr = std::hypot(st.x()(0, i), st.x()(1, i));
      const int b = std::clamp(static_cast<int>(rr / L), 0, nr - 1);
      us[b] += st.u()(2, i);
      rs[b] += rr;
      ++cnt[b];
    }
    pipe_probe pr;
    pr.t = t;
    double sq = 0.0;
    int rings = 0;
    for (int b = 0; b < nr; ++b) {
      if (cnt[b] == 0) continue;
      const double e = std::abs(us[b] / cnt[b] - ex.velocity(rs[b] / cnt[b], t)) / ex.u_max();
      pr.max_error = std::max(pr.max_error, e);
      sq += e * e;
      ++rings;
    }
    pr.rms_error = rings ? std::sqrt(sq / rings) : 0.0;
    r.probes.push_back(pr);
  };
  const auto t0 = std::chrono::steady_clock::now();
  for (double tp : c.probe_times) {
    sim.run_until(tp, observe);
    probe(sim.time());
  }
  sim.run_until(c.t_end, observe);
  probe(sim.time());
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.steps = sim.counters().steps;
  r.guarded = sim.counters().guarded;
  r.small_diameter_events = sim.counters().small_diameter_events;
  r.copies_per_step = r.steps ? double(copies) / double(r.steps) : 0.0;
  return r;
}

}  // namespace mpskit::cases
