#pragma once
// Hydrostatic tank (issue 4; validation-cases.md D3): fluid of depth H at rest in an open tank.
// Measured as the issue states: depth from the mean height of surface-flagged fluid particles, pressure
// averaged over t in [20, 40] sqrt(H/g) and binned by depth (bin = l0), wall particles included.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "cases/tank.hpp"

namespace mpskit::cases {

/// Set-up of the hydrostatic tank.
template <int D>
struct hydrostatic_config {
  double depth = 0.1;        ///< H (m)
  double width = 0.1;        ///< tank width on every horizontal axis (m)
  double l0 = 0.005;         ///< spacing (m)
  double t_begin = 20.0;     ///< averaging window start, in sqrt(H/g)
  double t_end = 40.0;       ///< averaging window end and run end, in sqrt(H/g)
  scheme::semi_implicit_params<D> params{};  ///< scheme numbers (l0 is set from above)
};

/// What the run measured.
struct hydrostatic_result {
  double surface_height = 0.0;      ///< mean height of surface-flagged fluid particles at the end (m)
  std::vector<double> bin_depth;    ///< mean depth of each bin (m)
  std::vector<double> bin_pressure; ///< time-averaged pressure of each bin (Pa)
  std::vector<long> bin_samples;    ///< samples per bin
  double max_bin_error = 0.0;       ///< max |p̄ − ρ g d̄| / (ρ g H) below the top two layers
  double rms_speed = 0.0;           ///< RMS fluid speed at the end / sqrt(g H)
  double max_speed = 0.0;           ///< max fluid speed at the end / sqrt(g H)
  double min_fluid_height = 0.0;    ///< lowest fluid particle (m): < 0 means through the bottom wall
  double max_fluid_offset = 0.0;    ///< furthest fluid particle beyond a side wall (m); > 0: through a wall
  long steps = 0;                   ///< steps taken
  index_t particles = 0;            ///< particles (all kinds)
  index_t fluid = 0;                ///< fluid particles at the start
  index_t fluid_end = 0;            ///< fluid particles at the end
  double wall_seconds = 0.0;        ///< wall time of the run
  long ppe_iterations = 0;          ///< total PPE iterations
  double bottom_force_ratio = 0.0;  ///< time-averaged downward force on the bottom wall / fluid weight
  double side_force_ratio = 0.0;    ///< time-averaged outward force on the x = 0 wall / (½ ρ g H_m² W^(D−2))
  double mass_depth = 0.0;          ///< H_m = fluid volume / base area (m)
};

/// Runs the hydrostatic tank with Scene (a scene type, e.g. mpskit::defaults<D>).
template <class Scene>
hydrostatic_result run_hydrostatic(hydrostatic_config<Scene::dim> cfg) {
  constexpr int D = Scene::dim;
  const double g = -cfg.params.g[D - 1];
  vec<D> fluid_hi = vec<D>::Constant(cfg.width), tank_hi = vec<D>::Constant(cfg.width);
  fluid_hi[D - 1] = cfg.depth;
  tank_hi[D - 1] = cfg.depth + 4.0 * cfg.l0;
  cfg.params.l0 = cfg.l0;
  simulation<Scene> sim(cfg.params, tank_state<D>(fluid_hi, tank_hi, cfg.l0));
  hydrostatic_result r;
  r.particles = sim.state().n_real();
  r.fluid = count_kind(sim.state(), kind::fluid);
  const double T = std::sqrt(cfg.depth / g);
  const int nbins = static_cast<int>(std::ceil(cfg.depth / cfg.l0)) + 4;
  std::vector<double> psum(static_cast<std::size_t>(nbins), 0.0), dsum(static_cast<std::size_t>(nbins), 0.0);
  double fbottom = 0.0, fside = 0.0;
  long fsamples = 0;
  r.bin_samples.assign(static_cast<std::size_t>(nbins), 0);
  const auto t0 = std::chrono::steady_clock::now();
  auto surface_height = [&](const auto& st) {
    double h = 0.0;
    long n = 0;
    for (index_t i = 0; i < st.n_real(); ++i)
      if (st.kinds()[static_cast<std::size_t>(i)] == kind::fluid &&
          (st.flags()[static_cast<std::size_t>(i)] & flag::surface)) {
        h += st.x()(D - 1, i);
        ++n;
      }
    return n ? h / n : 0.0;
  };
  sim.run_until(cfg.t_end * T, [&](const auto& s) {
    if (s.time() < cfg.t_begin * T) return;
    const auto& st = s.state();
    const double hs = surface_height(st);
    // Loads: wall/dummy particles below the fluid box (bottom) and left of it (side x = 0).
    fbottom -= s.wall_force([&](index_t i) { return st.x()(D - 1, i) < 0.0; })[D - 1];
    fside -= s.wall_force([&](index_t i) { return st.x()(0, i) < 0.0 && st.x()(D - 1, i) >= 0.0; })[0];
    ++fsamples;
    const auto& p = st.template get<field::pressure>();
    for (index_t i = 0; i < st.n_real(); ++i) {
      const kind k = st.kinds()[static_cast<std::size_t>(i)];
      if (k == kind::dummy) continue;
      const double d = hs - st.x()(D - 1, i);
      const int b = static_cast<int>(std::floor(d / cfg.l0 + 0.5));  // bin = l0, centred on the layers
      if (b < 0 || b >= nbins) continue;
      psum[static_cast<std::size_t>(b)] += p[i];
      dsum[static_cast<std::size_t>(b)] += d;
      ++r.bin_samples[static_cast<std::size_t>(b)];
    }
  });
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& st = sim.state();
  r.surface_height = surface_height(st);
  const double rho = cfg.params.rho, ref = rho * g * cfg.depth;
  for (int b = 0; b < nbins; ++b) {
    const long c = r.bin_samples[static_cast<std::size_t>(b)];
    r.bin_depth.push_back(c ? dsum[static_cast<std::size_t>(b)] / c : 0.0);
    r.bin_pressure.push_back(c ? psum[static_cast<std::size_t>(b)] / c : 0.0);
    if (b >= 2 && c > 0 && r.bin_depth.back() <= cfg.depth)
      r.max_bin_error =
          std::max(r.max_bin_error, std::abs(r.bin_pressure.back() - rho * g * r.bin_depth.back()) / ref);
  }
  double u2 = 0.0, umax = 0.0;
  r.min_fluid_height = 1e300;
  for (index_t i = 0; i < st.n_real(); ++i) {
    if (st.kinds()[static_cast<std::size_t>(i)] != kind::fluid) continue;
    ++r.fluid_end;
    const double u = st.u().col(i).norm();
    u2 += u * u;
    umax = std::max(umax, u);
    r.min_fluid_height = std::min(r.min_fluid_height, st.x()(D - 1, i));
    for (int a = 0; a < D - 1; ++a)
      r.max_fluid_offset = std::max({r.max_fluid_offset, -st.x()(a, i), st.x()(a, i) - cfg.width});
  }
  const double U = std::sqrt(g * cfg.depth);
  r.rms_speed = std::sqrt(u2 / double(r.fluid_end)) / U;
  r.max_speed = umax / U;
  r.steps = sim.counters().steps;
  r.ppe_iterations = sim.counters().ppe_iterations;
  const double cell = std::pow(cfg.l0, D), base = std::pow(cfg.width, D - 1);
  r.mass_depth = double(r.fluid) * cell / base;
  const double weight = rho * g * double(r.fluid) * cell;
  const double side = 0.5 * rho * g * r.mass_depth * r.mass_depth * std::pow(cfg.width, D - 2);
  if (fsamples > 0) {
    r.bottom_force_ratio = fbottom / fsamples / weight;
    r.side_force_ratio = fside / fsamples / side;
  }
  return r;
}

}  // namespace mpskit::cases
