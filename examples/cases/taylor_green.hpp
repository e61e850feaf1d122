#pragma once
// Inviscid Taylor–Green vortex (Tanaka 2018 §5.4, eqs. 102–104; validation-cases.md A4 and D4): a periodic
// square of side W, particles of diameter L = W/N on the N×N grid of cell centres, U = 1 m/s, ν = 0.
// Measured: kinetic energy drift E/E0 − 1, linear momentum |Σ V u| / Σ V|u|, and the mean-free pressure's
// relative L2 error against eq. 104.
#include <chrono>
#include <cmath>
#include <numbers>
#include <vector>

#include "mpskit/io/probes.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// The scene: Tanaka's LSMPS scheme with no walls and no free surface (every particle inner; the PPE is
/// pinned at one particle, the lowest id).
struct taylor_green_scene : lsmps_defaults<2> {
  using walls = mpskit::scheme::no_walls;
  using surface = mpskit::scheme::no_surface;
};

/// Set-up.
struct taylor_green_config {
  int n = 50;             ///< particles per side
  double width = 1.0;     ///< W (m)
  double speed = 1.0;     ///< U (m/s)
  double t_end = 0.5;     ///< run end (s)
  double rho = 1000.0;    ///< density (kg/m³)
  double dt_courant = 0.09;  ///< Δt = dt_courant · L / U (fixed)
  scheme::lsmps_params<2> params{};  ///< scheme numbers (rho, nu, g and the domain are set from above)
};

/// Analytic fields (eqs. 102–104 with ν = 0: F = U).
struct taylor_green_exact {
  double W = 1.0, U = 1.0, rho = 1000.0;
  vec<2> velocity(const vec<2>& x) const {
    const double k = 2.0 * std::numbers::pi / W;
    return vec<2>(U * std::cos(k * x[0]) * std::sin(k * x[1]), -U * std::sin(k * x[0]) * std::cos(k * x[1]));
  }
  double pressure(const vec<2>& x) const {
    const double k = 2.0 * std::numbers::pi / W;
    return -rho * U * U / 4.0 * (std::cos(2.0 * k * x[0]) + std::cos(2.0 * k * x[1]));
  }
};

/// Initial particles on the N×N cell-centre grid with the exact velocity.
inline scheme::lsmps_state<2> taylor_green_state(const taylor_green_config& c) {
  const double L = c.width / c.n;
  scheme::lsmps_state<2> s(static_cast<index_t>(c.n) * c.n);
  const taylor_green_exact ex{c.width, c.speed, c.rho};
  auto& V = s.get<field::volume>();
  for (int a = 0; a < c.n; ++a)
    for (int b = 0; b < c.n; ++b) {
      const index_t i = static_cast<index_t>(a) * c.n + b;
      s.x().col(i) = vec<2>((b + 0.5) * L, (a + 0.5) * L);
      s.u().col(i) = ex.velocity(s.x().col(i));
      V[i] = L * L;
    }
  return s;
}

/// What a run measured.
struct taylor_green_result {
  double energy_drift = 0.0;       ///< E(t_end)/E0 − 1
  double max_energy_drift = 0.0;   ///< max over steps of |E/E0 − 1|
  double momentum_ratio = 0.0;     ///< max over steps of |Σ V u| / Σ V|u|
  double pressure_error = 0.0;     ///< max over steps with t ≥ 20 Δt of the mean-free relative L2 error
  double pressure_error_mean = 0.0; ///< its mean over those steps
  double velocity_error = 0.0;     ///< relative L2 error of u at t_end against eqs. 102–103 (steady at ν = 0)
  long steps = 0;                  ///< steps taken
  long pinned = 0;                 ///< pinned PPE parts (one per step expected)
  long ppe_iterations = 0;         ///< total solver iterations
  double wall_seconds = 0.0;       ///< wall time of the run
  index_t particles = 0;           ///< particles
};

/// Kinetic energy per unit depth, ½ Σ ρ V |u|² (J/m), from io::integrals (no gravity: the potential part is
/// 0).
template <class State>
double kinetic_energy(const State& s, double rho) {
  return io::integrals(s, rho, vec<2>::Zero()).kinetic_energy;
}

/// Runs the vortex with Scene (taylor_green_scene or a variant).
/// The scheme numbers of the case: c.params with ρ, ν = 0, no gravity and the box periodic in both axes (Δt
/// is the caller's).
inline scheme::lsmps_params<2> taylor_green_params(const taylor_green_config& c) {
  auto p = c.params;
  p.rho = c.rho;
  p.nu = 0.0;
  p.g.setZero();
  p.domain.periodic = {true, true};
  p.domain.lo = vec<2>::Zero();
  p.domain.hi = vec<2>::Constant(c.width);
  return p;
}

template <class Scene = taylor_green_scene>
taylor_green_result run_taylor_green(taylor_green_config c) {
  auto p = taylor_green_params(c);
  const double L = c.width / c.n;
  // Tanaka: Courant α_C = 0.1 and a constant Δt in the source. A fixed Δt = 0.09 L/U: at 0.1 L/U the
  // controller halved Δt as soon as some particle exceeded U by 0.2 %, and the det F source (∝ 1/Δt²)
  // then gave a pressure transient (mean-free error 0.54 against 0.02–0.1 otherwise, N = 50).
  p.time.mode = scheme::time_step_mode::fixed;
  p.time.dt_fixed = c.dt_courant * L / c.speed;
  p.time.dt_max = p.time.dt_fixed;
  simulation<Scene> sim(p, taylor_green_state(c));
  const taylor_green_exact ex{c.width, c.speed, c.rho};
  taylor_green_result r;
  r.particles = sim.state().n_real();
  const double e0 = kinetic_energy(sim.state(), c.rho);
  const auto t0 = std::chrono::steady_clock::now();
  long samples = 0;
  sim.run_until(c.t_end, [&](const auto& s) {
    const auto& st = s.state();
    const index_t n = st.n_real();
    const auto& V = st.template get<field::volume>();
    const auto& P = st.template get<field::pressure>();
    const double e = kinetic_energy(st, c.rho);
    r.max_energy_drift = std::max(r.max_energy_drift, std::abs(e / e0 - 1.0));
    vec<2> mom = vec<2>::Zero();
    double mag = 0.0, pm = 0.0, pe = 0.0;
    for (index_t i = 0; i < n; ++i) {
      mom += V[i] * st.u().col(i);
      mag += V[i] * st.u().col(i).norm();
      pm += V[i] * P[i];
      pe += V[i];
    }
    r.momentum_ratio = std::max(r.momentum_ratio, mom.norm() / mag);
    if (s.time() >= 20.0 * s.dt() - 1e-12) {
      // Mean-free pressure against eq. 104 (whose mean over the box is 0).
      const double pmean = pm / pe;
      double num = 0.0, den = 0.0;
      for (index_t i = 0; i < n; ++i) {
        const double pa = ex.pressure(st.x().col(i));
        num += V[i] * (P[i] - pmean - pa) * (P[i] - pmean - pa);
        den += V[i] * pa * pa;
      }
      r.pressure_error = std::max(r.pressure_error, std::sqrt(num / den));
      r.pressure_error_mean += std::sqrt(num / den);
      ++samples;
    }
  });
  if (samples > 0) r.pressure_error_mean /= static_cast<double>(samples);
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& st = sim.state();
  r.energy_drift = kinetic_energy(st, c.rho) / e0 - 1.0;
  double num = 0.0, den = 0.0;
  for (index_t i = 0; i < st.n_real(); ++i) {
    const vec<2> ua = ex.velocity(st.x().col(i));
    num += (st.u().col(i) - ua).squaredNorm();
    den += ua.squaredNorm();
  }
  r.velocity_error = std::sqrt(num / den);
  r.steps = sim.counters().steps;
  r.pinned = sim.counters().pinned_components;
  r.ppe_iterations = sim.counters().ppe_iterations;
  return r;
}

}  // namespace mpskit::cases
