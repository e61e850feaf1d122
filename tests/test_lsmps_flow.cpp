// Tanaka 2018's LSMPS scheme (scheme/lsmps_semi_implicit.hpp) on the cases of issue #7: Taylor–Green
// vortex (periodic), hydrostatic tank with polygon walls, dam break.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "cases/dam_break.hpp"
#include "cases/hydrostatic_polygon.hpp"
#include "cases/polygon_tank.hpp"
#include "cases/run_measures.hpp"
#include "cases/tanaka_dam_break_options.hpp"
#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_dam_break_slab.hpp"
#include "cases/tanaka_ilu0_scene.hpp"
#include "cases/taylor_green.hpp"
#include "mpskit/io/lsmps_checkpoint.hpp"
#include "support/support.hpp"
#ifdef _OPENMP
#include <omp.h>
#endif

using namespace mpskit;

TEST_SUITE("taylor_green") {
  TEST_CASE("inviscid Taylor-Green vortex, periodic in x and y (Tanaka 2018 §5.4, eqs. 102-104)") {
    // CI sizes of issue #7: 25×25 and 50×50 to t = 0.5 s, W = 1 m, U = 1 m/s, fixed Δt = 0.09 L/U.
    cases::taylor_green_config c25, c50;
    c25.n = 25;
    c50.n = 50;
    const auto r25 = cases::run_taylor_green(c25);
    const auto r50 = cases::run_taylor_green(c50);
    for (const auto* r : {&r25, &r50})
      std::printf(
          "taylor_green N=%lld: steps %ld, E/E0-1 %.3e (max %.3e), momentum %.2e, p error max %.3f mean "
          "%.3f, u error %.3e, pinned %ld, iterations %ld, %.1f s\n",
          static_cast<long long>(std::llround(std::sqrt(double(r->particles)))), r->steps, r->energy_drift,
          r->max_energy_drift, r->momentum_ratio, r->pressure_error, r->pressure_error_mean,
          r->velocity_error, r->pinned, r->ppe_iterations, r->wall_seconds);
    // Energy at t = 0.5 s: measured −3.26e-2 (N = 25) and −5.79e-3 (N = 50), a 5.6× reduction. The tolerance
    // 1e-2 at N = 50 leaves 1.7× room for platform/rounding differences; the issue asks ≥ 1.5× shrink.
    CHECK(std::abs(r50.energy_drift) <= 1e-2);
    CHECK(std::abs(r25.energy_drift) >= 1.5 * std::abs(r50.energy_drift));
    // Linear momentum (issue #7): |Σ V u| ≤ 1e-3 Σ V|u| at every step; measured 5.8e-4 (N = 50).
    CHECK(r50.momentum_ratio <= 1e-3);
    CHECK(r25.momentum_ratio <= 1e-3);
    // Mean-free pressure against eq. 104 for t ≥ 20 Δt. Issue #7 asks 10 %: the mean over steps meets it
    // (measured 0.045); the worst step does not (0.172, during the saddle compression near t = 0.25 s, where
    // min r_ij/L falls to 0.52): asserted at 0.25 and reported as unmet in docs/validation.md.
    CHECK(r50.pressure_error_mean <= 0.10);
    CHECK(r50.pressure_error <= 0.25);
    // The periodic box has no Dirichlet row: one floating part, pinned, every step.
    CHECK(r50.pinned == r50.steps);
    CHECK(r25.pinned == r25.steps);
  }
}

namespace {

/// One step from rest in a polygon tank: the PPE with imaginary copies (parent-gradient wall rows, copies
/// of surface particles included) must reproduce the linear hydrostatic field p = ρ g (z_top − z) exactly,
/// since LSMPS of order 2 is exact on it (source 0: ν = 0, volume correction off, u′ = g Δt uniform).
template <int D>
void check_first_step_hydrostatic(double angle_deg, double L) {
  cases::polygon_tank_config tc;
  tc.angle_deg = angle_deg;
  tc.L = L;
  tc.H = 0.1;
  tc.W = 0.1;
  tc.tank_height = 0.15;
  tc.B = 0.05;
  const auto tank = cases::make_polygon_tank<D>(tc);
  scheme::lsmps_state<D> s0(tank.size());
  s0.x() = tank.x;
  s0.u().setZero();
  s0.template get<field::volume>().setConstant(std::pow(L, D));
  scheme::lsmps_params<D> p;
  p.nu = 0.0;
  p.time.dt_max = 0.1 * L / std::sqrt(9.81 * 0.1);
  p.volume.c_min = 1e-9;  // the volume correction (eq. 62) off: it adds a source near the inclined wall,
  p.volume.c_max = 1e9;   // where the lattice fill leaves c < c_min
  p.reorder_every = 0;    // keep the tank's order, to compare with its positions
  simulation<lsmps_defaults<D>> sim(p, std::move(s0), &tank.walls);
  sim.step();
  const auto& st = sim.state();
  const auto& P = st.template get<field::pressure>();
  const index_t n = st.n_real();
  const double g = 9.81, rho = 1000.0, scale = rho * g * tc.H;
  double ztop = -1e9;
  for (index_t i = 0; i < n; ++i) ztop = std::max(ztop, tank.x(D - 1, i));
  double err = 0.0;
  long false_surface = 0, top_unflagged = 0;
  for (index_t i = 0; i < st.size(); ++i) {
    const double z = i < n ? tank.x(D - 1, i) : st.x()(D - 1, i);  // copies stay where they were made
    err = std::max(err, std::abs(P[i] - rho * g * (ztop - z)) / scale);
    if (i >= n) continue;
    const bool surf = (st.flags()[static_cast<std::size_t>(i)] & flag::surface) != 0;
    const bool top = tank.x(D - 1, i) > ztop - 1e-9;
    false_surface += surf && !top;
    top_unflagged += top && !surf;
  }
  std::printf(
      "hydrostatic_polygon %dD %.0f deg L = %.3f: %lld fluid, %lld copies, max |p - rho g d|/(rho g H) = "
      "%.2e, false surface %ld, top row unflagged %ld\n",
      D, angle_deg, L, static_cast<long long>(n), static_cast<long long>(st.n_ghost()), err, false_surface,
      top_unflagged);
  CHECK(st.n_ghost() > 0);
  // Measured ≤ 1.6e-9 (2D and 3D); the solver stops at a relative residual of 1e-8.
  CHECK(err <= 1e-7);
  // Surface detection with the wall-aware cone tests: nothing inside the fluid is flagged (without them,
  // 3 of 11 rows beside the 60° incline and 32 edge particles of the 3D box were).
  CHECK(false_surface == 0);
  // The whole top row is flagged, in 3D the contact-line particles in the vertical edges too (their cone
  // is solid; the cone slid along the walls is open and empty, surface/geometric.hpp — without it 4 of them
  // were unflagged and grew a vertical mode, label projection_stability).
  CHECK(top_unflagged == 0);
  CHECK(sim.counters().guarded == 0);
}

}  // namespace

namespace {

/// A polygon tank at rest with Tanaka's scheme (defaults: shifting and the
/// one-sided-band velocity filter on), averaged over [20, 40] √(H/g).
template <int D>
cases::hydrostatic_polygon_result check_long_hydrostatic(double angle_deg, double L, double alpha_g = 0.001,
                                                          bool shift_second_wall = false) {
  cases::hydrostatic_polygon_config<D> cfg;
  cfg.tank.angle_deg = angle_deg;
  cfg.tank.L = L;
  cfg.tank.H = 0.1;
  cfg.tank.W = 0.1;
  cfg.tank.B = 0.05;
  cfg.tank.tank_height = 0.15;
  cfg.params.time.dt_max = 0.1 * L / std::sqrt(9.81 * 0.1);
  cfg.params.shift.alpha_g = alpha_g;
  cfg.params.shift_second_wall = shift_second_wall;
  const auto r = cases::run_hydrostatic_polygon<lsmps_defaults<D>>(cfg);
  std::printf(
      "hydrostatic_polygon long %dD %.0f deg L = %.4f alpha_g = %g: %lld fluid, %ld steps, max bin error "
      "%.4f, rms %.2e, max %.2e sqrt(gH), surface %.4f (initial %.4f), guarded %ld, min signed distance "
      "%.2e L, %.1f s\n",
      D, angle_deg, L, alpha_g, static_cast<long long>(r.fluid), r.steps, r.max_bin_error, r.rms_speed,
      r.max_speed, r.surface_height, r.surface_height_initial, r.guarded, r.min_signed_distance / L,
      r.wall_seconds);
  return r;
}

/// A 2D box 0.2 m wide and 0.4 m tall with vertical walls (floor from x = 0 to 0.2 m), L = 10 mm, 50 mm of
/// water: room for particles placed far from the water and the floor.
cases::polygon_tank_config tall_box_config() {
  cases::polygon_tank_config tc;
  tc.angle_deg = 90.0;
  tc.L = 0.01;
  tc.H = 0.05;
  tc.W = 0.2;
  tc.tank_height = 0.4;
  return tc;
}

}  // namespace

namespace {

/// Shifting beside a concave kink whose faces differ by less than the copies' merge angle (the paper
/// channel's upper taper corner, 18.4°): a vessel (0, 0.15) → (0, 0) → (x_k, 0) → (0.12, (0.12 − x_k) tan
/// θ) → (0.12, 0.15), L = 5 mm, water to 50 mm, positions jittered by up to 0.15 L (seeded) so the shifting
/// acts, two particles at the kink placed (below). `closed`: the vessel has a lid at 50 mm, full of water,
/// and the scene no free surface (as the channels: no normals are computed, n = 0, so eq. 99 removes the
/// copy's wall normal only); open: the free-surface scene with the wall-only projection of the penalty (the
/// gears' and the dam break's opt-in). Returns, over `steps` steps, the largest component of δx into a face
/// (−δx·n, in L) among particles that have a copy and are within α_w L of both faces of the kink, and the
/// number of such (particle, step) pairs.
struct kink_shift_result {
  double into = 0.0;   // max over checked pairs of max(0, −δx·n_face) / L
  long checked = 0;    // (particle, step) pairs within α_w L of both faces with δx ≠ 0
};
struct closed_lsmps_scene : lsmps_defaults<2> {
  using surface = scheme::no_surface;
};
template <bool closed>
kink_shift_result run_kink_shift(bool merged_faces, double kink_deg, int steps) {
  const double L = 0.005, t = std::tan(kink_deg * std::numbers::pi / 180.0);
  // The kink 0.6 mm right of a lattice column (x = 57.5 mm). The first-row particle of that column is moved
  // 0.06 L up and left, 0.56 L from the floor (its copy) and 0.59 L from the incline (its feet on both
  // faces), and its left neighbour to 0.6 L from it: eq. 96's penalty pushes the pair apart, the kink
  // particle along the floor toward the incline.
  const double xk = 0.0581;
  const vec<2> site(0.0575, 0.0025), moved(0.0572, 0.0028), left_site(0.0525, 0.0025),
      left_moved(0.0542, 0.0028);
  const double top = closed ? 0.05 : 0.15;
  const std::vector<vec<2>> v{{0.0, top}, {0.0, 0.0}, {xk, 0.0}, {0.12, (0.12 - xk) * t}, {0.12, top}};
  std::vector<std::array<index_t, 2>> el;
  for (index_t k = 0; k + 1 < static_cast<index_t>(v.size()); ++k) el.push_back({k, k + 1});
  if (closed) el.push_back({static_cast<index_t>(v.size()) - 1, 0});  // the lid
  const geometry::polygon_set<2> walls(geometry::detail::make_mesh<2>(v, el));
  points<2> x = cases::fill_half_spacing<2>(walls, vec<2>(0.0, 0.0), vec<2>(0.12, 0.05), L);
  std::mt19937_64 rng(20261129);
  std::uniform_real_distribution<double> U(-0.15 * L, 0.15 * L);
  for (index_t i = 0; i < x.cols(); ++i) {
    const vec<2> y = x.col(i) + vec<2>(U(rng), U(rng));
    if ((x.col(i) - site).norm() < 1e-9)
      x.col(i) = moved;
    else if ((x.col(i) - left_site).norm() < 1e-9)
      x.col(i) = left_moved;
    else if (walls.signed_distance(y) >= 0.3 * L)
      x.col(i) = y;
  }
  scheme::lsmps_state<2> s0(x.cols());
  s0.x() = x;
  s0.u().setZero();
  s0.get<field::volume>().setConstant(L * L);
  scheme::lsmps_params<2> p;
  p.time.dt_max = 0.1 * L / std::sqrt(9.81 * 0.05);
  p.reorder_every = 0;
  p.shift_merged_faces = merged_faces;
  // Open: the wall-only projection of the penalty, in which δx** keeps every direction but into the copy's
  // wall. With the printed eq. 99 a 2D particle with a copy and a normal n ≠ 0 (a free-surface scene computes
  // one for every particle) does not shift at all: n and the wall normal remove both directions.
  if (!closed) p.shift.projection = regularize::penalty_projection::wall_only;
  using scene = std::conditional_t<closed, closed_lsmps_scene, lsmps_defaults<2>>;
  simulation<scene> sim(p, std::move(s0), &walls);
  const vec<2> n_floor(0.0, 1.0), n_incline = vec<2>(-t, 1.0).normalized();
  const auto foot_within = [&](const vec<2>& y, const vec<2>& a, const vec<2>& b, const vec<2>& nf) {
    const double s = (y - a).dot(b - a) / (b - a).squaredNorm(), d = (y - a).dot(nf);
    return s >= 0.0 && s <= 1.0 && d >= 0.0 && d < p.walls.alpha_w * L;
  };
  kink_shift_result r;
  for (int k = 0; k < steps; ++k) {
    const points<2> x_old = sim.state().x().leftCols(sim.state().n_real());  // δx is computed at x^k
    sim.step();
    for (index_t i = 0; i < x_old.cols(); ++i) {
      const vec<2> y = x_old.col(i), dx = sim.shift_displacement(i);
      if (dx.isZero(0.0) || !foot_within(y, v[1], v[2], n_floor) || !foot_within(y, v[2], v[3], n_incline))
        continue;
      ++r.checked;
      r.into = std::max({r.into, -dx.dot(n_floor) / L, -dx.dot(n_incline) / L});
    }
  }
  return r;
}

}  // namespace

TEST_SUITE("hydrostatic_polygon") {
  TEST_CASE(
      "hydrostatic box at rest for 40 sqrt(H/g), 2D (issue #4 criteria, with the one-sided-band filter)") {
    const auto r = check_long_hydrostatic<2>(90.0, 0.01);
    // Issue #4's criteria, unchanged: every bin below the top two layers within 2 % of ρ g H (measured 3e-6);
    // RMS speed ≤ 1e-3 √(gH), max ≤ 1e-2 √(gH) at t = 40 √(H/g) (measured 6e-8 and 2e-7; without the filter
    // the run failed at t ≈ 1.2 s); no particle through a wall.
    CHECK(r.max_bin_error <= 0.02);
    CHECK(r.rms_speed <= 1e-3);
    CHECK(r.max_speed <= 1e-2);
    CHECK(r.guarded == 0);
    CHECK(r.min_signed_distance > 0.0);
  }
  TEST_CASE("hydrostatic box at rest for 40 sqrt(H/g), 3D, volume correction on (issue #4 criteria)") {
    // 8 × 4 × 8 particles, L = 12.5 mm. Needs the slid-cone surface test (surface/geometric.hpp): without it
    // the 4 contact-line particles in the vertical edges were not flagged and the run failed at step ≈ 4000.
    // And c′ = 1 within R − L/2 of a wall copy: with the volume correction there (the copies bias c up to
    // 1.32 > c_max) the box moved at 3e-2 √(gH) within 10 steps and failed at t ≈ 1 s (docs/lsmps_scheme.md).
    // Still unmet past the window: quiet to t ≈ 4.1 s, the run rearranges after and fails at t ≈ 6.5 s.
    const auto r = check_long_hydrostatic<3>(90.0, 0.0125);
    CHECK(r.max_bin_error <= 0.02);  // issue #4: 2 % of ρgH per bin below the top two layers
    CHECK(r.rms_speed <= 1e-3);      // issue #4; measured max ≈ 1.5e-4 √(gH) over t ∈ [1.6, 4.1] s
    CHECK(r.max_speed <= 1e-2);
    CHECK(r.guarded == 0);
    CHECK(r.min_signed_distance > 0.0);
  }
  TEST_CASE(
      "hydrostatic tank with a 60 degree incline for 40 sqrt(H/g), 2D: pressure met, residual speed not") {
    const auto r = check_long_hydrostatic<2>(60.0, 0.01);
    CHECK(r.max_bin_error <= 0.02);  // issue #4: 2 % (measured 0.11 %)
    // Issue #4 asks RMS ≤ 1e-3 and max ≤ 1e-2 √(gH): unmet with the paper's α_g = 0.001 (measured 6.6e-3 and
    // 1.7e-2; quiet to 1e-5 until t ≈ 1 s, then a bounded rearrangement beside the incline driven by the
    // shifting, docs/lsmps_scheme.md; met with α_g = 0.002, next case). Regression bounds only:
    CHECK(r.rms_speed <= 2e-2);
    CHECK(r.max_speed <= 5e-2);
    CHECK(r.guarded == 0);
    CHECK(r.min_signed_distance > 0.0);
  }
  TEST_CASE(
      "hydrostatic tank with a 60 degree incline for 40 sqrt(H/g), 2D, alpha_g = 0.002: issue #4 criteria "
      "met") {
    // The residual motion of the case above is Tanaka's shifting (eqs. 93–100): with it off the tank stays at
    // rest to 2e-12 √(gH). Eq. 93 shifts a particle only when |g_i − x_i| > α_g L_i; the paper's table lists
    // α_g as a user-defined parameter (recommended 0.001). Beside the incline the lattice cut by the wall
    // trips α_g = 0.001 (and 0.0015: RMS 6.0e-3) from t ≈ 1 s and the rearrangement that follows does not
    // settle; from α_g = 0.002 the shifting stays idle at rest (measured RMS 1.5e-5, 1.6e-5, 2.0e-5 √(gH) for
    // α_g = 0.002, 0.003, 0.005; at L = 5 mm with 0.003: 1.3e-5). Not the default: the dam break's opt-in
    // configurations are chaotic in it (docs/lsmps_scheme.md).
    const auto r = check_long_hydrostatic<2>(60.0, 0.01, 0.002);
    CHECK(r.max_bin_error <= 0.02);  // issue #4: 2 % of ρgH per bin below the top two layers
    CHECK(r.rms_speed <= 1e-3);      // issue #4
    CHECK(r.max_speed <= 1e-2);      // issue #4
    CHECK(r.guarded == 0);
    CHECK(r.min_signed_distance > 0.0);
  }
  TEST_CASE(
      "hydrostatic prism with a 60 degree incline for 40 sqrt(H/g), 3D, eq. 99 along both walls of an edge") {
    // 8 × 4 × 8 L, L = 12.5 mm. With the defaults the run fails at step 474 (t = 0.30 s): the particles of
    // the tank's edges have copies on two walls and eq. 99 (one wall normal) let the second wall's copy push
    // them off it. lsmps_params::shift_second_wall (opt-in, ours; docs/lsmps_scheme.md deviation 12) removes
    // the component along every wall. Measured with it: bins 4.9e-4 ρgH, RMS 1.65e-4, max 5.9e-4 √(gH) at 40
    // √(H/g).
    const auto r = check_long_hydrostatic<3>(60.0, 0.0125, 0.001, true);
    CHECK(r.max_bin_error <= 0.02);  // issue #4: 2 % of ρgH per bin below the top two layers
    CHECK(r.rms_speed <= 1e-3);      // issue #4
    CHECK(r.max_speed <= 1e-2);      // issue #4
    CHECK(r.guarded == 0);
    CHECK(r.min_signed_distance > 0.0);
  }
  TEST_CASE("shifting beside an 18.4 degree concave kink (copies merged): no component into either face") {
    // Deviation 14 (lsmps_params::shift_merged_faces, docs/lsmps_scheme.md): the kink's faces differ by 18.4°
    // < merge_angle_deg = 30°, so a particle within α_w L of both has one copy, and eq. 99 alone keeps δx
    // tangential to that copy's face only. The rule removes what points into the other face, so every
    // checked δx has δx·n ≥ 0 for both faces. Removing a component along n is exact up to rounding: 1e-12 L.
    const kink_shift_result r[2][2] = {
        {run_kink_shift<true>(true, 18.4, 20), run_kink_shift<true>(false, 18.4, 20)},
        {run_kink_shift<false>(true, 18.4, 20), run_kink_shift<false>(false, 18.4, 20)}};
    for (int c = 0; c < 2; ++c) {
      const kink_shift_result &on = r[c][0], &off = r[c][1];
      MESSAGE(std::string(c == 0 ? "closed, no surface" : "open, wall_only")
              << ", 18.4 deg kink, 20 steps: with the rule " << on.checked << " checked, max into a face "
              << on.into << " L; without " << off.checked << ", " << off.into << " L");
      CHECK(on.checked > 0);
      CHECK(on.into <= 1e-12);
      // Without the rule the same scenes shift particles into a face (measured up to 3.2e-3 L in a step, the
      // same in both; the channel's ratchet): the check above can fail. 1e-4 leaves 30x room.
      CHECK(off.checked > 0);
      CHECK(off.into > 1e-4);
    }
  }
  TEST_CASE(
      "first step from rest reproduces the hydrostatic pressure, 2D tanks with 60, 45 and 90 degree walls") {
    check_first_step_hydrostatic<2>(60.0, 0.005);
    check_first_step_hydrostatic<2>(45.0, 0.005);
    check_first_step_hydrostatic<2>(90.0, 0.005);
  }
  TEST_CASE("first step from rest reproduces the hydrostatic pressure, 3D prism tanks") {
    check_first_step_hydrostatic<3>(60.0, 0.01);
    check_first_step_hydrostatic<3>(90.0, 0.01);
  }
  TEST_CASE("an isolated particle moves ballistically under gravity and is excluded from the PPE") {
    // A lone droplet far from the fluid and the walls: c < α_c (Tanaka §4.6), so u^{k+1} = u^k + Δt g and
    // x^{k+1} = x^k + Δt u^{k+1} exactly (no pressure, no viscosity, no shifting).
    const cases::polygon_tank_config tc = tall_box_config();
    const auto tank = cases::make_polygon_tank<2>(tc);
    scheme::lsmps_state<2> s0(tank.size() + 1);
    s0.x().leftCols(tank.size()) = tank.x;
    const vec<2> x0(0.1, 0.3);
    s0.x().col(tank.size()) = x0;
    s0.u().setZero();
    s0.get<field::volume>().setConstant(tc.L * tc.L);
    scheme::lsmps_params<2> p;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = 1e-3;
    p.reorder_every = 0;
    simulation<lsmps_defaults<2>> sim(p, std::move(s0), &tank.walls);
    const index_t drop = tank.size();
    double y = x0[1], v = 0.0;
    for (int k = 0; k < 50; ++k) {
      sim.step();
      v += 1e-3 * p.g[1];
      y += 1e-3 * v;
    }
    const auto& st = sim.state();
    CHECK((st.flags()[static_cast<std::size_t>(drop)] & flag::isolated) != 0);
    CHECK(st.get<field::pressure>()[drop] == 0.0);
    // The same arithmetic in the same order: equal to rounding (1e-14 of the fall).
    CHECK(std::abs(st.u()(1, drop) - v) <= 1e-12);
    CHECK(std::abs(st.x()(1, drop) - y) <= 1e-12);
    CHECK(st.x()(0, drop) == x0[0]);
    CHECK(sim.counters().isolated >= 50);
  }
  TEST_CASE("lsmps_params::remove_outside removes a particle at the first step that starts outside the box") {
    // The lone droplet of the case above, thrown up at 1 m/s from y = 0.3 m, moves ballistically; with the
    // box's top at y = 0.32 m (the tank's water is below 0.05 m) it is removed at the start of the first step
    // after its position, by the same arithmetic, is above 0.32 m, and counted. It was isolated and far from
    // the tank's fluid, so the tank's particles must be bitwise those of the same run without the box (the
    // removed particle is the last slot: nobody else moves in the state).
    const cases::polygon_tank_config tc = tall_box_config();
    const auto tank = cases::make_polygon_tank<2>(tc);
    const auto make = [&] {
      scheme::lsmps_state<2> s0(tank.size() + 1);
      s0.x().leftCols(tank.size()) = tank.x;
      s0.x().col(tank.size()) = vec<2>(0.1, 0.3);
      s0.u().setZero();
      s0.u()(1, tank.size()) = 1.0;
      s0.get<field::volume>().setConstant(tc.L * tc.L);
      return s0;
    };
    scheme::lsmps_params<2> p;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = 1e-3;
    p.reorder_every = 0;
    scheme::lsmps_params<2> pb = p;
    pb.remove_outside.hi[1] = 0.32;
    simulation<lsmps_defaults<2>> with_box(pb, make(), &tank.walls), without(p, make(), &tank.walls);
    double y = 0.3, v = 1.0;
    int k_out = -1;  // the step after which the droplet is above the box
    for (int k = 0; k < 200 && k_out < 0; ++k) {
      v += 1e-3 * p.g[1];
      y += 1e-3 * v;
      if (y > 0.32) k_out = k + 1;
    }
    REQUIRE(k_out > 0);
    REQUIRE(y - 0.32 > 1e-6);  // far from the bound compared with rounding (the case above: 1e-12)
    for (int k = 0; k < k_out + 3; ++k) {
      with_box.step();
      without.step();
      // Steps 1..k_out start inside: kept; step k_out + 1 starts above the box: removed at its start.
      CHECK(with_box.state().n_real() == tank.size() + (k + 1 <= k_out ? 1 : 0));
    }
    CHECK(with_box.counters().left_domain == 1);
    CHECK(without.counters().left_domain == 0);
    CHECK(without.state().x()(1, tank.size()) > 0.32);
    for (index_t i = 0; i < tank.size(); ++i) {
      CHECK(with_box.state().x().col(i) == without.state().x().col(i));
      CHECK(with_box.state().u().col(i) == without.state().u().col(i));
      CHECK(with_box.state().get<field::pressure>()[i] == without.state().get<field::pressure>()[i]);
    }
    // Refused: lo >= hi, NaN, a finite bound on a periodic axis.
    scheme::lsmps_params<2> bad = p;
    bad.remove_outside.hi[0] = -1.0;
    bad.remove_outside.lo[0] = 1.0;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("axis 0: lo = 1, hi = -1"), mpskit::error);
    bad = p;
    bad.remove_outside.hi[1] = std::nan("");
    CHECK_THROWS_AS(bad.validate(), mpskit::error);
    bad = p;
    bad.domain.periodic[0] = true;
    bad.domain.lo = vec<2>(0.0, 0.0);
    bad.domain.hi = vec<2>(1.0, 1.0);
    CHECK_NOTHROW(bad.validate());
    bad.remove_outside.hi[0] = 2.0;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("axis 0 is periodic"), mpskit::error);
    // A box with every particle outside is an error, not an empty run.
    scheme::lsmps_params<2> none = p;
    none.remove_outside.lo[1] = 1.0;  // everything is below 1 m
    simulation<lsmps_defaults<2>> empty(none, make(), &tank.walls);
    CHECK_THROWS_WITH_AS(empty.step(), doctest::Contains("every particle"), mpskit::error);
  }
  TEST_CASE("isolated droplets collide only with collision.isolated (seed 001 eq. 13, restitution alpha2)") {
    // Two droplets of the case above, 0.45 L apart side by side, meeting head-on at ±1 m/s: both isolated
    // (c < α_c). By default the collision stage leaves isolated particles alone (they move ballistically):
    // u_x stays ±1 m/s. With collision.isolated the pair is in contact (0.45 L < α1 L = 0.5 L) and
    // approaching, and eq. 13 with equal volumes (share 1/2) turns ±1 into ∓α2 = ∓0.2 m/s; gravity acts along
    // y, across the pair, and changes nothing of u_x. Σ V u_x stays 0 either way.
    const cases::polygon_tank_config tc = tall_box_config();
    const auto tank = cases::make_polygon_tank<2>(tc);
    const auto run = [&](bool isolated, bool before_ppe) {
      scheme::lsmps_state<2> s0(tank.size() + 2);
      s0.x().leftCols(tank.size()) = tank.x;
      s0.u().setZero();
      s0.x().col(tank.size()) = vec<2>(0.1, 0.3);
      s0.x().col(tank.size() + 1) = vec<2>(0.1 + 0.45 * tc.L, 0.3);
      s0.u().col(tank.size()) = vec<2>(1.0, 0.0);
      s0.u().col(tank.size() + 1) = vec<2>(-1.0, 0.0);
      s0.get<field::volume>().setConstant(tc.L * tc.L);
      scheme::lsmps_params<2> p;
      p.time.mode = scheme::time_step_mode::fixed;
      p.time.dt_fixed = 1e-3;
      p.reorder_every = 0;  // the droplets stay the last two columns
      p.collision.alpha1 = 0.5;
      p.collision.isolated = isolated;
      p.collide_before_ppe = before_ppe;
      simulation<lsmps_defaults<2>> sim(p, std::move(s0), &tank.walls);
      sim.step();
      const auto& st = sim.state();
      for (index_t i = tank.size(); i < tank.size() + 2; ++i)
        REQUIRE((st.flags()[static_cast<std::size_t>(i)] & flag::isolated) != 0);
      return std::array<double, 2>{st.u()(0, tank.size()), st.u()(0, tank.size() + 1)};
    };
    const std::array<double, 2> ballistic = run(false, false), bounced = run(true, false);
    CHECK(ballistic[0] == 1.0);
    CHECK(ballistic[1] == -1.0);
    CHECK(bounced[0] == doctest::Approx(-0.2).epsilon(1e-12));
    CHECK(bounced[1] == doctest::Approx(0.2).epsilon(1e-12));
    // With the stage before the PPE (collide_before_ppe) it acts on the predicted velocities (u + g Δt: the
    // same u_x) and the isolated pair keeps what it gives through the correction: the same ∓0.2 m/s, once.
    const std::array<double, 2> before = run(true, true);
    CHECK(before[0] == doctest::Approx(-0.2).epsilon(1e-12));
    CHECK(before[1] == doctest::Approx(0.2).epsilon(1e-12));
    scheme::lsmps_params<2> off;
    off.collide_before_ppe = true;  // without the stage there is nothing to move before the PPE
    CHECK_THROWS_WITH_AS(off.validate(), doctest::Contains("collide_before_ppe"), mpskit::error);
  }
  TEST_CASE("collide_before_ppe: the PPE sees the collided velocities, after the correction it does not") {
    // The tall box's water at rest with one interior pair pushed to 0.45 L apart and approaching at ±1 m/s
    // (both in the fluid, so both PPE unknowns). The first step's PPE right-hand side (u′'s divergence)
    // is the collision-free one bit for bit with the stage after the correction (it acts after the solve),
    // and differs from it with the stage before the PPE (u′ is the collided one).
    const cases::polygon_tank_config tc = tall_box_config();
    const auto tank = cases::make_polygon_tank<2>(tc);
    const vec<2> centre(0.5 * tc.W, 0.5 * tc.H);
    index_t i = 0;
    for (index_t k = 1; k < tank.size(); ++k)
      if ((tank.x.col(k) - centre).norm() < (tank.x.col(i) - centre).norm()) i = k;
    index_t j = -1;  // the right neighbour of i
    for (index_t k = 0; k < tank.size(); ++k) {
      const vec<2> d = tank.x.col(k) - tank.x.col(i);
      if (std::abs(d[1]) < 0.1 * tc.L && std::abs(d[0] - tc.L) < 0.1 * tc.L) j = k;
    }
    REQUIRE(j >= 0);
    const auto first_rhs = [&](double alpha1, bool before) {
      scheme::lsmps_state<2> s0(tank.size());
      s0.x() = tank.x;
      s0.u().setZero();
      s0.x().col(i) += vec<2>(0.55 * tc.L, 0.0);
      s0.u().col(i) = vec<2>(1.0, 0.0);
      s0.u().col(j) = vec<2>(-1.0, 0.0);
      s0.get<field::volume>().setConstant(tc.L * tc.L);
      scheme::lsmps_params<2> p;
      p.time.mode = scheme::time_step_mode::fixed;
      p.time.dt_fixed = 1e-4;
      p.reorder_every = 0;
      p.collision.alpha1 = alpha1;
      p.collide_before_ppe = before;
      simulation<lsmps_defaults<2>> sim(p, std::move(s0), &tank.walls);
      sim.step();
      REQUIRE((sim.state().flags()[static_cast<std::size_t>(i)] & (flag::isolated | flag::surface)) == 0);
      // the pair, once each way (and with the stage before the PPE the floor row's u′ = g Δt toward its
      // copies)
      if (alpha1 > 0.0)
        CHECK(sim.counters().collisions >= 2);
      else
        CHECK(sim.counters().collisions == 0);
      return Eigen::VectorXd(sim.ppe_rhs());
    };
    const Eigen::VectorXd none = first_rhs(0.0, false), after = first_rhs(0.5, false),
                          before = first_rhs(0.5, true);
    REQUIRE(after.size() == none.size());
    CHECK((after.array() == none.array()).all());
    REQUIRE(before.size() == none.size());
    CHECK((before - none).cwiseAbs().maxCoeff() > 1e-3 * none.cwiseAbs().maxCoeff());
  }
  TEST_CASE("the blow-up bound (time_step_params::max_speed) stops a run at the step that starts above it") {
    // The lone droplet of the case above falls at g with Δt = 1e-3 s: |u| = k Δt |g| at the start of step k,
    // so with the bound at 0.2 m/s the first step to start above it is k = ceil(0.2 / (Δt |g|)) (21 with
    // |g| = 9.81); the tank's fluid, at rest, stays far below 0.2 m/s over 21 steps.
    const cases::polygon_tank_config tc = tall_box_config();
    const auto tank = cases::make_polygon_tank<2>(tc);
    scheme::lsmps_state<2> s0(tank.size() + 1);
    s0.x().leftCols(tank.size()) = tank.x;
    s0.x().col(tank.size()) = vec<2>(0.1, 0.3);
    s0.u().setZero();
    s0.get<field::volume>().setConstant(tc.L * tc.L);
    scheme::lsmps_params<2> p;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = 1e-3;
    p.time.max_speed = 0.2;
    p.reorder_every = 0;
    simulation<lsmps_defaults<2>> sim(p, std::move(s0), &tank.walls);
    const long k = static_cast<long>(std::ceil(0.2 / (1e-3 * p.g.norm())));
    for (long s = 0; s < k; ++s) REQUIRE_NOTHROW(sim.step());
    const std::string expected =
        mpskit::detail::concat("blow-up at step ", k, ": particle ", tank.size(), " moves");
    CHECK_THROWS_WITH_AS(sim.step(), doctest::Contains(expected.c_str()), mpskit::error);
  }
  TEST_CASE(
      "Neumann-point walls with nothing to solve: two surface particles moving into a wall lose their normal "
      "velocity") {
    // Every fluid particle a surface one (p = 0), so the PPE has no unknown, but the correction's gradient
    // still carries the copies' Neumann data ∂p/∂n = ρ u′·n/Δt (eq. 83, copy_row = neumann_points,
    // deviation 11). A vertical pair 0.5 L from the left wall, far from the floor, moving into the wall at
    // 0.1 m/s: both have a copy, one fluid neighbour and an open cone away from the wall (surface, not
    // isolated). Until 2026-11-29 the Neumann data was set after the no-unknown return, and this first step
    // read an empty vector (a crash).
    const cases::polygon_tank_config tc = tall_box_config();
    const auto tank = cases::make_polygon_tank<2>(tc);
    scheme::lsmps_state<2> s0(2);
    const double xw = 0.0;  // the left wall (polygon_tank_config: the floor runs from x = 0 to W)
    s0.x().col(0) = vec<2>(xw + 0.5 * tc.L, 0.2);
    s0.x().col(1) = vec<2>(xw + 0.5 * tc.L, 0.2 + tc.L);
    s0.u().setZero();
    s0.u().row(0).setConstant(-0.1);
    s0.get<field::volume>().setConstant(tc.L * tc.L);
    scheme::lsmps_params<2> p;
    p.copy_row = scheme::copy_row_kind::neumann_points;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = 1e-3;
    simulation<lsmps_defaults<2>> sim(p, std::move(s0), &tank.walls);
    sim.step();
    const auto& st = sim.state();
    for (index_t i = 0; i < 2; ++i) {
      CAPTURE(i);
      // the premise: nothing to solve
      REQUIRE((st.flags()[static_cast<std::size_t>(i)] & flag::surface) != 0);
      REQUIRE((st.flags()[static_cast<std::size_t>(i)] & flag::isolated) == 0);
      CHECK(st.get<field::pressure>()[i] == 0.0);
      MESSAGE("u = (" << st.u()(0, i) << ", " << st.u()(1, i)
                      << ") m/s, x - x_wall = " << (st.x()(0, i) - xw) / tc.L << " L");
      // The Neumann-point fit imposes ∂p/∂n exactly, so Δt ∂p/∂n / ρ = u′·n cancels the normal velocity to
      // rounding (measured 1.4e-17 m/s); along the wall only gravity acts (p = 0, equal velocities: no
      // viscous term), u_y = g Δt (measured to the last digit).
      CHECK(std::abs(st.u()(0, i)) <= 1e-12);
      CHECK(std::abs(st.u()(1, i) - p.g[1] * 1e-3) <= 1e-12);
    }
    CHECK(sim.counters().guarded == 0);
  }
}

namespace {
/// The settings scheme::lsmps_impact_params sets (its wall variant's and the collision stage's), q against
/// ref.
template <class P, class Q>
void check_impact_settings(const P& q, const Q& ref) {
  CHECK(q.copy_two_point == ref.copy_two_point);
  CHECK(q.shift.projection == ref.shift.projection);
  CHECK(q.active_set_solves == ref.active_set_solves);
  CHECK(q.active_set_copies == ref.active_set_copies);
  CHECK(q.own_loop.enabled == ref.own_loop.enabled);
  CHECK(q.op.max_condition == ref.op.max_condition);
  CHECK(q.shift_velocity_limit == ref.shift_velocity_limit);
  CHECK(q.collision.alpha1 == ref.collision.alpha1);
  CHECK(q.collision.isolated == ref.collision.isolated);
  CHECK(q.shift_isolated_penalty == ref.shift_isolated_penalty);
}
}  // namespace

TEST_SUITE("bad_input") {
  TEST_CASE("LSMPS scheme: walls and geometry must match the scene, volumes must be positive") {
    cases::polygon_tank_config tc;
    tc.L = 0.01;
    tc.H = 0.05;
    const auto tank = cases::make_polygon_tank<2>(tc);
    scheme::lsmps_state<2> s0(tank.size());
    s0.x() = tank.x;
    s0.get<field::volume>().setConstant(tc.L * tc.L);
    scheme::lsmps_params<2> p;
    CHECK_THROWS_WITH_AS(simulation<lsmps_defaults<2>>(p, s0, nullptr),
                         doctest::Contains("no geometry"), mpskit::error);
    CHECK_THROWS_WITH_AS(simulation<cases::taylor_green_scene>(p, s0, &tank.walls),
                         doctest::Contains("walls given"), mpskit::error);
    auto bad = s0;
    bad.get<field::volume>()[3] = 0.0;
    CHECK_THROWS_WITH_AS(simulation<lsmps_defaults<2>>(p, bad, &tank.walls),
                         doctest::Contains("particle 3 has volume"), mpskit::error);
    auto wall = s0;
    wall.kinds()[5] = kind::wall;
    CHECK_THROWS_WITH_AS(simulation<lsmps_defaults<2>>(p, wall, &tank.walls),
                         doctest::Contains("fluid particles only"), mpskit::error);
    p.volume.c_prime_min = 1.5;
    CHECK_THROWS_WITH_AS(simulation<lsmps_defaults<2>>(p, s0, &tank.walls),
                         doctest::Contains("c_prime_min"), mpskit::error);
    p.volume = {};
    p.boundary_filter.size_ratio = 0.9;  // a factor between diameters: ≥ 1
    CHECK_THROWS_WITH_AS(simulation<lsmps_defaults<2>>(p, s0, &tank.walls),
                         doctest::Contains("size_ratio"), mpskit::error);
  }

  // examples/tanaka_dam_break.cpp's command line (cases/tanaka_dam_break_options.hpp): the examples are not
  // built in CI, so their defaults and refusals are checked here. Each refusal names its option.
  TEST_CASE("tanaka_dam_break's command line: defaults, readings and refusals") {
    const auto read = [](std::vector<const char*> args) {
      args.insert(args.begin(), "tanaka_dam_break");
      return cases::read_tanaka_dam_break_options(static_cast<int>(args.size()), args.data(), "data-dir");
    };
    // The defaults: the library's impact configuration (the example's header says so), 5 mm to T = 3.2.
    const scheme::lsmps_params<2> impact = scheme::lsmps_impact_params<2>();
    const cases::tanaka_dam_break_options d = read({});
    CHECK(d.L_mm == 5.0);
    CHECK(d.T_end == 3.2);
    CHECK(d.lsmps.collision == impact.collision.alpha1);
    CHECK(d.lsmps.colliding_isolated() == impact.collision.isolated);
    CHECK(d.lsmps.shift_isolated == impact.shift_isolated_penalty);
    CHECK(d.lsmps.walls_name == cases::tanaka_impact_walls);
    const scheme::lsmps_params<2> q = d.lsmps.params("test");  // what the example runs with
    check_impact_settings(q, impact);
    CHECK(d.data == "data-dir");
    CHECK_NOTHROW(d.validate());
    CHECK(d.config().L == doctest::Approx(5e-3).epsilon(1e-15));
    CHECK_FALSE(d.config().closed_top);

    // Readings: --full is 1 mm; --collision 0 lets the default "isolated particles collide" lapse; the lid
    // and the obstacle reach the case.
    const auto f =
        read({"--full", "--collision", "0", "--T", "1.5", "--lid", "300", "--obstacle", "--out", "o"});
    CHECK(f.L_mm == 1.0);
    CHECK(f.T_end == 1.5);
    CHECK_FALSE(f.lsmps.colliding_isolated());
    CHECK(f.out == "o");
    CHECK_NOTHROW(f.validate());
    const cases::tanaka_dam_break_config cfg = f.config();
    CHECK(cfg.closed_top);
    CHECK(cfg.vessel_height == doctest::Approx(0.3).epsilon(1e-15));
    CHECK(cfg.obstacle_width > 0.0);
    CHECK_NOTHROW(read({"--slab", "4", "--walls", "parent_gradient", "--slab-walls"}).validate());
    // The 3D slab's parameters: the impact configuration by default, Table 2 with --walls parent_gradient,
    // the collision and isolated-particle options applied to both.
    check_impact_settings(read({"--slab", "4"}).lsmps.slab_params(), scheme::lsmps_impact_params<3>());
    const auto table2 =
        read({"--slab", "4", "--walls", "parent_gradient", "--collision", "0", "--no-shift-isolated"});
    check_impact_settings(table2.lsmps.slab_params(), scheme::lsmps_params<3>{});
    CHECK(std::string(table2.lsmps.slab_scheme_name()).find("Table 2") != std::string::npos);
    const scheme::lsmps_params<3> slab =
        read({"--slab", "4", "--collision", "0.3", "--no-collide-isolated", "--no-shift-isolated"})
            .lsmps.slab_params();
    CHECK(slab.collision.alpha1 == 0.3);
    CHECK_FALSE(slab.collision.isolated);
    CHECK_FALSE(slab.shift_isolated_penalty);
    CHECK(slab.copy_two_point == scheme::lsmps_impact_params<3>().copy_two_point);
    CHECK_NOTHROW(read({"--no-collide-isolated", "--collision", "0"}).validate());
    const auto pieces =
        read({"--checkpoint", "ck.bin", "--every", "600", "--stop-after", "60", "--resume", "r.bin"});
    CHECK_NOTHROW(pieces.validate());
    CHECK(pieces.pieces.checkpoint == "ck.bin");
    CHECK(pieces.pieces.checkpoint_interval == 600.0);
    CHECK(pieces.pieces.stop_after == 60.0);
    CHECK(pieces.pieces.resume == "r.bin");

    // Reading: a number is the whole text (no atof zero), an option needs its value, an unknown one is
    // refused.
    CHECK_THROWS_WITH_AS(read({"--collision", "abc"}), doctest::Contains("--collision 'abc'"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--L", "3mm"}), doctest::Contains("--L '3mm'"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--T", "inf"}), doctest::Contains("--T 'inf'"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--T"}), doctest::Contains("--T needs a value"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--lenght", "3"}), doctest::Contains("unknown option '--lenght'"),
                         mpskit::error);

    // Validation, before any output.
    const auto refused = [&](std::vector<const char*> args, const char* text) {
      const cases::tanaka_dam_break_options o = read(std::move(args));
      CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains(text), mpskit::error);
    };
    refused({"--L", "0"}, "--L 0 mm: must be > 0");
    refused({"--T", "-1"}, "--T -1: must be > 0");
    refused({"--trace", "-2"}, "--trace -2 m/s: must be >= 0");
    refused({"--fallback", "--ilu0"}, "--fallback and --ilu0 name two solvers");
    refused({"--every", "600"}, "need a checkpoint file");
    refused({"--checkpoint", "ck.bin", "--stop-after", "-1"}, "must be finite and >= 0");
    refused({"--walls", "nope"}, "wall variant 'nope'");
    refused({"--collision", "2"}, "alpha1");
    refused({"--collision", "0", "--collide-isolated"}, "needs the collision stage on");
    refused({"--slab", "2.5"}, "whole number in [1, 1000]");
    refused({"--slab", "0"}, "whole number in [1, 1000]");
    for (const char* two_d : {"--obstacle", "--fallback", "--ilu0"})
      refused({"--slab", "4", two_d}, "--slab takes neither");
    refused({"--slab", "4", "--trace", "7"}, "--slab takes neither");
    refused({"--slab", "4", "--checkpoint", "ck.bin"}, "--slab takes neither");
    refused({"--slab", "4", "--resume", "ck.bin"}, "--slab takes neither");
    refused({"--slab", "4", "--walls", "neumann_points"}, "--slab takes --walls");
    refused({"--slab-walls"}, "--slab-walls needs --slab N");
    // The case's own check: a lid at or below the water (the column is 200 mm high).
    CHECK_THROWS_WITH_AS(read({"--lid", "150"}).config(), doctest::Contains("vessel_height"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--L", "150"}).config(), doctest::Contains("tanaka_dam_break_config.L"),
                         mpskit::error);
  }

  // examples/cases/cli.hpp, which every example and benchmark reads its numbers through.
  TEST_CASE("cases/cli.hpp: numbers are the whole text, finite and within their bound") {
    CHECK(cases::parse_number("--x", "1e-3") == 1e-3);
    CHECK(cases::parse_number("--x", "-2.5") == -2.5);
    CHECK(cases::parse_number("--x", "0", 0.0) == 0.0);
    CHECK_THROWS_WITH_AS(cases::parse_number("--x", ""), doctest::Contains("--x '': must be a finite number"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_number("--x", "abc"), doctest::Contains("--x 'abc'"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_number("--x", "1.5x"), doctest::Contains("--x '1.5x'"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_number("--x", "nan"), doctest::Contains("--x 'nan'"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_number("--x", "-inf"), doctest::Contains("--x '-inf'"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_number("--x", "-1", 0.0),
                         doctest::Contains("must be a finite number >= 0"), mpskit::error);
    CHECK(cases::parse_numbers("--xs", "3,3.5,4", 0.0) == std::vector<double>{3.0, 3.5, 4.0});
    CHECK_THROWS_WITH_AS(cases::parse_numbers("--xs", "3,,4", 0.0), doctest::Contains("--xs ''"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_numbers("--xs", "", 0.0), doctest::Contains("--xs: an empty list"),
                         mpskit::error);
    CHECK(cases::parse_integer("--n", "25", 1) == 25);
    CHECK_THROWS_WITH_AS(cases::parse_integer("--n", "2.5", 1),
                         doctest::Contains("2.5 is not a whole number"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::parse_integer("--n", "0", 1), doctest::Contains(">= 1"), mpskit::error);
    CHECK(cases::parse_integers("--ns", "25,50", 1) == std::vector<int>{25, 50});
    CHECK_THROWS_WITH_AS(cases::parse_integers("--ns", "25,5e9", 1), doctest::Contains("not a whole number"),
                         mpskit::error);
  }
}

namespace {
/// Five steps of the inviscid Taylor-Green vortex (4900 particles: above exec::par's 4096-item threshold, so
/// the loops do run on two threads) on `threads` threads, with the collision stage at collision_alpha1 (0:
/// off): positions, velocities, pressures and the colliding pairs counted.
struct tg_threads_run {
  points<2> x, u;
  Eigen::VectorXd p;
  long collisions = 0;
};
/// The inviscid Taylor-Green vortex on an n x n lattice, periodic in both axes, with the collision stage at
/// alpha1.
cases::taylor_green_config tg_periodic(int n, double collision_alpha1) {
  cases::taylor_green_config c;
  c.n = n;
  c.params.nu = 0.0;
  c.params.g.setZero();
  c.params.domain.periodic = {true, true};
  c.params.domain.hi = vec<2>::Constant(c.width);
  c.params.time.dt_max = 0.09 / c.n;
  c.params.collision.alpha1 = collision_alpha1;
  return c;
}
[[maybe_unused]] tg_threads_run run_tg_threads(int threads, double collision_alpha1) {
  const cases::taylor_green_config c = tg_periodic(70, collision_alpha1);
  const auto& p = c.params;
#ifdef _OPENMP
  omp_set_num_threads(threads);
#endif
  simulation<cases::taylor_green_scene> sim(p, cases::taylor_green_state(c));
  for (int k = 0; k < 5; ++k) sim.step();
  return {sim.state().x(), sim.state().u(), sim.state().get<field::pressure>(), sim.counters().collisions};
}
}  // namespace

TEST_SUITE("lsmps_threads") {
  TEST_CASE("LSMPS scheme: bitwise identical for 1 and 2 threads (Taylor-Green, 4900 particles, 5 steps)") {
#ifdef _OPENMP
    const tg_threads_run a = run_tg_threads(1, 0.0), b = run_tg_threads(2, 0.0);
    CHECK((a.x.array() == b.x.array()).all());
    CHECK((a.p.array() == b.p.array()).all());
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
  TEST_CASE("LSMPS scheme: a coincident pair is counted by the collision stage and the shifting") {
    // Two particles at one point have no direction between them: the collision stage skips the pair and so
    // does eq. 94 of the shifting; each counts it (lsmps_counters::collision_coincident, shift_coincident),
    // once per direction. The Taylor-Green lattice (20 x 20, periodic) with particle 210 duplicated (same x,
    // u, V): one step counts 2 directed pairs in each; the lattice without the duplicate counts none.
    const auto one_step = [](bool duplicate) {
      const cases::taylor_green_config c = tg_periodic(20, 0.5);
      const scheme::lsmps_state<2> lattice = cases::taylor_green_state(c);
      const index_t n = lattice.n_real() + (duplicate ? 1 : 0), k = 210;
      scheme::lsmps_state<2> s(n);
      for (index_t i = 0; i < n; ++i) {
        const index_t from = i < lattice.n_real() ? i : k;
        s.x().col(i) = lattice.x().col(from);
        s.u().col(i) = lattice.u().col(from);
        s.get<field::volume>()[i] = lattice.get<field::volume>()[from];
      }
      simulation<cases::taylor_green_scene> sim(c.params, std::move(s));
      sim.step();
      return sim.counters();
    };
    const scheme::lsmps_counters with = one_step(true), without = one_step(false);
    CHECK(with.collision_coincident == 2);
    CHECK(with.shift_coincident == 2);
    CHECK(without.collision_coincident == 0);
    CHECK(without.shift_coincident == 0);
  }
  TEST_CASE("LSMPS scheme with the collision stage: bitwise identical for 1 and 2 threads, pairs collide") {
    // The opt-in stage 9c (lsmps_params::collision, deviation 17) inside the stepper: the same Taylor-Green
    // set-up with alpha1 = 1 (contact at r <= L_ij: the lattice's nearest neighbours are at r = L, so the
    // approaching pairs of the vortex's strain collide from the first step). Every Δu of the stage is
    // computed from the same u (Jacobi), so the thread count must not change a bit; and the stage must
    // actually act.
#ifdef _OPENMP
    const tg_threads_run a = run_tg_threads(1, 1.0), b = run_tg_threads(2, 1.0);
    CHECK(a.collisions > 0);
    CHECK(a.collisions == b.collisions);
    CHECK((a.x.array() == b.x.array()).all());
    CHECK((a.u.array() == b.u.array()).all());
    CHECK((a.p.array() == b.p.array()).all());
    MESSAGE("colliding pairs in 5 steps: " << a.collisions);
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
}

namespace {

// One step of a 12 × 12 lattice blob (spacing 0.01 m) in free space (surface test on, no walls, g = 0) with
// the velocity u(x − x_c) at each particle and the active-set options given: the pressures and the last PPE
// system.
struct blob_step {
  Eigen::VectorXd p, b;  // pressures by particle; the last PPE's right-hand side (rows: `rows`)
  ppe::matrix A;
  std::vector<index_t> rows;
  scheme::lsmps_counters c;
};
constexpr int blob_n = 12;
constexpr double blob_L = 0.01;

blob_step run_blob_step(const std::function<vec<2>(const vec<2>&)>& u, int solves, bool reuse, bool release) {
  struct blob : lsmps_defaults<2> {
    using walls = scheme::no_walls;
  };
  const int N = blob_n;
  const double L = blob_L, xc = 0.5 * N * L;
  scheme::lsmps_state<2> s0(N * N);
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) s0.x().col(i * N + j) << (i + 0.5) * L, (j + 0.5) * L;
  for (int k = 0; k < N * N; ++k) s0.u().col(k) = u(vec<2>(s0.x().col(k) - vec<2>(xc, xc)));
  s0.template get<field::volume>().setConstant(L * L);
  scheme::lsmps_params<2> p;
  p.g.setZero();
  p.active_set_solves = solves;
  p.active_set_reuse_rows = reuse;
  p.active_set_release = release;
  simulation<blob> sim(p, std::move(s0));
  sim.step();
  return blob_step{Eigen::VectorXd(sim.state().get<field::pressure>().head(N * N)), sim.ppe_rhs(),
                   sim.ppe_matrix(), sim.ppe_rows(), sim.counters()};
}

// The 0.32 × 0.3 m tank of run_tank_blob (a static: the simulations keep a pointer to it).
const geometry::polygon_set<2>& blob_tank() {
  static const geometry::polygon_set<2> walls(geometry::tank(vec<2>(0.0, 0.0), vec<2>(0.32, 0.3)));
  return walls;
}
using tank_blob_sim = simulation<lsmps_defaults<2>>;

// The blob of run_blob_step on the floor of blob_tank() (from x = 0.1 m; copies as unknowns, rows beside the
// wall), with gravity, the velocity u(x − (x_c, 0)) and the active set (10 repeats) with the options given.
tank_blob_sim make_tank_blob(const std::function<vec<2>(const vec<2>&)>& u, bool reuse, bool release,
                             bool warm = false) {
  const int N = blob_n;
  const double L = blob_L, xc = 0.1 + 0.5 * N * L;
  scheme::lsmps_state<2> s0(N * N);
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) s0.x().col(i * N + j) << 0.1 + (i + 0.5) * L, (j + 0.5) * L;
  for (int k = 0; k < N * N; ++k) s0.u().col(k) = u(vec<2>(s0.x().col(k) - vec<2>(xc, 0.0)));
  s0.template get<field::volume>().setConstant(L * L);
  scheme::lsmps_params<2> p;
  p.active_set_solves = 10;
  p.active_set_reuse_rows = reuse;
  p.active_set_release = release;
  p.active_set_warm_start = warm;
  return tank_blob_sim(p, std::move(s0), &blob_tank());
}

// make_tank_blob run `steps` steps: positions, counters.
std::pair<Eigen::MatrixXd, scheme::lsmps_counters> run_tank_blob(
    const std::function<vec<2>(const vec<2>&)>& u, int steps, bool reuse, bool release, bool warm = false) {
  tank_blob_sim sim = make_tank_blob(u, reuse, release, warm);
  for (int k = 0; k < steps; ++k) sim.step();
  return std::pair(Eigen::MatrixXd(sim.state().x().leftCols(blob_n * blob_n)), sim.counters());
}

// Two runs of run_tank_blob, rows reused and rows built for every repeat: bitwise the same run.
void check_same_tank_run(const std::pair<Eigen::MatrixXd, scheme::lsmps_counters>& reuse,
                         const std::pair<Eigen::MatrixXd, scheme::lsmps_counters>& build) {
  CHECK(reuse.second.copies > 0);
  CHECK(reuse.second.active_set_rows == build.second.active_set_rows);
  CHECK(reuse.second.active_set_released == build.second.active_set_released);
  CHECK(reuse.second.active_set_solves == build.second.active_set_solves);
  CHECK(reuse.second.ppe_iterations == build.second.ppe_iterations);
  CHECK((reuse.first.array() == build.first.array()).all());
}

}  // namespace

TEST_SUITE("det_f") {
  // Compile-time refusal (Tanaka §4.3: eq. 63 needs every second derivative separately).
  static_assert(!ppe::SecondDerivativeOperator<op::mps<2, kernel::quadratic>>, "classic MPS must be refused");
  static_assert(!ppe::SecondDerivativeOperator<op::lsmps_a<2, 1>>, "LSMPS order 1 must be refused");
  static_assert(ppe::SecondDerivativeOperator<op::lsmps_a<2, 2>> &&
                ppe::SecondDerivativeOperator<op::lsmps_a<3, 3>>);

  TEST_CASE(
      "PPE: fluid rows whose operator has a non-negative diagonal become p = 0 rows (wrong_sign_rows)") {
    // An 8 × 8 lattice blob in free space with no surface test: every row is a det F row, and at the blob's
    // edge the one-sided LSMPS-A second derivatives give 20 rows a diagonal ≥ 0 (measured; up to +12.7
    // against −1.1 or less elsewhere). Such a row is no discrete Laplacian at its particle; with them kept
    // the BiCGSTAB solve of this first step diverged (NaN). The default makes those particles free surface.
    struct blob : lsmps_defaults<2> {
      using walls = scheme::no_walls;
      using surface = scheme::no_surface;
    };
    const int N = 8;
    const double L = 0.01;
    const auto run = [&](scheme::wrong_sign_row mode, long& wrong, long& counted) {
      scheme::lsmps_state<2> s0(N * N);
      for (int a = 0; a < N; ++a)
        for (int b = 0; b < N; ++b) s0.x().col(a * N + b) << (a + 0.5) * L, (b + 0.5) * L;
      s0.u().setZero();
      s0.template get<field::volume>().setConstant(L * L);
      scheme::lsmps_params<2> p;
      p.wrong_sign_rows = mode;
      simulation<blob> sim(p, std::move(s0));
      bool solved = true;
      try {
        sim.step();
      } catch (const mpskit::error&) {  // `keep`: the solve may fail; the matrix is what is checked
        solved = false;
      }
      const auto& A = sim.ppe_matrix();
      wrong = 0;
      for (Eigen::Index r = 0; r < A.rows(); ++r) wrong += A.coeff(r, r) >= 0.0;
      counted = sim.counters().wrong_sign_rows;
      return solved && sim.last_solve().info == Eigen::Success;
    };
    long wrong = 0, counted = 0;
    run(scheme::wrong_sign_row::keep, wrong, counted);
    CHECK(wrong > 0);  // the configuration does produce such rows (measured 20)
    CHECK(counted == 0);
    const long kept = wrong;
    const bool solved = run(scheme::wrong_sign_row::dirichlet, wrong, counted);
    CHECK(wrong == 0);       // no row with a diagonal ≥ 0 is left
    CHECK(counted == kept);  // each was counted once, and only those
    CHECK(solved);
  }

  TEST_CASE("time step: Courant per particle (Tanaka eq. 64), min_i L_i/|u_i|, not min L / max |u|") {
    // Two 6 × 6 blobs far apart in free space (no walls, no surface test, g = 0): fine (L = 1 mm) at rest and
    // coarse (L = 2 mm) moving at 1 m/s. Eq. 64 limits Δt by the coarse blob, α_C 2 mm / (1 m/s) = 2e-4 s, so
    // the ladder 1e-3 / 2^k gives 1.25e-4 s; the global rule α_C (1 mm) / (1 m/s) = 1e-4 s gives 6.25e-5 s.
    // With one diameter the two rules are the same (the fine blob moving too: both 6.25e-5 s).
    struct blobs : lsmps_defaults<2> {
      using walls = scheme::no_walls;
      using surface = scheme::no_surface;
    };
    const auto dt_of = [](bool per_particle, double u_fine) {
      const int N = 6;
      scheme::lsmps_state<2> s0(2 * N * N);
      auto& V = s0.template get<field::volume>();
      for (int a = 0; a < N; ++a)
        for (int b = 0; b < N; ++b) {
          const index_t f = a * N + b, c = N * N + f;
          s0.x().col(f) << (a + 0.5) * 1e-3, (b + 0.5) * 1e-3;
          s0.x().col(c) << 0.1 + (a + 0.5) * 2e-3, (b + 0.5) * 2e-3;
          s0.u().col(f) << u_fine, 0.0;
          s0.u().col(c) << 1.0, 0.0;
          V[f] = 1e-6;
          V[c] = 4e-6;
        }
      scheme::lsmps_params<2> p;
      p.g.setZero();
      p.time.per_particle_courant = per_particle;
      simulation<blobs> sim(p, std::move(s0));
      sim.step();
      return sim.dt();
    };
    CHECK(dt_of(true, 0.0) == 1.25e-4);
    CHECK(dt_of(false, 0.0) == 6.25e-5);
    CHECK(dt_of(true, 1.0) == 6.25e-5);
    CHECK(dt_of(false, 1.0) == 6.25e-5);
  }

  TEST_CASE(
      "PPE active set (active_set_solves): p >= 0 where the plain solve pulls, unchanged where it pushes") {
    // The blob of run_blob_step with u = a (x − x_c): expanding
    // (a > 0) the det F source is positive and the plain solve gives negative pressures inside; with the
    // active set those particles are held at p = 0 and the PPE solved again until none is negative.
    // Contracting (a < 0) every solved pressure is positive, so the active set must change nothing (bitwise).
    using outcome = blob_step;
    const auto run = [](double a, int solves, bool reuse = true) {
      return run_blob_step([a](const vec<2>& d) { return vec<2>(a * d); }, solves, reuse, false);
    };
    const outcome pull = run(1.0, 0), held = run(1.0, 10);
    CHECK(pull.p.minCoeff() < 0.0);  // the case does exercise the set (plain solve: negative inside)
    CHECK(pull.c.active_set_rows == 0);
    CHECK(held.p.minCoeff() >= 0.0);  // exactly: a pressure < 0 left would be counted as unfinished
    CHECK(held.c.active_set_rows > 0);
    CHECK(held.c.active_set_solves >= 1);
    CHECK(held.c.active_set_unfinished == 0);
    MESSAGE("expanding blob: plain min p = " << pull.p.minCoeff() << " Pa, active set "
                                             << held.c.active_set_rows << " rows in "
                                             << held.c.active_set_solves << " repeated solves");
    const outcome push = run(-1.0, 0), same = run(-1.0, 10);
    CHECK(push.p.minCoeff() >= 0.0);
    CHECK(same.c.active_set_rows == 0);
    CHECK((push.p.array() == same.p.array()).all());
    // The repeats reuse the first build's rows (active_set_reuse_rows, default): bitwise what rebuilding them
    // gives, here and over 5 steps of the blob expanding on the floor of a tank (copies as unknowns, rows
    // beside the wall, Dirichlet flags changing as particles join the set).
    CHECK((run(1.0, 10, false).p.array() == held.p.array()).all());
    const auto run_tank = [](bool reuse) {
      return run_tank_blob([](const vec<2>& d) { return d; }, 5, reuse, false);
    };
    {
      scheme::lsmps_params<2> p;
      CHECK(p.active_set_reuse_rows);
    }
    const auto tank = run_tank(true);
    const auto& c_reuse = tank.second;
    CHECK(c_reuse.active_set_rows > 0);
    check_same_tank_run(tank, run_tank(false));
    MESSAGE("blob on a tank floor, 5 steps: " << c_reuse.active_set_rows << " rows in the set over "
                                              << c_reuse.active_set_solves << " repeated solves, "
                                              << c_reuse.copies << " copies");
    // Refused: a negative count, and clamping together with the set (it would hide what the set looks for).
    scheme::lsmps_params<2> bad;
    bad.active_set_solves = -1;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("active_set_solves"), mpskit::error);
    bad.active_set_solves = 2;
    bad.negative = scheme::negative_pressure::clamp_to_zero;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("negative = keep"), mpskit::error);
  }

  TEST_CASE(
      "PPE active set with releases (active_set_release): the complementarity p >= 0, w >= 0, p w = 0") {
    // The blob of run_blob_step with u = (|x − x_c|, 0): the left half is compressed, the right
    // half stretched, so the plain solve pulls (p < 0) on the right. The set without releases holds the right
    // half at p = 0, and some of it is then squeezed by the left half's pressure: freed, those rows would
    // take p > 0 (w = b − A p < 0 with a_ii < 0). With releases they leave the set. Checked against the plain
    // run's system (A0, b0: the same first build, every non-surface particle an unknown, the rows independent
    // of the set): rows with p > 0 meet their equation to the solver's tolerance (1e-8 relative, checked at
    // 1e-6 of max |b0|), rows held at p = 0 have w / a_ii <= 0 (to 1e-9 of the largest pressure: round-off of
    // two summation orders).
    using outcome = blob_step;
    const auto run = [](bool contracting, int solves, bool release, bool reuse = true) {
      if (contracting)
        return run_blob_step([](const vec<2>& d) { return vec<2>(-d); }, solves, reuse, release);
      return run_blob_step([](const vec<2>& d) { return vec<2>(std::abs(d[0]), 0.0); }, solves, reuse,
                           release);
    };
    const outcome plain = run(false, 0, false);
    CHECK(plain.p.minCoeff() < 0.0);
    // Complementarity of pressures p (by particle) against the plain system: {rows held at 0 violating
    // w >= 0, negatives, largest |w| / max|b0| over the rows with p > 0}.
    const auto check = [&](const Eigen::VectorXd& p) {
      const auto m = static_cast<Eigen::Index>(plain.rows.size());
      Eigen::VectorXd pu(m);
      for (Eigen::Index k = 0; k < m; ++k) pu[k] = p[plain.rows[static_cast<std::size_t>(k)]];
      const Eigen::VectorXd w = plain.b - plain.A * pu;
      int violating = 0, negative = 0;
      double equation = 0.0;
      for (Eigen::Index k = 0; k < m; ++k) {
        if (pu[k] < 0.0) ++negative;
        if (pu[k] == 0.0 && w[k] / plain.A.coeff(k, k) > 1e-9 * p.maxCoeff()) ++violating;
        if (pu[k] > 0.0) equation = std::max(equation, std::abs(w[k]) / plain.b.lpNorm<Eigen::Infinity>());
      }
      return std::tuple(violating, negative, equation);
    };
    const outcome grow = run(false, 10, false), released = run(false, 10, true);
    const auto [v_grow, n_grow, e_grow] = check(grow.p);
    const auto [v_rel, n_rel, e_rel] = check(released.p);
    CHECK(n_grow == 0);
    CHECK(v_grow > 0);  // the case exercises the releases: the grow-only set squeezes some of its particles
    CHECK(e_grow < 1e-6);
    CHECK(released.c.active_set_released > 0);
    CHECK(released.c.active_set_unfinished == 0);
    CHECK(n_rel == 0);
    CHECK(v_rel == 0);
    CHECK(e_rel < 1e-6);
    MESSAGE("half-compressed blob: grow-only set leaves "
            << v_grow << " rows squeezed at p = 0; with releases " << released.c.active_set_released
            << " released, residual " << e_rel);
    // With releases the repeats reuse the rows between joins and build them all after a release
    // (active_set_reuse_rows, default): bitwise what building every row for every repeat gives, same counts.
    const outcome rebuilt = run(false, 10, true, false);
    CHECK((rebuilt.p.array() == released.p.array()).all());
    CHECK(rebuilt.c.active_set_released == released.c.active_set_released);
    CHECK(rebuilt.c.active_set_solves == released.c.active_set_solves);
    CHECK(rebuilt.c.ppe_iterations == released.c.ppe_iterations);
    // The same over 6 steps of that blob on the floor of a tank (copies as unknowns, rows beside the wall,
    // particles joining and leaving the set over several repeats and steps).
    const auto run_tank = [](bool reuse) {
      return run_tank_blob([](const vec<2>& d) { return vec<2>(std::abs(d[0]), 0.0); }, 6, reuse, true);
    };
    const auto tank = run_tank(true);
    const auto& c_reuse = tank.second;
    CHECK(c_reuse.active_set_released > 0);
    check_same_tank_run(tank, run_tank(false));
    MESSAGE("half-compressed blob on a tank floor, 6 steps: "
            << c_reuse.active_set_released << " released, " << c_reuse.active_set_rows << " joined in "
            << c_reuse.active_set_solves << " repeated solves");
    // A step whose last allowed solve leaves members that their rows would release, and no negative pressure,
    // is counted unfinished too (until 2026-12-05 only negatives were): one repeat, which releases nothing.
    const outcome cut = run(false, 1, true);
    const auto [v_cut, n_cut, e_cut] = check(cut.p);
    CHECK(v_cut > 0);
    CHECK(n_cut == 0);
    CHECK(cut.c.active_set_released == 0);
    CHECK(cut.c.active_set_unfinished == 1);
    // Nothing to release where nothing pulls: a contracting blob's pressures are bitwise the plain ones.
    const outcome push = run(true, 0, false), push_rel = run(true, 10, true);
    CHECK(push.p.minCoeff() >= 0.0);
    CHECK((push.p.array() == push_rel.p.array()).all());
    CHECK(push_rel.c.active_set_released == 0);
    scheme::lsmps_params<2> bad;
    bad.active_set_release = true;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("active_set_release"), mpskit::error);
  }

  TEST_CASE(
      "PPE active set warm-started from the last solve's set (active_set_warm_start): fewer repeats, "
      "restart") {
    // The 6 steps of the release test's half-compressed blob on a tank floor, each step's set started empty
    // (cold, the default) and from the set the previous step ended with (warm: its particles held at p = 0
    // from the first solve, the releases tested after it). Where every step's iteration converges (no step
    // unfinished) both runs end at complementarity points of the same problem; when the point is unique (not
    // shown for these non-symmetric rows, but then they differ only by the solver's tolerance, 1e-8 relative,
    // carried through 6 steps) positions agree within 1e-9 m (1e-7 L), measured 1.02e-12 m; not bitwise, or
    // the warm start did nothing. The repeated solves and releases must drop: that is what the option is for.
    const auto u = [](const vec<2>& d) { return vec<2>(std::abs(d[0]), 0.0); };
    const auto cold = run_tank_blob(u, 6, true, true);
    const auto warm = run_tank_blob(u, 6, true, true, true);
    CHECK(cold.second.active_set_unfinished == 0);
    CHECK(warm.second.active_set_unfinished == 0);
    CHECK(warm.second.active_set_solves < cold.second.active_set_solves);
    CHECK(warm.second.active_set_released < cold.second.active_set_released);
    const double dx = (warm.first - cold.first).cwiseAbs().maxCoeff();
    CHECK(dx > 0.0);
    CHECK(dx < 1e-9);
    MESSAGE("blob on a tank floor, 6 steps, cold / warm start: "
            << cold.second.active_set_solves << " / " << warm.second.active_set_solves << " repeated solves, "
            << cold.second.active_set_released << " / " << warm.second.active_set_released
            << " released; largest position difference " << dx << " m");
    // The carried set is state: 3 steps, saved, 3 more; loaded into a new stepper, 3 more: bitwise the same.
    mpskit::test::scratch tmp("mpskit_test_lsmps_flow", "warm_start");
    tank_blob_sim a = make_tank_blob(u, true, true, true);
    for (int k = 0; k < 3; ++k) a.step();
    const std::vector<particle_id> held = a.active_set_held();
    CHECK(!held.empty());
    CHECK(std::is_sorted(held.begin(), held.end()));
    io::save_simulation(tmp / "w.mpscp", a);
    for (int k = 0; k < 3; ++k) a.step();
    tank_blob_sim b = make_tank_blob(u, true, true, true);
    io::load_simulation(tmp / "w.mpscp", b);
    CHECK(b.active_set_held() == held);
    for (int k = 0; k < 3; ++k) b.step();
    const index_t n = blob_n * blob_n;
    CHECK((a.state().x().leftCols(n).array() == b.state().x().leftCols(n).array()).all());
    CHECK(
        (a.state().get<field::pressure>().head(n).array() == b.state().get<field::pressure>().head(n).array())
            .all());
    CHECK(a.active_set_held() == b.active_set_held());
    CHECK(a.counters().active_set_solves == b.counters().active_set_solves);
    CHECK(a.counters().active_set_released == b.counters().active_set_released);
    io::checkpoint_sections sec;  // the file holds the set
    tank_blob_sim probe = make_tank_blob(u, true, true, true);
    io::load_simulation(tmp / "w.mpscp", probe, &sec);
    CHECK(sec.get_int64s("lsmps.active_set_held").size() == held.size());
    // Refused: a warm start without releases (the set could only grow), and held ids that are no particle's.
    scheme::lsmps_params<2> bad;
    bad.active_set_solves = 10;
    bad.active_set_warm_start = true;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("active_set_warm_start"), mpskit::error);
    tank_blob_sim d = make_tank_blob(u, true, true, true);
    tank_blob_sim::state_type st = a.state();
    st.clear_ghosts();
    CHECK_THROWS_WITH_AS(d.restore(st, 0.0, 0.0, {}, {}, {}, 0, {held.back() + 100000}),
                         doctest::Contains("held ids"), mpskit::error);
    CHECK_THROWS_WITH_AS(d.restore(st, 0.0, 0.0, {}, {}, {}, 0, {held[0], held[0]}),
                         doctest::Contains("held ids"), mpskit::error);
  }

  TEST_CASE("c' of eq. 62: 1 inside [c_min, c_max], linear outside, limited to [c'_min, c'_max]") {
    const ppe::det_f s;  // c_min 0.95, c_max 1.2, c'_min 0.999, c'_max 1.001 (Tanaka Table 2)
    CHECK(s.volume_ratio(0.95) == 1.0);
    CHECK(s.volume_ratio(1.0) == 1.0);
    CHECK(s.volume_ratio(1.2) == 1.0);
    CHECK(s.volume_ratio(0.9496) == doctest::Approx(0.9996).epsilon(1e-12));  // c − c_min + 1
    CHECK(s.volume_ratio(0.5) == 0.999);                                        // limited
    CHECK(s.volume_ratio(1.2004) == doctest::Approx(1.0004).epsilon(1e-12));
    CHECK(s.volume_ratio(3.0) == 1.001);
    ppe::det_f_params bad;
    bad.c_max = 0.9;
    CHECK_THROWS_WITH_AS(ppe::det_f{bad}, doctest::Contains("c_max"), mpskit::error);
  }

  TEST_CASE("cofactor: cof(A)^T A = det(A) I, and Jacobi's formula d det = cof : dA (2D and 3D)") {
    // Seeded pseudo-random matrices near I (the regime of A = I + Δt ∇u′).
    std::uint64_t seed = 12345;
    const auto rnd = [&]() {
      seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
      return double(seed >> 11) / double(1ULL << 53) - 0.5;
    };
    const auto check = [&](auto dim) {
      constexpr int D = decltype(dim)::value;
      for (int trial = 0; trial < 20; ++trial) {
        mat<D> A = mat<D>::Identity(), dA;
        for (int a = 0; a < D; ++a)
          for (int b = 0; b < D; ++b) {
            A(a, b) += 0.3 * rnd();
            dA(a, b) = rnd();
          }
        const mat<D> C = ppe::det_f::cofactor<D>(A);
        const double det = ppe::det_f::determinant<D>(A);
        // Exact identity; rounding only (entries O(1)).
        CHECK(((C.transpose() * A - det * mat<D>::Identity()).cwiseAbs().maxCoeff()) <= 1e-14);
        // Jacobi's formula: (det(A + ε dA) − det(A − ε dA)) / 2ε = cof(A):dA + O(ε²); ε = 1e-4 → error ~1e-8.
        const double eps = 1e-4;
        const double fd =
            (ppe::det_f::determinant<D>(A + eps * dA) - ppe::det_f::determinant<D>(A - eps * dA)) / (2 * eps);
        CHECK(std::abs(fd - (C.array() * dA.array()).sum()) <= 1e-7);
      }
    };
    check(std::integral_constant<int, 2>{});
    check(std::integral_constant<int, 3>{});
  }

  TEST_CASE("selector: the 2D combination is eq. 63 term by term; 3D uses the symmetric part of cof(A)") {
    using op2 = op::lsmps_a<2, 2>;
    mat<2> A;
    A << 1.1, 0.2, -0.3, 0.9;
    const double rho = 1000.0;
    const op2::vector s = ppe::det_f::selector<op2, 2>(A, rho);
    // Eq. 63: (1/ρ)(a22 ∂xx − (a12 + a21) ∂xy + a11 ∂yy).
    CHECK(s[op2::derivative_index(2, 0)] == doctest::Approx(0.9 / rho));
    CHECK(s[op2::derivative_index(1, 1)] == doctest::Approx(-(0.2 - 0.3) / rho));
    CHECK(s[op2::derivative_index(0, 2)] == doctest::Approx(1.1 / rho));
    CHECK(s[op2::derivative_index(1, 0)] == 0.0);
    CHECK(s[op2::derivative_index(0, 1)] == 0.0);
    using op3 = op::lsmps_a<3, 2>;
    mat<3> B;
    B << 1.0, 0.1, 0.2, -0.1, 1.2, 0.05, 0.3, -0.2, 0.8;
    const op3::vector t = ppe::det_f::selector<op3, 3>(B, 1.0);
    const mat<3> C = ppe::det_f::cofactor<3>(B);
    CHECK(t[op3::derivative_index(2, 0, 0)] == doctest::Approx(C(0, 0)));
    CHECK(t[op3::derivative_index(0, 0, 2)] == doctest::Approx(C(2, 2)));
    CHECK(t[op3::derivative_index(1, 1, 0)] == doctest::Approx(C(0, 1) + C(1, 0)));
    CHECK(t[op3::derivative_index(0, 1, 1)] == doctest::Approx(C(1, 2) + C(2, 1)));
    // With A = I the operator is the Laplacian / ρ.
    const op3::vector l = ppe::det_f::selector<op3, 3>(mat<3>::Identity(), 2.0);
    CHECK((l - op3::laplacian_selector() / 2.0).cwiseAbs().maxCoeff() <= 1e-15);
  }
}

namespace {

/// Tanaka's dam break (§5.6.1) at L = 4 mm to T = T_end (cases/tanaka_dam_break_run.hpp): front samples every
/// 0.05 T against the band of issue #4 (Martin & Moyce and Koshizuka & Oka ± 10 %), lowest fluid pressure,
/// guard activations.
struct tanaka_run {
  int samples = 0, inside = 0;
  int inside_widened = 0;  // inside the band widened by `widen` in Z on both sides
  double pmin = 0.0;     // fluid particles, all steps
  double rho_g_h = 0.0;  // ρ g H of the column
  long guarded = 0;
  double min_pair = 0.0;  // smallest fluid r_ij/L_ij after any step (cases::min_pair_ratio)
  cases::impact_measures impact;  // the probe at (195, 5) mm: 10 ms window, 2 ms filter, every 100 steps
  double T_front_at_probe = std::nan("");  // first front sample with the front past x = 191 mm (Z ≥ 3.91)
  double T_of_t = 0.0;                     // T = t √(2g/h0) per second
  long active_set_rows = 0, active_set_unfinished = 0;
  double max_u = 0.0;  // largest fluid |u| over all steps, in √(gH)
};
/// Runs c with p to T_end and measures (`what` names the configuration in the printed line).
tanaka_run measure_tanaka_dam_break(const cases::tanaka_dam_break_config& c, double T_end,
                                    const scheme::lsmps_params<2>& p, double widen, const std::string& what) {
  const double L = c.L, sqrt_gH = std::sqrt(c.g * c.column_height);
  const auto r = cases::run_tanaka_dam_break(c, T_end, p, false);
  // The fastest fluid particle after any step (issue #9's hard-case bound: 5 √(gH)), recorded by the runner.
  const double u_max = r.u_max, T_u = r.T_u_max;
  const std::vector<cases::front_series> data =
      cases::read_front_data(std::string(MPSKIT_TEST_DATA_DIR) + "/dam_break_front");
  int samples = 0, inside = 0, inside_widened = 0;
  for (std::size_t k = 0; k < r.T.size(); ++k) {
    const auto band = cases::front_band(data, r.T[k]);
    if (std::isnan(band.first)) continue;
    ++samples;
    const bool ok = r.Z[k] >= band.first && r.Z[k] <= band.second;
    inside += ok;
    inside_widened += r.Z[k] >= band.first - widen && r.Z[k] <= band.second + widen;
    if (!ok)
      std::printf("dam_break_lsmps: T = %.2f Z = %.3f outside [%.3f, %.3f]\n", r.T[k], r.Z[k], band.first,
                  band.second);
  }
  std::printf(
      "dam_break_lsmps L = %g mm to T = %.2f (%s): front in band %d/%d, min fluid p = %.0f Pa (-rho g H = "
      "%.0f; copies %.0f), "
      "%ld steps, filtered %ld particle-steps, guarded %ld, min r_ij/L_ij %.3f (T = %.2f), max |u| %.2f "
      "sqrt(gH) (T = %.2f), active-set rows %ld (unfinished steps %ld)\n",
      1e3 * L, T_end, what.c_str(), inside, samples, r.p_min, -r.rho_g_h, r.p_min_copies, r.steps, r.filtered,
      r.guarded, r.min_pair_ratio, r.T_min_pair, u_max / sqrt_gH, T_u, r.active_set_rows,
      r.active_set_unfinished);
  tanaka_run out;
  out.samples = samples;
  out.inside = inside;
  out.inside_widened = inside_widened;
  out.pmin = r.p_min;
  out.rho_g_h = r.rho_g_h;
  out.guarded = r.guarded;
  out.min_pair = r.min_pair_ratio;
  out.impact = cases::far_wall_impact(r);
  out.T_of_t = std::sqrt(2.0 * c.g / c.column_width);
  out.active_set_rows = r.active_set_rows;
  out.active_set_unfinished = r.active_set_unfinished;
  out.max_u = u_max / sqrt_gH;
  // The probe is wet once a particle centre lies within 1.5 L of it: x ≥ 195 − 6 mm, front x + L/2 ≥ 191 mm.
  for (std::size_t k = 0; k < r.T.size() && std::isnan(out.T_front_at_probe); ++k)
    if (r.Z[k] >= (0.191 - c.vessel_left) / c.column_width) out.T_front_at_probe = r.T[k];
  if (std::isfinite(out.impact.t_arrival))
    std::printf(
        "dam_break_lsmps probe (195, 5) mm: wet at T = %.3f (front past 191 mm at T = %.2f); over 10 ms: "
        "impulse %.2f Pa s, peak %.0f Pa, 2 ms-filtered peak %.0f Pa, every-100-steps peak %.0f Pa "
        "(paper 4433 Pa at 1 mm, every 100 steps)%s\n",
        out.impact.t_arrival * out.T_of_t, out.T_front_at_probe, out.impact.impulse, out.impact.peak,
        out.impact.peak_filtered, out.impact.peak_sparse, out.impact.complete ? "" : " [window incomplete]");
  return out;
}
tanaka_run run_tanaka_dam_break(double T_end, double copy_two_point,
                                regularize::penalty_projection projection,
                                scheme::copy_row_kind copy_row = scheme::copy_row_kind::parent_gradient,
                                int active_set_solves = 0, double widen = 0.0, double L = 0.004,
                                double max_amplification = std::numeric_limits<double>::infinity()) {
  cases::tanaka_dam_break_config c;
  c.L = L;
  scheme::lsmps_params<2> p;
  p.copy_row = copy_row;
  p.active_set_solves = active_set_solves;
  p.copy_two_point = copy_two_point;
  p.shift.projection = projection;
  p.boundary_filter.max_amplification = max_amplification;
  return measure_tanaka_dam_break(
      c, T_end, p, widen,
      mpskit::detail::concat("neumann_points ", int(copy_row == scheme::copy_row_kind::neumann_points),
                             ", copy_two_point ", copy_two_point, ", wall_only ",
                             int(projection == regularize::penalty_projection::wall_only), ", active set ",
                             active_set_solves));
}
/// The same with a wall variant of cases::tanaka_wall_variants.
tanaka_run run_tanaka_dam_break(double T_end, const std::string& walls, double L, double widen = 0.0) {
  cases::tanaka_dam_break_config c;
  c.L = L;
  scheme::lsmps_params<2> p;
  cases::tanaka_wall_variant_named(walls, "run_tanaka_dam_break").apply(p);
  return measure_tanaka_dam_break(c, T_end, p, widen, walls);
}

}  // namespace

TEST_SUITE("dam_break_lsmps") {
  TEST_CASE("lsmps_params::surface_copies_zero(_below): the copies of surface particles are p = 0 rows") {
    // Tanaka's dam break at 10 mm to T = 0.3 (the column's first collapse): the column's free surface meets
    // the left wall and the floor, so surface particles have copies from the first step. With
    // surface_copies_zero (the paper's reading, Tanaka 2018 §4.6) every such copy is exactly 0 after each
    // step; by default (deviation 3) they are unknowns of the parent-gradient row, and some are solved away
    // from 0 — so the test tells the two apart. With surface_copies_zero_below = c_s only the copies of
    // parents with packing ratio c < c_s are 0 rows: all of those are exactly 0, and some of the others not.
    // c_s is the median of the parents' c over the default run, so that both sides have copies.
    cases::tanaka_dam_break_config c;
    c.L = 0.01;
    struct count {
      long copies = 0, nonzero = 0;                   // copies of surface parents, and of those p != 0
      long sparse = 0, sparse_nonzero = 0;            // the same for parents with c < c_s
      std::vector<std::pair<double, bool>> parent_c;  // the parents' c and p != 0, copy by copy
    };
    const auto surface_copies = [&](bool zero, double below, double c_s) {
      scheme::lsmps_params<2> p;
      p.surface_copies_zero = zero;
      p.surface_copies_zero_below = below;
      count n;
      long inner_nonzero = 0;
      const auto observe = [&](const auto& sim) {
        const auto& st = sim.state();
        const auto& P = st.template get<field::pressure>();
        const auto& parent = st.template get<field::parent>();
        for (index_t k = st.n_real(); k < st.size(); ++k)
          if ((st.flags()[static_cast<std::size_t>(k)] & flag::surface) != 0) {
            ++n.copies;
            n.nonzero += P[k] != 0.0;
            // c of this step, in its order (no resize in this case)
            const double cp = sim.packing_ratio()[parent[static_cast<std::size_t>(k)]];
            n.parent_c.emplace_back(cp, P[k] != 0.0);
            if (cp < c_s) {
              ++n.sparse;
              n.sparse_nonzero += P[k] != 0.0;
            }
          } else {
            inner_nonzero += P[k] != 0.0;  // copies of inner parents: unknowns either way
          }
      };
      const cases::tanaka_dam_break_result r = cases::run_tanaka_dam_break(c, 0.3, p, true, observe);
      CHECK_FALSE(r.failed);
      CHECK(r.steps > 0);
      CHECK(inner_nonzero > 0);
      return n;
    };
    const count all_zero = surface_copies(true, 0.0, 0.0);
    CHECK(all_zero.copies > 0);
    CHECK(all_zero.nonzero == 0);
    const count by_default = surface_copies(false, 0.0, 0.0);
    CHECK(by_default.copies > 0);
    CHECK(by_default.nonzero > 0);
    REQUIRE(by_default.parent_c.size() >= 2);
    std::vector<double> sorted;
    for (const auto& [cp, nz] : by_default.parent_c) sorted.push_back(cp);
    std::sort(sorted.begin(), sorted.end());
    const std::size_t mid = sorted.size() / 2;
    const double c_s = 0.5 * (sorted[mid - 1] + sorted[mid]);
    REQUIRE(sorted.front() < c_s);  // the parents' c are not all equal
    const count sparse_zero = surface_copies(false, c_s, c_s);
    CHECK(sparse_zero.sparse > 0);
    CHECK(sparse_zero.sparse_nonzero == 0);
    CHECK(sparse_zero.nonzero > 0);  // the copies of denser surface parents are still solved
    // By default copies of parents with c < c_s are solved away from 0: the zeros above are the option's.
    CHECK(std::count_if(by_default.parent_c.begin(), by_default.parent_c.end(),
                        [&](const auto& e) { return e.first < c_s && e.second; }) > 0);
    MESSAGE("surface copies over the run: ", all_zero.copies, " (surface_copies_zero), ", by_default.copies,
            " (default, ", by_default.nonzero, " of them p != 0; parents' c from ", sorted.front(), " to ",
            sorted.back(), ", median ", c_s, "), ", sparse_zero.copies, " (below ", c_s, ": ",
            sparse_zero.sparse, " with c below it, all 0; ", sparse_zero.nonzero, " p != 0)");
    // Only with the parent-gradient rows: with the others the copies of surface particles are not unknowns.
    scheme::lsmps_params<2> p;
    p.surface_copies_zero = true;
    p.copy_row = scheme::copy_row_kind::neumann_points;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("surface_copies_zero"), mpskit::error);
    p.surface_copies_zero = false;
    p.surface_copies_zero_below = 0.5;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("surface_copies_zero_below"), mpskit::error);
    p.copy_row = scheme::copy_row_kind::parent_gradient;
    p.surface_copies_zero_below = -0.1;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("surface_copies_zero_below"), mpskit::error);
  }
  TEST_CASE("Tanaka's vessel with closed_top: the lid closes the chain, its normal into the vessel") {
    // Open by default: three elements, and a point above the vessel is not behind any wall. closed_top adds
    // the fourth element (right, top) -> (left, top); its left normal is -y (into the vessel), so the
    // vessel's inside has signed distance > 0 and a point above the lid < 0, and a move across the lid is a
    // crossing.
    cases::tanaka_dam_break_config c;
    c.L = 0.01;
    const double H = c.vessel_height;
    const vec<2> below(0.05, H - 0.02), above(0.05, H + 0.02);
    const auto open = cases::make_tanaka_dam_break(c);
    CHECK(open.walls.size() == 3);
    CHECK(!open.walls.crosses(below, above));
    c.closed_top = true;
    const auto closed = cases::make_tanaka_dam_break(c);
    REQUIRE(closed.walls.size() == 4);
    CHECK(closed.walls.element_normal(3)[0] == doctest::Approx(0.0));
    CHECK(closed.walls.element_normal(3)[1] == doctest::Approx(-1.0));
    CHECK(closed.walls.signed_distance(below) == doctest::Approx(0.02));
    CHECK(closed.walls.signed_distance(above) == doctest::Approx(-0.02));
    CHECK(closed.walls.crosses(below, above));
    CHECK(closed.size() == open.size());  // the same column
  }
  TEST_CASE("measure_impact: a triangular pulse's arrival, impulse, peak, filtered peak and sparse peak") {
    // p = H (1 − |t − t0|/b) on |t − t0| < b, 0 elsewhere, dry (NaN) before t = 0.1 s, every 1e-5 s. The
    // kinks sit on samples, so the trapezoids integrate exactly: impulse H b; the 2 ms centred average at the
    // apex is H (1 − f/(4b)); every 100th step (step k + 1 of the run) the largest sample is at
    // t = 0.10499 s.
    const double H = 4000.0, t0 = 0.105, b = 0.003, dt = 1e-5;
    std::vector<double> t, p;
    for (int k = 0; k <= 20000; ++k) {
      t.push_back(k * dt);
      p.push_back(k < 10000 ? std::nan("") : H * std::max(0.0, 1.0 - std::abs(k * dt - t0) / b));
    }
    const auto m = cases::measure_impact(t, p, 0.02, 0.002);
    CHECK(m.t_arrival == doctest::Approx(0.1).epsilon(1e-12));
    CHECK(m.complete);
    CHECK(m.impulse == doctest::Approx(H * b).epsilon(1e-9));
    CHECK(m.peak == doctest::Approx(H).epsilon(1e-9));
    CHECK(m.t_peak == doctest::Approx(t0).epsilon(1e-9));
    CHECK(m.peak_filtered == doctest::Approx(H * (1.0 - 0.002 / (4.0 * b))).epsilon(1e-9));
    CHECK(m.t_peak_filtered == doctest::Approx(t0).epsilon(1e-9));
    CHECK(m.peak_sparse == doctest::Approx(H * (1.0 - dt / b)).epsilon(1e-9));
    // A window past the series' end: partial numbers, flagged; a series never wet: NaN.
    const auto cut = cases::measure_impact(std::vector<double>(t.begin(), t.begin() + 10401),
                                           std::vector<double>(p.begin(), p.begin() + 10401), 0.02, 0.002);
    CHECK_FALSE(cut.complete);
    // the ramp to 0.104 s
    CHECK(cut.impulse == doctest::Approx(0.5 * H * (0.002 / b) * 0.002).epsilon(1e-9));
    CHECK(std::isnan(cases::measure_impact({0.0, 1.0}, {std::nan(""), std::nan("")}, 0.02, 0.002).t_arrival));
    CHECK_THROWS_WITH_AS(cases::measure_impact({0.0, 1.0}, {0.0}, 0.02, 0.002),
                         doctest::Contains("2 times but 1"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::measure_impact({0.0, 0.0}, {0.0, 0.0}, 0.02, 0.002),
                         doctest::Contains("not increasing"), mpskit::error);
    CHECK_THROWS_AS(cases::measure_impact({0.0, 1.0}, {0.0, 0.0}, 0.0, 0.002), mpskit::error);
  }
  TEST_CASE(
      "Tanaka's dam break (§5.6.1), L = 4 mm, defaults: surge front inside the data band for T <= 1.25") {
    // Issue #7 asks T ≤ 3 (the band of issue #4). With the defaults the floor copies' pressures run away from
    // T ≈ 1.35 and the run fails at T ≈ 1.6 (docs/lsmps_scheme.md): asserted up to T = 1.25.
    const auto r = run_tanaka_dam_break(1.25, 0.0, regularize::penalty_projection::with_displacement);
    CHECK(r.samples >= 20);
    CHECK(r.inside == r.samples);  // the issue's band (± 10 % around the data)
    CHECK(r.pmin >= -r.rho_g_h);  // issue #7: p ≥ −ρ g H (fluid; measured −1519 Pa to T = 1.25)
    CHECK(r.guarded == 0);
  }
  TEST_CASE(
      "Tanaka's dam break, L = 4 mm, two-point copy rows + contact-line shifting: front in the band for T <= "
      "3, probe") {
    // copy_two_point = 1 and shift.projection = wall_only (opt-in, docs/lsmps_scheme.md): the front stays in
    // the band at all 61 samples to T = 3 and the run reaches the far wall. Unmet, hence not the defaults:
    // the fluid pressure dips far below −ρgH (measured −4.1e4 Pa at the far-wall impact, −1.0e5 Pa before
    // wrong-sign rows became p = 0 rows (docs/lsmps_scheme.md, deviation 10), −1 to −6 kPa before
    // it; −4.8e5 Pa before c′ = 1 beside walls); before that change, at L = 5 mm the run failed at T ≈ 2.6,
    // at L = 3 mm at T ≈ 1.75; as defaults they cost elsewhere (Poiseuille 3.0 → 3.6 %, tanks at rest spread
    // with wall_only: docs/lsmps_scheme.md). Run to T = 3.1 for the first impact at the probe (195, 5) mm
    // (issue #7): wet at T ≈ 2.91, the 10 ms window ends at T ≈ 3.05. Its numbers are reported
    // (docs/validation.md); asserted: the probe gets wet when the front reaches it (the front is sampled
    // every 0.05 in T; the two agree within two samples) and the window completes.
    const auto r = run_tanaka_dam_break(3.1, 1.0, regularize::penalty_projection::wall_only);
    CHECK(r.samples >= 55);  // the band's data end at T = 3
    CHECK(r.inside == r.samples);
    CHECK(r.guarded == 0);
    REQUIRE(std::isfinite(r.impact.t_arrival));
    CHECK(r.impact.complete);
    CHECK(std::abs(r.impact.t_arrival * r.T_of_t - r.T_front_at_probe) <= 0.1);
    CHECK(r.impact.peak_filtered > 0.0);  // the water pushes on the wall
    // Clustering (cases::min_pair_ratio after every step): issue #9's bound for its hard cases,
    // r_ij/L_ij ≥ 0.3. Measured 0.454 (at T = 2.50); the Neumann-point run below falls to 0.104 by T = 1.9
    // (printed).
    CHECK(r.min_pair >= 0.3);
  }
  TEST_CASE(
      "Tanaka's dam break, L = 4 mm, two-point copy rows + contact-line shifting + active set + bounded "
      "filter: through the impact") {
    // active_set_solves = 10 (opt-in, docs/lsmps_scheme.md deviation 13): fluid pressures solved below 0 are
    // held at 0 and the PPE solved again: p ≥ 0 by construction (no step left unfinished), so issue #7's
    // p ≥ −ρgH holds (the copies, auxiliary unknowns, go below). Until 2026-12-01 this run failed in the
    // far-wall impact at T ≈ 2.95: the one-sided-band filter's fit at a splash particle beside the wall (six
    // neighbours, all on one side) extrapolated to 13, then 1177 m/s and shot it out at 75 m/s. With the
    // filter bounded (opt-in boundary_filter_params::max_amplification = 20, docs/lsmps_scheme.md) it runs
    // through the impact and the probe's 10 ms window. The front is ahead of the band at T = 1.75–1.85
    // by ≤ 0.015 in Z (1.5 mm, < L/2), as before the bound; asserted: at most 4 misses, each within
    // L/2 = 0.02 in Z.
    const auto r =
        run_tanaka_dam_break(3.2, 1.0, regularize::penalty_projection::wall_only,
                             scheme::copy_row_kind::parent_gradient, 10, 0.5 * 0.004 / 0.1, 0.004, 20.0);
    CHECK(r.samples >= 55);  // the band's data end at T = 3
    CHECK(r.inside_widened == r.samples);
    CHECK(r.samples - r.inside <= 4);
    CHECK(r.active_set_unfinished == 0);
    CHECK(r.pmin >= 0.0);  // by the set (a kept negative would be counted above); issue #7 asks ≥ −ρgH
    CHECK(r.active_set_rows > 0);
    // measured 2 (in the impact); issue #9's hard cases report leakage rather than forbid it
    CHECK(r.guarded <= 4);
    REQUIRE(std::isfinite(r.impact.t_arrival));
    CHECK(r.impact.complete);  // the run got through the probe's 10 ms window
    CHECK(std::abs(r.impact.t_arrival * r.T_of_t - r.T_front_at_probe) <= 0.1);
    CHECK(r.min_pair >= 0.5);  // issue #9's hard-case bound is 0.3; measured 0.689
  }
  TEST_CASE(
      "Tanaka's dam break, L = 5 mm, two-point copy rows + contact-line shifting + active set: through the "
      "impact") {
    // The configuration above at L = 5 mm, run to T = 3.2 through the far-wall impact: the one spacing at
    // which every dam-break criterion of issue #7 holds through the probe's 10 ms window (measured
    // 2026-11-27: band 65/65, p >= 0, no guard activation, closest pair 0.579 L, probe wet at T = 2.975,
    // impulse 27.85 Pa s, 2 ms-filtered peak 11.7 kPa against the paper's 4433 Pa at 1 mm; raw peak
    // 99.8 kPa). Not at 4 mm (fails in the impact at T ≈ 2.96; with the opt-in bounded filter it passes, case
    // above), 3 mm (T ≈ 2.78) or 5.5 mm (T ≈ 2.6, a splash on the far wall); 4.5 mm passes the impact but
    // with 7 guard activations (docs/lsmps_scheme.md, deviation 13). The outcome in the impact is still a
    // matter of the spacing, so this is a reproducible data point for the probe with p >= -rho g H, not a
    // claim that the option makes the impact robust.
    const auto r = run_tanaka_dam_break(3.2, 1.0, regularize::penalty_projection::wall_only,
                                        scheme::copy_row_kind::parent_gradient, 10, 0.0, 0.005);
    CHECK(r.samples >= 60);
    CHECK(r.inside == r.samples);  // the issue's band, strictly
    CHECK(r.active_set_unfinished == 0);
    // by the set; issue #7 asks >= -rho g H (the copies, auxiliary unknowns: -11 rho g H)
    CHECK(r.pmin >= 0.0);
    CHECK(r.guarded == 0);
    CHECK(r.min_pair >= 0.5);  // issue #9's hard-case bound is 0.3
    REQUIRE(std::isfinite(r.impact.t_arrival));
    CHECK(r.impact.complete);  // the 10 ms window after the probe gets wet lies inside the run
    CHECK(std::abs(r.impact.t_arrival * r.T_of_t - r.T_front_at_probe) <= 0.1);  // wet when the front arrives
    CHECK(r.impact.peak_filtered > 0.0);  // the water pushes on the wall
  }
  TEST_CASE(
      "Tanaka's dam break, L = 3.5 mm, active set with copies + own-loop guard + cond1(M) <= 1e4: through "
      "the impact, quietly") {
    // Variant two_point_wall_only_active_set_own_loop_copies_conditioned (docs/lsmps_scheme.md
    // "Ill-conditioned fits"): the own-loop variant with the wall copies in the active set fails here
    // (T = 3.07): two surface particles 0.04 L apart on the right wall, their two copies at one point with
    // p = 0 and 1.26e4 Pa, and a fit whose points are collinear to within ~1e-3 L (order 1 accepted up to
    // cond1 = 1e8) reads a vertical gradient 1197 times the largest difference quotient: 10.6 -> 154 m/s in
    // one step. With op.max_condition = 1e4 such fits fall back (a lower order, else regularised; whether
    // this one arises then is not known, the runs part long before: the largest such ratio over the run is
    // 3.4), and the run gets through the impact with issue #9's hard-case bounds. Measured 2026-12-02: max
    // |u| 2.97 sqrt(gH), no guard activation, closest pair 0.516 L, p >= 0; over the 31 spacings 3.0-6.0 mm
    // 31 reach T = 3.2 (row tpoc_mc1e4), one spacing is one sample, not the claim. The front: within the
    // issue's band widened by one diameter (L / h0 = 0.035 in Z). Measured: 49 of 65 samples inside the band
    // itself, the 16 others ahead of it by at most 0.023 in Z (0.66 L, at T = 2.10): the LSMPS front's lead
    // over the data, which grows with refinement (docs/validation.md, "Dam break").
    const auto r = run_tanaka_dam_break(3.2, "two_point_wall_only_active_set_own_loop_copies_conditioned",
                                        0.0035, 0.035);
    CHECK(r.samples >= 60);
    CHECK(r.inside_widened == r.samples);
    CHECK(r.active_set_unfinished == 0);
    CHECK(r.pmin >= 0.0);  // by the set; issue #7 asks >= -rho g H
    CHECK(r.guarded == 0);
    CHECK(r.max_u <= 5.0);      // issue #9's hard-case bound, 5 sqrt(gH)
    CHECK(r.min_pair >= 0.3);   // issue #9's hard-case bound
    REQUIRE(std::isfinite(r.impact.t_arrival));
    CHECK(r.impact.complete);  // through the probe's 10 ms window
    CHECK(std::abs(r.impact.t_arrival * r.T_of_t - r.T_front_at_probe) <= 0.1);
  }
  TEST_CASE(
      "scheme::lsmps_impact_params: the reporter's wall variant tanaka_impact_walls plus the collision "
      "stage") {
    // The reporter's variant (benchmarks/report_dam_break.cpp: row tpocml with --lsmps-collision 0.5
    // --lsmps-collide-isolated --lsmps-shift-isolated), with which the runs of docs/validation.md were made,
    // is the library's preset without its collision settings (since 2026-12-04; until then written out, field
    // by field, as the other variants are). Every setting either touches must agree, and the rest must stay
    // Tanaka's (the 2D and 3D presets alike).
    scheme::lsmps_params<2> v;
    cases::tanaka_wall_variant_named(cases::tanaka_impact_walls, "test").apply(v);
    CHECK(v.collision.alpha1 == 0.0);  // a wall variant leaves the collision settings to its caller
    CHECK_FALSE(v.collision.isolated);
    CHECK_FALSE(v.shift_isolated_penalty);
    CHECK(v.active_set_solves == 10);  // and sets the walls' part of the preset
    CHECK(v.copy_two_point == 1.0);
    v.collision.alpha1 = 0.5;
    v.collision.isolated = true;
    v.shift_isolated_penalty = true;
    const auto check = [&](const auto& q, const auto& paper) {
      check_impact_settings(q, v);
      // untouched: Tanaka's Table 2 and the library's other defaults
      CHECK(q.copy_row == paper.copy_row);
      CHECK(q.shift_second_wall == paper.shift_second_wall);
      CHECK(q.boundary_filter.strength == paper.boundary_filter.strength);
      CHECK(q.boundary_filter.max_amplification == paper.boundary_filter.max_amplification);
      CHECK(q.own_loop.wall_candidate_packing == paper.own_loop.wall_candidate_packing);
      CHECK(q.time.courant == paper.time.courant);
      CHECK_NOTHROW(q.validate());
    };
    check(scheme::lsmps_impact_params<2>(), scheme::lsmps_params<2>{});
    check(scheme::lsmps_impact_params<3>(), scheme::lsmps_params<3>{});
    // On top of a caller's params: the caller's other numbers are kept.
    scheme::lsmps_params<2> mine;
    mine.nu = 0.0;
    mine.time.courant = 0.05;
    const auto q = scheme::lsmps_impact_params<2>(mine);
    CHECK(q.nu == 0.0);
    CHECK(q.time.courant == 0.05);
    CHECK(q.active_set_solves == 10);
  }
  TEST_CASE(
      "Tanaka's dam break, L = 3 mm, the main example's options: through the impact with no guard "
      "activation") {
    // scheme::lsmps_impact_params<2>(): the conditioned, limited wall variant with the collision stage
    // (alpha1 0.5, isolated particles too) and isolated particles in the shifting penalty
    // (docs/lsmps_scheme.md deviations 13, 15-18; all opt-in). With them every spacing from 6 to 1.5 mm
    // measured gets through the far-wall impact to T = 3.2 with no guard activation, p >= 0 and no pair
    // closer than 0.469 L (docs/validation.md, "With the collision stage and the isolated-particle options as
    // well"); 3 mm is the spacing with the fastest particle of the 6-2 mm runs but 2 mm's splash. Measured
    // 2026-12-03 (-O3 harness, the same code): guard 0, p >= 0, closest pair 0.477 L, max |u| 5.47 sqrt(gH)
    // (issue #9's 5 is not asserted here: this is issue #7's case), the probe wet at T = 2.839, 45 of 65
    // front samples in the band, the others ahead of it by at most 0.079 in Z (2.6 L, T = 2.75): the LSMPS
    // front's lead over the data, which grows with refinement; asserted within the band widened by 3 L (0.09
    // in Z). Run to T = 3.05 since 2026-12-04 (T = 3.2 before; cut for issue #7's CI budget on a slower
    // machine, 87 -> 71 s): the probe's 10 ms window ends at T = 2.98, and the extremes fall before it (max
    // |u| at T = 2.87, the closest pair at T = 2.89; 42 of 62 samples in the band, measured).
    cases::tanaka_dam_break_config c;
    c.L = 0.003;
    const auto r =
        measure_tanaka_dam_break(c, 3.05, scheme::lsmps_impact_params<2>(), 0.09, "lsmps_impact_params");
    // (A failed run throws: catch_failure is off in measure_tanaka_dam_break.)
    CHECK(r.inside_widened == r.samples);
    CHECK(r.active_set_unfinished == 0);
    CHECK(r.pmin >= 0.0);        // by the active set; issue #7 asks >= -rho g H
    CHECK(r.guarded == 0);       // no particle crossed a wall, the impact included
    CHECK(r.min_pair >= 0.45);   // the collision stage: 0.06 L at 3 mm without it (docs/validation.md)
    REQUIRE(std::isfinite(r.impact.t_arrival));
    CHECK(r.impact.complete);    // through the probe's 10 ms window
    // wet by the surge, not a film
    CHECK(std::abs(r.impact.t_arrival * r.T_of_t - r.T_front_at_probe) <= 0.1);
  }
  TEST_CASE("Tanaka's dam break, L = 4 mm, copies as Neumann points: band and p >= -rho g H for T <= 1.9") {
    // copy_row = neumann_points (opt-in, docs/lsmps_scheme.md deviation 11): no copy unknowns, so the floor
    // copies' runaway of the defaults (their near-null space) cannot happen. Measured: the front in the band
    // at 39/39 samples, no guard activation, the lowest fluid pressure −1945 Pa = −0.99 ρgH (a thin margin:
    // a bottom-row particle 0.38 L above the floor at T = 0.87; elsewhere ≥ −0.92 ρgH). The defaults meet
    // p ≥ −ρgH only to T = 1.25 and fail at T = 1.62. This run fails at T ≈ 2.0 (a particle at the top of a
    // film on the left wall, 0.13 L from it, not flagged surface), so T = 1.9 is as far as it is asserted.
    // That film clusters first: the closest fluid pair is 0.10 L apart at T = 1.9 (printed;
    // docs/lsmps_scheme.md).
    const auto r = run_tanaka_dam_break(1.9, 0.0, regularize::penalty_projection::with_displacement,
                                        scheme::copy_row_kind::neumann_points);
    CHECK(r.samples >= 37);
    CHECK(r.inside == r.samples);
    CHECK(r.pmin >= -r.rho_g_h);  // issue #7's criterion, met to T = 1.9 with this option
    CHECK(r.guarded == 0);
  }

  TEST_CASE(
      "dam break with BiCGSTAB-ILU(0) (ppe::bicgstab_ilu0): the Jacobi run's flow, in fewer iterations") {
    // The scene's solver is a policy: ppe::bicgstab_ilu0 in place of the default BiCGSTAB-Jacobi, the same
    // tolerance (1e-8), the lagged factors of the stepper's same-unknowns signal. Tanaka's dam break at
    // L = 8 mm with lsmps_impact_params to T = 1 (before the surge reaches the far wall; the flow does not
    // yet amplify the solvers' different last digits): the same steps, the front samples to 1e-6 (measured:
    // 1.1e-11) and max |u| to 1e-5 relative; ILU(0) at most half the PPE iterations (3198 against 14 650,
    // measured; 5.2× fewer at 4 mm, 6.4× at 2 mm: docs/performance.md "ILU(0) for the LSMPS PPE").
    cases::tanaka_dam_break_config c;
    c.L = 0.008;
    const scheme::lsmps_params<2> p = scheme::lsmps_impact_params<2>();
    const auto jacobi = cases::run_tanaka_dam_break(c, 1.0, p);
    const auto ilu0 = cases::run_tanaka_dam_break<cases::tanaka_ilu0_scene>(c, 1.0, p);
    CHECK(ilu0.steps == jacobi.steps);
    REQUIRE(ilu0.Z.size() == jacobi.Z.size());
    REQUIRE(jacobi.Z.size() >= 20);  // every 0.05 T
    double dz = 0.0;
    for (std::size_t k = 0; k < jacobi.Z.size(); ++k)
      dz = std::max(dz, std::abs(ilu0.Z[k] - jacobi.Z[k]) / jacobi.Z[k]);
    MESSAGE("ILU(0) " << ilu0.ppe_iterations << " PPE iterations against Jacobi's " << jacobi.ppe_iterations
                      << " over " << ilu0.steps << " steps; max |u| " << ilu0.u_max << " / " << jacobi.u_max
                      << " m/s; largest front difference " << dz);
    CHECK(dz <= 1e-6);
    CHECK(ilu0.u_max == doctest::Approx(jacobi.u_max).epsilon(1e-5));
    CHECK(2 * ilu0.ppe_iterations <= jacobi.ppe_iterations);
    CHECK(ilu0.guarded == 0);
    // The solve ledger (lsmps_counters::ppe_solves, ppe_factorisations): each step solves once, plus the
    // active set's and the own-loop guard's repeats (every system here has unknowns), whatever the solver;
    // Jacobi factorises nothing; ILU(0) with the default lag factorises at least every ilut_reuse-th solve
    // and at most at every solve and lagged retry (measured: 348 factorisations for 351 solves over 177
    // steps); factorised at every solve (ilut_reuse = 1: no lag, no retry), exactly once per solve. The
    // repeated solves (ppe_repeat_solves, ppe_repeat_iterations) are those after each step's first: the
    // repeats made (with the identity above, the first solves are one per step), with part of the
    // iterations.
    scheme::lsmps_params<2> fresh_p = p;
    fresh_p.solver.ilut_reuse = 1;
    const auto fresh = cases::run_tanaka_dam_break<cases::tanaka_ilu0_scene>(c, 1.0, fresh_p);
    MESSAGE("PPE solves " << ilu0.ppe_solves << " (Jacobi " << jacobi.ppe_solves << ", fresh factors "
                          << fresh.ppe_solves << ") over " << ilu0.steps << " steps, ILU(0) factorisations "
                          << ilu0.ppe_factorisations << " (fresh factors " << fresh.ppe_factorisations
                          << ")");
    for (const auto* r : {&jacobi, &ilu0, &fresh}) {
      CHECK(r->ppe_solves == r->steps + r->active_set_solves + r->own_loop_solves);
      CHECK(r->active_set_solves + r->own_loop_solves > 0);  // the repeats are exercised
      CHECK(r->ppe_repeat_solves == r->active_set_solves + r->own_loop_solves);
      CHECK(r->ppe_repeat_iterations > 0);
      CHECK(r->ppe_repeat_iterations < r->ppe_iterations);
    }
    CHECK(jacobi.ppe_factorisations == 0);
    CHECK(p.solver.ilut_reuse * ilu0.ppe_factorisations >= ilu0.ppe_solves);
    CHECK(ilu0.ppe_factorisations <= ilu0.ppe_solves + ilu0.ppe_lagged_retries);
    CHECK(fresh.ppe_lagged_retries == 0);
    CHECK(fresh.ppe_factorisations == fresh.ppe_solves);
  }
}

TEST_SUITE("dam_break_slab") {
  // Tanaka's dam break as a 3D slab (cases/tanaka_dam_break_slab.hpp). Not one of issue #7's cases (its dam
  // break is 2D): its own label since 2026-12-06, so that issue #7's CI budget counts the issue's cases (the
  // slab run is ≈ 77 s of one core; docs/resolution.md "CI sizes").
  TEST_CASE(
      "Tanaka's dam break in 3D (a slab periodic in y), L = 12.5 mm, scheme::lsmps_impact_params<3>: to the "
      "far wall") {
    // cases/tanaka_dam_break_slab.hpp: the 2D vessel extruded along y over 8 L, periodic (the period must
    // exceed twice the search radius, 7.44 L), so the flow is plane and its front should be the 2D run's up
    // to the discretisation. Measured 2026-12-04 at 10 mm (the example, -O3, the same code): 651 steps to
    // T = 3.4, front in the band at 69 of 69 samples, guard 0, p >= 0, max |u| 2.33 sqrt(gH), closest pair
    // 0.495 L; the largest body's front at the far wall (Z >= 3.9) from T = 3.15 on; against the 2D run with
    // lsmps_impact_params<2> at 10 mm the largest relative front difference to T = 2.5 is 2.26 % (3.36 % to
    // T = 3.4). This test runs 12.5 mm (10 mm until 2026-12-04, 124 -> 58 s, cut for issue #7's CI budget on
    // a slower machine; the period is 8 L = 100 mm): 1024 particles, 510 steps to T = 3.3, band 67/67, the
    // body at the far wall at 3 of 3 samples from T = 3.2, guard 0, p >= 0, max |u| 2.06 sqrt(gH), closest
    // pair 0.571 L, against the 2D run at 12.5 mm 1.62 % to T = 2.5 (50 samples). Asserted within 4 %: closed
    // by two end walls 4 L apart the slab's front lagged the 2D run's by 5.7 % (their copies carry the wall
    // velocity and the one-sided-band filter drags the layers beside them: docs/lsmps_scheme.md "The impact
    // configuration"). With Tanaka's Table 2 the slab blows up before T = 1.2 (measured with end walls at 10,
    // 6.67 and 5 mm).
    cases::tanaka_dam_break_config c;
    c.L = 0.0125;  // 8 x 16 x 8 particles in the column
    const auto r = cases::run_tanaka_slab(c, 8, 3.3, scheme::lsmps_impact_params<3>());
    REQUIRE(!r.Z.empty());
    const std::vector<cases::front_series> data =
        cases::read_front_data(std::string(MPSKIT_TEST_DATA_DIR) + "/dam_break_front");
    int samples = 0, inside = 0, at_wall = 0, after = 0;
    for (std::size_t k = 0; k < r.T.size(); ++k) {
      // the body at the far wall (Z = 4) to the end
      if (r.T[k] >= 3.2) ++after, at_wall += r.Z_body[k] >= 3.9;
      const auto band = cases::front_band(data, r.T[k]);
      if (std::isnan(band.first)) continue;
      ++samples;
      inside += r.Z[k] >= band.first && r.Z[k] <= band.second;
    }
    const auto r2 = cases::run_tanaka_dam_break(c, 2.5, scheme::lsmps_impact_params<2>());
    REQUIRE(r2.T.size() >= 2);
    double diff = 0.0;
    int compared = 0;
    for (std::size_t k = 0; k < r.T.size() && r.T[k] <= 2.5; ++k) {
      if (r.T[k] < r2.T.front() || r.T[k] > r2.T.back()) continue;
      // not begin: r.T[k] >= r2.T.front()
      const auto it = std::upper_bound(r2.T.begin(), r2.T.end(), r.T[k]);
      const std::size_t j = it == r2.T.end() ? r2.T.size() - 1 : static_cast<std::size_t>(it - r2.T.begin());
      const double w = (r.T[k] - r2.T[j - 1]) / (r2.T[j] - r2.T[j - 1]);
      const double z2 = (1.0 - w) * r2.Z[j - 1] + w * r2.Z[j];
      diff = std::max(diff, std::abs(r.Z[k] - z2) / z2);
      ++compared;
    }
    const double sqrt_gH = std::sqrt(c.g * c.column_height);
    std::printf(
        "dam_break_slab 3D slab (periodic, 8 layers) L = 12.5 mm to T = 3.3: %ld particles, %ld steps, front "
        "in band %d/%d, body at the far wall at %d of %d samples from T = 3.2, min fluid p %.0f Pa, guarded "
        "%ld, max |u| %.2f sqrt(gH), min r_ij/L_ij %.3f, collisions %ld, against 2D to T = 2.5: %.2f %% "
        "(%d samples)\n",
        static_cast<long>(r.particles), r.steps, inside, samples, at_wall, after, r.p_min, r.guarded,
        r.u_max / sqrt_gH, r.min_pair_ratio, r.collisions, 100.0 * diff, compared);
    CHECK(samples >= 60);
    CHECK(inside == samples);               // issue #4's band (the data ± 10 %), as the 2D runs
    CHECK(after >= 2);
    CHECK(at_wall == after);                // the surge reached the far wall and stays there
    CHECK(r.guarded == 0);                  // no particle crossed a wall
    CHECK(r.p_min >= 0.0);                  // the active set; issue #7 asks >= -rho g H
    CHECK(r.active_set_unfinished == 0);
    CHECK(r.u_max <= 5.0 * sqrt_gH);        // issue #9's explosion bound
    CHECK(r.min_pair_ratio >= 0.3);         // issue #9's clustering bound
    CHECK(compared >= 45);
    CHECK(diff <= 0.04);                    // plane flow: the 2D front
  }
  TEST_CASE("cases::make_tanaka_slab: the column and the walls, periodic or closed, bad input refused") {
    cases::tanaka_dam_break_config c;
    c.L = 0.01;
    for (const auto sides : {cases::slab_sides::periodic, cases::slab_sides::walls}) {
      const auto s = cases::make_tanaka_slab(c, 3, sides);
      CHECK(s.size() == 10 * 3 * 20);  // h0/L x layers x 2 h0/L
      CHECK(s.B == doctest::Approx(0.03));
      // left, floor and right: two triangles each (open top), and two per end wall
      CHECK(s.walls.size() == (sides == cases::slab_sides::periodic ? 6 : 10));
      // Every particle at least L/2 inside every wall; the column's extent exactly h0 x B x 2 h0.
      double closest = 1e300;
      for (index_t i = 0; i < s.size(); ++i)
        closest = std::min(closest, s.walls.signed_distance(vec<3>(s.x.col(i))));
      CHECK(closest == doctest::Approx(0.5 * c.L));
      CHECK(s.x.row(0).minCoeff() == doctest::Approx(0.005));
      CHECK(s.x.row(0).maxCoeff() == doctest::Approx(0.095));
      CHECK(s.x.row(1).minCoeff() == doctest::Approx(0.005));
      CHECK(s.x.row(1).maxCoeff() == doctest::Approx(0.025));
      CHECK(s.x.row(2).maxCoeff() == doctest::Approx(0.195));
      // The far wall at x = 0.4 and the floor: a point 1 cm inside each, mid-slab, is 1 cm from the walls;
      // near an end (y = 2 mm) only the end wall is closer.
      CHECK(s.walls.signed_distance(vec<3>(0.39, 0.015, 0.15)) == doctest::Approx(0.01));
      CHECK(s.walls.signed_distance(vec<3>(0.2, 0.015, 0.01)) == doctest::Approx(0.01));
      CHECK(s.walls.signed_distance(vec<3>(0.2, 0.002, 0.1)) ==
            doctest::Approx(sides == cases::slab_sides::periodic ? 0.1 : 0.002));
    }
    CHECK_THROWS_WITH_AS(cases::make_tanaka_slab(c, 0), doctest::Contains("layers"), mpskit::error);
    auto bad = c;
    bad.L = 0.003;  // 100/3 mm: not a whole number of spacings
    CHECK_THROWS_WITH_AS(cases::make_tanaka_slab(bad, 4), doctest::Contains("whole numbers of L"),
                         mpskit::error);
    bad = c;
    bad.vessel_height = 0.205;  // below the column + L
    CHECK_THROWS_WITH_AS(cases::make_tanaka_slab(bad, 4), doctest::Contains("vessel_height"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::make_tanaka_slab(cases::tanaka_obstacle_config(), 4),
                         doctest::Contains("obstacle"), mpskit::error);
    // A period not above twice the search radius (2 x 1.2 x 3.1 L = 7.44 L) is refused by the search at the
    // start.
    CHECK_THROWS_WITH_AS(cases::run_tanaka_slab(c, 7, 0.1, scheme::lsmps_impact_params<3>()),
                         doctest::Contains("period"), mpskit::error);
  }
}

TEST_SUITE("restart") {
  TEST_CASE("restart: Tanaka's dam break in three pieces gives the uninterrupted run's numbers bitwise") {
    // cases::run_tanaka_dam_break with the example's configuration (lsmps_impact_params) at L = 10 mm to
    // T = 3.3, the far-wall impact included (probe wet at T ≈ 3.04): once straight, once in pieces — stopped
    // after its first step (stop_after 1e-9 wall seconds), resumed to T = 2 (a T_end other than the first
    // piece's, checkpoint written at the end), resumed from that file to T = 3.3. Every sample and extreme
    // equals the straight run's bitwise: BiCGSTAB-Jacobi keeps no factorisation across steps
    // (io/lsmps_checkpoint.hpp), and the runner's running measurements (front and probe samples, extremes,
    // the next front sample's T) travel in the file.
    mpskit::test::scratch tmp("mpskit_test_lsmps_flow", "tanaka_pieces");
    cases::tanaka_dam_break_config c;
    c.L = 0.01;
    const scheme::lsmps_params<2> p = scheme::lsmps_impact_params<2>();
    const auto straight = cases::run_tanaka_dam_break(c, 3.3, p);
    cases::tanaka_pieces first;
    first.checkpoint = (tmp / "db.mpscp").string();
    first.stop_after = 1e-9;
    // The caller's own section travels with the file (the example keeps its output state there).
    first.save_extra = [](io::checkpoint_sections& s) { s.add_doubles("caller.state", {42.0}); };
    const auto a = cases::run_tanaka_dam_break(c, 3.3, p, false, cases::no_tanaka_observer{}, first);
    CHECK(a.stopped);
    CHECK(a.steps == 1);
    cases::tanaka_pieces second;
    second.resume = first.checkpoint;
    second.checkpoint = (tmp / "db2.mpscp").string();
    second.checkpoint_interval = 1e-9;  // written after every step too: writing must not change the run
    double extra = 0.0;
    second.load_extra = [&](const io::checkpoint_sections& s, const cases::tanaka_dam_break_result& so_far) {
      extra = s.get_doubles("caller.state").at(0);
      CHECK(so_far.T.size() == 1);  // the first step's front sample, restored before the second step
    };
    const auto b = cases::run_tanaka_dam_break(c, 2.0, p, false, cases::no_tanaka_observer{}, second);
    CHECK(extra == 42.0);
    CHECK(b.resumed_at == a.T_reached);
    CHECK(b.T_reached >= 2.0);
    cases::tanaka_pieces third;
    third.resume = second.checkpoint;
    const auto r = cases::run_tanaka_dam_break(c, 3.3, p, false, cases::no_tanaka_observer{}, third);
    CHECK(r.resumed_at == b.T_reached);
    // the earlier pieces' wall time travels in the file
    CHECK(r.wall_seconds_before > b.wall_seconds_before);
    CHECK(b.wall_seconds_before > 0.0);
    using mpskit::test::same_bits;
    REQUIRE(straight.probe_t.size() == r.probe_t.size());
    CHECK(same_bits(r.probe_t, straight.probe_t));
    CHECK(same_bits(r.probe_p, straight.probe_p));  // NaN while dry: compared as bits
    CHECK(same_bits(r.T, straight.T));
    CHECK(same_bits(r.Z, straight.Z));
    CHECK(same_bits(r.Z_body, straight.Z_body));
    CHECK(same_bits(r.p_min, straight.p_min));
    CHECK(same_bits(r.p_min_copies, straight.p_min_copies));
    CHECK(same_bits(r.u_max, straight.u_max));
    CHECK(same_bits(r.T_u_max, straight.T_u_max));
    CHECK(same_bits(r.min_pair_ratio, straight.min_pair_ratio));
    CHECK(same_bits(r.T_min_pair, straight.T_min_pair));
    CHECK(same_bits(r.min_pair_ratio_non_isolated, straight.min_pair_ratio_non_isolated));
    CHECK(same_bits(r.volume_change, straight.volume_change));
    CHECK(r.steps == straight.steps);
    CHECK(r.ppe_iterations == straight.ppe_iterations);
    CHECK(r.collisions == straight.collisions);
    CHECK(r.active_set_rows == straight.active_set_rows);
    CHECK(r.shift_velocity_clipped == straight.shift_velocity_clipped);
    CHECK(r.particles == straight.particles);
    CHECK(r.particles_end == straight.particles_end);
    // The run must have reached what it is compared on: the impact at the probe, within the 10 ms window.
    const cases::impact_measures m = cases::far_wall_impact(r);
    CHECK(std::isfinite(m.t_arrival));
    CHECK(same_bits(m.impulse, cases::far_wall_impact(straight).impulse));
    CHECK(r.collisions > 0);
    CHECK(r.active_set_rows > 0);

    // Refused: another configuration's file (named field), a caller's section under the runner's prefix, and
    // stop_after without a file.
    auto other = c;
    other.L = 0.0125;
    CHECK_THROWS_WITH_AS(
        cases::run_tanaka_dam_break(other, 3.3, p, false, cases::no_tanaka_observer{}, third),
        doctest::Contains("was written with L = 0.01"), mpskit::error);
    auto other_g = c;
    other_g.g = 9.81;
    CHECK_THROWS_WITH_AS(
        cases::run_tanaka_dam_break(other_g, 3.3, p, false, cases::no_tanaka_observer{}, third),
        doctest::Contains("was written with g = 9.8"), mpskit::error);
    cases::tanaka_pieces reserved;
    reserved.checkpoint = (tmp / "r.mpscp").string();
    reserved.save_extra = [](io::checkpoint_sections& s) { s.add_doubles("tanaka_dam_break.mine", {1.0}); };
    CHECK_THROWS_WITH_AS(cases::run_tanaka_dam_break(c, 0.1, p, false, cases::no_tanaka_observer{}, reserved),
                         doctest::Contains("is reserved"), mpskit::error);
    cases::tanaka_pieces no_file;
    no_file.stop_after = 10.0;
    CHECK_THROWS_WITH_AS(cases::run_tanaka_dam_break(c, 0.1, p, false, cases::no_tanaka_observer{}, no_file),
                         doctest::Contains("need a checkpoint file"), mpskit::error);
    // A file that cannot be written is refused before the first step, with catch_failure too (not a scheme
    // failure).
    cases::tanaka_pieces unwritable;
    unwritable.checkpoint = (tmp / "no_such_dir" / "x.mpscp").string();
    CHECK_THROWS_AS(cases::run_tanaka_dam_break(c, 0.1, p, true, cases::no_tanaka_observer{}, unwritable),
                    mpskit::error);
    // ... and so is one that fails later (here the caller's section on the second write, after the first
    // step).
    cases::tanaka_pieces later;
    later.checkpoint = (tmp / "later.mpscp").string();
    later.checkpoint_interval = 1e-9;
    int writes = 0;
    later.save_extra = [&](io::checkpoint_sections&) {
      if (++writes == 2) fail("caller's section refused");
    };
    CHECK_THROWS_WITH_AS(cases::run_tanaka_dam_break(c, 0.5, p, true, cases::no_tanaka_observer{}, later),
                         doctest::Contains("caller's section refused"), mpskit::error);
    // A file at or beyond T_end: nothing to run.
    cases::tanaka_pieces past;
    past.resume = second.checkpoint;  // written at the end, T >= 2
    CHECK_THROWS_WITH_AS(cases::run_tanaka_dam_break(c, 1.5, p, false, cases::no_tanaka_observer{}, past),
                         doctest::Contains("nothing to run"), mpskit::error);

    // A run killed before its first interval leaves the checkpoint written before the first step; resumed
    // from it, the run is the straight one.
    cases::tanaka_pieces killed;
    killed.checkpoint = (tmp / "db0.mpscp").string();
    killed.checkpoint_interval = 1e6;
    CHECK_THROWS_WITH_AS(
        cases::run_tanaka_dam_break(c, 3.3, p, false, [](const auto&) { fail("killed"); }, killed),
        doctest::Contains("killed"), mpskit::error);
    cases::tanaka_pieces from0;
    from0.resume = killed.checkpoint;
    const auto r0 = cases::run_tanaka_dam_break(c, 3.3, p, false, cases::no_tanaka_observer{}, from0);
    CHECK(r0.resumed_at == 0.0);
    CHECK(same_bits(r0.probe_p, straight.probe_p));
    CHECK(same_bits(r0.Z, straight.Z));
    CHECK(same_bits(r0.u_max, straight.u_max));
    CHECK(r0.steps == straight.steps);
  }
}  // TEST_SUITE
