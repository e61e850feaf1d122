#pragma once
// Start-up flow in a square duct with Tanaka's LSMPS scheme in 3D (issue #8: pressure boundaries in 3D): the
// duct (0, ℓ) × (0, W)² along x, its four walls triangulated planes (wall::imaginary) extended 4 L beyond
// both ends, driven from rest either by pressure inflow/outflow faces at x = 0 and x = ℓ (Δp = G ℓ, Tanaka
// §4.5.2) or, periodic in x, by the body force G/ρ. Reference: the double sine series of the start-up flow
// (ours, from u_t = G/ρ + ν∇²u with u = 0 on the walls):
//   u(y, z, t) = Σ_{m,n odd} 16 G / (ρ π² m n ν λ_mn) (1 − e^{−ν λ_mn t}) sin(mπy/W) sin(nπz/W),
//   λ_mn = π² (m² + n²) / W².
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <type_traits>
#include <vector>

#include "cases/run_measures.hpp"
#include "mpskit/boundary/pressure.hpp"
#include "mpskit/resolution/split_merge.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// Periodic duct: LSMPS defaults in 3D without free-surface detection, ILUT-BiCGSTAB (as the pipe).
struct duct_scene : lsmps_defaults<3> {
  using surface = mpskit::scheme::no_surface;
  using solver = mpskit::ppe::bicgstab;
};
/// Pressure-driven duct.
struct duct_pressure_scene : duct_scene {
  using boundary = mpskit::boundary::pressure;
};
/// Pressure-driven duct with particle splitting and merging (issue #9 item 3: pressure boundaries in 3D); the
/// target diameter is params.resolution.target_diameter.
struct duct_pressure_multires_scene : duct_pressure_scene {
  using resolution = mpskit::resolution::split_merge<>;
};

/// The start-up series above.
struct duct_exact {
  double G = 1000.0, W = 0.004, mu = 0.1, rho = 1000.0;
  double velocity(double y, double z, double t) const {
    const double pi = std::numbers::pi, nu = mu / rho;
    double sum = 0.0;
    for (int m = 1; m <= 199; m += 2)
      for (int n = 1; n <= 199; n += 2) {
        const double lam = pi * pi * (double(m) * m + double(n) * n) / (W * W);
        sum += 16.0 * G / (rho * pi * pi * m * n * nu * lam) * (1.0 - std::exp(-nu * lam * t)) *
               std::sin(m * pi * y / W) * std::sin(n * pi * z / W);
      }
    return sum;
  }
  /// Steady centre velocity (the series at t → ∞, y = z = W/2): ≈ 0.07367 G W²/μ.
  double u_centre() const { return velocity(0.5 * W, 0.5 * W, 1e30); }
};

struct duct_config {
  double W = 0.004;      ///< side (m)
  double length = 0.008; ///< ℓ (m)
  double L = 0.5e-3;     ///< diameter (m)
  double G = 1000.0, rho = 1000.0, mu = 0.1;
  double t_end = 0.05;   ///< run end (s); the slowest mode's time constant W²/(2π²ν) = 8 ms at W = 4 mm
  double L_fine = 1e300; ///< smallest diameter splitting can make (m); only bounds the fixed Δt
  /// Boundary-particle spacing on the faces (empty: L); a multi-resolution run passes its target diameter.
  std::function<double(const vec<3>&)> boundary_spacing;
  scheme::lsmps_params<3> params{};
  boundary::pressure_params boundary{};
};

struct duct_result {
  double max_error = 0.0, rms_error = 0.0;  ///< over the (y, z) cells of the mid-length slab, / u_centre
  double u_centre = 0.0;                    ///< the series' steady centre velocity (m/s)
  long steps = 0, guarded = 0, inflow = 0, outflow = 0;
  double ledger_error = 0.0, wall_seconds = 0.0;
  index_t particles = 0, particles_end = 0;
  long splits = 0, merges = 0;        ///< resolution events (scenes with split_merge)
  double L_min = 0.0, L_max = 0.0;    ///< smallest and largest fluid diameter V^(1/3) at the end (m)
  double u_max = 0.0;                 ///< largest |u| at the end (m/s)
};

/// Four walls y = 0, y = W, z = 0, z = W for x in [x0, x1], normals into the duct.
inline geometry::polygon_mesh<3> duct_walls(double W, double x0, double x1) {
  geometry::polygon_mesh<3> m;
  m.vertices.resize(3, 8);
  // corners: k = 4 (x1?) + 2 (z = W?) + (y = W?)
  for (int k = 0; k < 8; ++k)
    m.vertices.col(k) = vec<3>((k & 4) ? x1 : x0, (k & 1) ? W : 0.0, (k & 2) ? W : 0.0);
  // normal = (v1 − v0) × (v2 − v0)
  m.elements.resize(3, 8);
  m.elements.col(0) << 0, 4, 5;  // z = 0: (x̂) × (x̂ + ŷ) = +ẑ
  m.elements.col(1) << 0, 5, 1;
  m.elements.col(2) << 2, 7, 6;  // z = W: −ẑ
  m.elements.col(3) << 2, 3, 7;
  m.elements.col(4) << 0, 6, 4;  // y = 0: (x̂ + ẑ) × x̂ = +ŷ
  m.elements.col(5) << 0, 2, 6;
  m.elements.col(6) << 1, 5, 7;  // y = W: x̂ × (x̂ + ẑ) = −ŷ
  m.elements.col(7) << 1, 7, 3;
  return m;
}

/// The faces x = 0 (normal +x) and x = ℓ (normal −x), two triangles each; elements 0–1 inlet, 2–3 outlet.
inline geometry::polygon_mesh<3> duct_faces(double W, double ell) {
  geometry::polygon_mesh<3> m;
  m.vertices.resize(3, 8);
  for (int k = 0; k < 8; ++k)
    m.vertices.col(k) = vec<3>((k & 4) ? ell : 0.0, (k & 1) ? W : 0.0, (k & 2) ? W : 0.0);
  m.elements.resize(3, 4);
  m.elements.col(0) << 0, 1, 3;  // x = 0: ŷ × (ŷ + ẑ) = +x̂
  m.elements.col(1) << 0, 3, 2;
  m.elements.col(2) << 4, 7, 5;  // x = ℓ: −x̂
  m.elements.col(3) << 4, 6, 7;
  return m;
}

/// Runs the duct with Scene: through pressure faces when the scene's boundary is boundary::pressure
/// (duct_pressure_scene and scenes derived from it), else periodic in x with the body force G/ρ (duct_scene).
template <class Scene>
duct_result run_duct_impl(const duct_config& c) {
  constexpr bool pressure =
      std::is_same_v<typename scheme::detail::scene_boundary<Scene>::type, mpskit::boundary::pressure>;
  const double L = c.L, W = c.W, ell = c.length;
  auto p = c.params;
  p.rho = c.rho;
  p.nu = c.mu / c.rho;
  p.g.setZero();
  if constexpr (!pressure) {
    p.g[0] = c.G / c.rho;
    p.domain.periodic = {true, false, false};
    p.domain.lo = vec<3>(0.0, 0.0, 0.0);
    p.domain.hi = vec<3>(ell, W, W);
  }
  p.time.mode = scheme::time_step_mode::fixed;
  const double Ldt = std::min(L, c.L_fine);
  // the viscous limit (rounded below)
  p.time.dt_fixed = p.time.dt_max = 0.1 * Ldt * Ldt / p.nu * (1.0 - 1e-12);
  geometry::polygon_options<3> opt;
  opt.fluid_seed = vec<3>(0.5 * ell, 0.5 * W, 0.5 * W);
  const geometry::polygon_set<3> walls(duct_walls(W, -4.0 * L, ell + 4.0 * L), opt);
  const int nx = static_cast<int>(std::lround(ell / L)), ny = static_cast<int>(std::lround(W / L));
  scheme::lsmps_state<3> s(static_cast<index_t>(nx) * ny * ny);
  index_t q = 0;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < ny; ++k) s.x().col(q++) = vec<3>((i + 0.5) * L, (j + 0.5) * L, (k + 0.5) * L);
  s.template get<field::volume>().setConstant(L * L * L);
  const duct_exact ex{c.G, W, c.mu, c.rho};
  duct_result r;
  r.u_centre = ex.u_centre();
  r.particles = s.n_real();
  const auto t0 = std::chrono::steady_clock::now();
  const auto finish = [&](const auto& sim) {
    r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto& st = sim.state();
    // mean u_x per (y, z) cell of size L over the slab |x − ℓ/2| ≤ 2 L (periodic: the whole period)
    std::vector<double> us(static_cast<std::size_t>(ny * ny), 0.0), ys(us.size(), 0.0), zs(us.size(), 0.0);
    std::vector<long> cnt(us.size(), 0);
    for (index_t i = 0; i < st.n_real(); ++i) {
      if (pressure && std::abs(st.x()(0, i) - 0.5 * ell) > 2.0 * L) continue;
      const int j = std::clamp(static_cast<int>(st.x()(1, i) / L), 0, ny - 1);
      const int k = std::clamp(static_cast<int>(st.x()(2, i) / L), 0, ny - 1);
      const std::size_t b = static_cast<std::size_t>(j * ny + k);
      us[b] += st.u()(0, i);
      ys[b] += st.x()(1, i);
      zs[b] += st.x()(2, i);
      ++cnt[b];
    }
    double sq = 0.0;
    long cells = 0;
    for (std::size_t b = 0; b < us.size(); ++b) {
      if (cnt[b] == 0) continue;
      const double e =
          std::abs(us[b] / cnt[b] - ex.velocity(ys[b] / cnt[b], zs[b] / cnt[b], sim.time())) / r.u_centre;
      r.max_error = std::max(r.max_error, e);
      sq += e * e;
      ++cells;
    }
    r.rms_error = cells ? std::sqrt(sq / cells) : 0.0;
    r.steps = sim.counters().steps;
    r.guarded = sim.counters().guarded;
    record_sizes(sim, r);
    for (index_t i = 0; i < st.n_real(); ++i) r.u_max = std::max(r.u_max, st.u().col(i).norm());
  };
  if constexpr (pressure) {
    const auto spacing = [&](const vec<3>& y) { return c.boundary_spacing ? c.boundary_spacing(y) : L; };
    const boundary::pressure_boundary<3> pb(geometry::polygon_set<3>(duct_faces(W, ell)),
                                            {c.G * ell, c.G * ell, 0.0, 0.0}, spacing, c.boundary);
    // inflow creates particles of the boundary particles' diameter L_p = √(A/m²) ≤ L (0.47 mm at L = 0.5 mm);
    // with splitting, the smallest diameter splitting can make (c.L_fine) bounds Δt as well
    const double Lmin = std::min({L, pb.diameters().minCoeff(), c.L_fine});
    p.time.dt_fixed = p.time.dt_max = 0.1 * Lmin * Lmin / p.nu * (1.0 - 1e-12);
    simulation<Scene> sim(p, std::move(s), &walls, &pb);
    const auto volume = [&] {
      const auto& st = sim.state();
      return st.template get<field::volume>().head(st.n_real()).sum();
    };
    const double V0 = volume();
    sim.run_until(c.t_end);
    finish(sim);
    const auto& k = sim.counters();
    r.inflow = k.inflow;
    r.outflow = k.outflow + k.outflow_behind;
    r.ledger_error = std::abs(volume() - V0 - k.net_boundary_volume()) / V0;
  } else {
    simulation<Scene> sim(p, std::move(s), &walls);
    sim.run_until(c.t_end);
    finish(sim);
  }
  return r;
}

/// Refines c for duct_pressure_multires_scene (issue #9 item 3 in 3D; the function is ours): target
/// L* = 0.75 L within 1.5 L of a wall (0.75 mm at L = 0.5 mm), a linear ramp to 1.05 L at 3 L, so the outer
/// band splits once (β_s L = 0.897 L > 0.75 L; children 2^(−1/3) L) and the core stays at L; the faces carry
/// the target spacing (each face triangle is cut at the smallest L* of its corners: L_p = 0.354 mm at
/// L = 0.5 mm), which is what keeps the face slabs' pressure drop at the single-resolution level
/// (docs/resolution.md); ILUT drop tolerance 1e-3 (same digits as 1e-4, 1.25× faster).
inline void refine_duct_walls(duct_config& c) {
  const double L = c.L, W = c.W;
  const auto target = [L, W](const vec<3>& x) {
    const double d = std::min({x[1], W - x[1], x[2], W - x[2]});
    return L * (0.75 + std::clamp((d - 1.5 * L) / (1.5 * L), 0.0, 1.0) * (1.05 - 0.75));
  };
  c.params.resolution.target_diameter = target;
  c.boundary_spacing = target;
  c.L_fine = std::cbrt(0.5) * L;
  c.params.solver.ilut_drop_tolerance = 1e-3;
}

/// Runs the duct through pressure faces (pressure_faces) or periodic with the body force, single resolution.
inline duct_result run_duct(const duct_config& c, bool pressure_faces = true) {
  return pressure_faces ? run_duct_impl<duct_pressure_scene>(c) : run_duct_impl<duct_scene>(c);
}

}  // namespace mpskit::cases
