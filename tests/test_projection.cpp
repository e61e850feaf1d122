// Stability of the LSMPS projection (scheme/lsmps_semi_implicit.hpp, docs/lsmps_scheme.md "Stability of the
// projection"): the spectral radius of the linearised one-step velocity map at rest, with g = 0 and ν = 0.
// Label projection_stability (built with SuiteSparse: the nested-gradient PPE needs a direct solver).
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "cases/hydrostatic_polygon.hpp"
#include "mpskit/ppe/fallback.hpp"
#include "mpskit/ppe/sparse_lu.hpp"
#include "mpskit/ppe/suitesparse.hpp"
#include "mpskit/scene.hpp"

using namespace mpskit;

namespace {

struct slab_scene : lsmps_defaults<2> {  // periodic in x, free surfaces above and below
  using walls = mpskit::scheme::no_walls;
  using shifting = mpskit::scheme::no_regularization;
  using solver = mpskit::ppe::umfpack;
};
struct tank_scene : lsmps_defaults<2> {  // polygon tank, free surface on top
  using shifting = mpskit::scheme::no_regularization;
  using solver = mpskit::ppe::umfpack;
};
struct tank_fallback_scene : tank_scene {  // the same tank, BiCGSTAB-Jacobi with Eigen's SparseLU behind it
  using solver = mpskit::ppe::with_fallback<mpskit::ppe::bicgstab_jacobi, mpskit::ppe::sparse_lu>;
};
struct tank_scene_3d : lsmps_defaults<3> {  // 3D box or prism tank, free surface on top
  using shifting = mpskit::scheme::no_regularization;
  using solver = mpskit::ppe::umfpack;
};

/// The fluid at rest with g = 0 and ν = 0 is a fixed point of one step; a velocity perturbation δu (|δu| Δt
/// ≪ L, so the geometry is frozen) maps linearly: δu^{k+1} = P δu^k, P = I − G L⁻¹ D with the scheme's own
/// divergence (det F source), PPE operator and gradient. A growing mode is an eigenvalue |λ| > 1 of P. P is
/// built column by column from one step per unit perturbation (ε = 1e-9 m/s; the det F source is quadratic
/// in ∇u′ beyond the linear term, so the neglected part is O(ε Δt) relative) minus the unperturbed step.
template <class Scene>
double spectral_radius(const scheme::lsmps_params<Scene::dim>& p, const scheme::lsmps_state<Scene::dim>& s0,
                       const geometry::polygon_set<Scene::dim>* walls) {
  constexpr int D = Scene::dim;
  const index_t n = s0.n_real();
  const double eps = 1e-9;
  points<D> u0;
  {
    simulation<Scene> sim(p, s0, walls);
    sim.step();
    u0 = sim.state().u().leftCols(n);
  }
  Eigen::MatrixXd M(D * n, D * n);
  for (index_t c = 0; c < D * n; ++c) {
    auto s = s0;
    s.u()(c % D, c / D) += eps;
    simulation<Scene> sim(p, std::move(s), walls);
    sim.step();
    for (index_t r = 0; r < D * n; ++r) M(r, c) = (sim.state().u()(r % D, r / D) - u0(r % D, r / D)) / eps;
  }
  const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(M, false).eigenvalues();
  return ev.cwiseAbs().maxCoeff();
}

template <int D = 2>
scheme::lsmps_params<D> rest_params() {
  scheme::lsmps_params<D> p;
  p.g.setZero();
  p.nu = 0.0;
  p.time.mode = scheme::time_step_mode::fixed;
  p.time.dt_fixed = 1e-3;
  p.reorder_every = 0;
  p.solver.tolerance = 1e-10;  // the direct solver's residual check (measured ≤ 2e-12)
  return p;
}

/// The 2D polygon tank of the stability tests: 12 × 8 cm of water at L = 1 cm, a left wall at `angle`.
cases::polygon_tank_config tank_2d(double angle) {
  cases::polygon_tank_config tc;
  tc.L = 0.01;
  tc.W = 0.12;
  tc.H = 0.08;
  tc.angle_deg = angle;
  tc.tank_height = 0.13;
  return tc;
}

/// Spectral radii of the linearised step in a polygon tank at rest: with the filter (the default), without
/// it, and (nested = true) with the nested-gradient operator and no filter.
struct tank_radii {
  index_t fluid = 0;
  double filtered = 0.0, plain = 0.0, nested = 0.0;
};
template <class Scene>
tank_radii tank_spectral_radii(const cases::polygon_tank_config& tc, bool nested) {
  constexpr int D = Scene::dim;
  const auto tank = cases::make_polygon_tank<D>(tc);
  const auto s0 = cases::rest_state(tank);
  auto p = rest_params<D>();
  p.volume.c_min = 1e-9;  // volume correction off: the staircase fill beside the incline has c < c_min,
  p.volume.c_max = 1e9;   // which would make the state at rest move (no fixed point to linearise about)
  tank_radii r;
  r.fluid = tank.size();
  r.filtered = spectral_radius<Scene>(p, s0, &tank.walls);
  p.boundary_filter.strength = 0.0;
  r.plain = spectral_radius<Scene>(p, s0, &tank.walls);
  if (nested) {
    p.pressure = scheme::pressure_operator::nested_gradient;
    r.nested = spectral_radius<Scene>(p, s0, &tank.walls);
  }
  return r;
}

}  // namespace

TEST_SUITE("projection_stability") {
  TEST_CASE(
      "periodic slab with two free surfaces: second derivatives alone grow an odd-even mode; the filter and "
      "the nested gradient do not") {
    const int nx = 16, ny = 8;
    const double L = 0.01;
    scheme::lsmps_state<2> s0(nx * ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) s0.x().col(j * nx + i) << (i + 0.5) * L, (j + 0.5) * L;
    s0.u().setZero();
    s0.get<field::volume>().setConstant(L * L);
    auto p = rest_params();
    p.domain.periodic[0] = true;
    p.domain.hi[0] = nx * L;
    const double filtered = spectral_radius<slab_scene>(p, s0, nullptr);  // the defaults: eq. 63 + filter
    p.boundary_filter.strength = 0.0;
    const double compact = spectral_radius<slab_scene>(p, s0, nullptr);
    p.pressure = scheme::pressure_operator::nested_gradient;
    const double nested = spectral_radius<slab_scene>(p, s0, nullptr);
    std::printf(
        "projection_stability slab %dx%d: |lambda|max - 1 = %.3e (second derivatives), %.3e (with the "
        "one-sided-band filter, the default), %.3e (nested gradient)\n",
        nx, ny, compact - 1.0, filtered - 1.0, nested - 1.0);
    // The default filter (ε = 0.05) damps the mode: measured |λ| = 1 to 1e-12 (the divergence-free modes).
    CHECK(filtered - 1.0 <= 1e-9);
    // Measured 1.57e-2: the odd-even vertical mode of the row below each free surface (the growth of the
    // hydrostatic-tank runs, docs/lsmps_scheme.md). Asserted so that this analysis is known to detect an
    // instability; when a fix of the default operator makes this fail, update the docs and this bound.
    CHECK(compact - 1.0 >= 1e-2);
    // The nested gradient makes P a projection (P² = P: D G L⁻¹ = I with L = D G), eigenvalues 0 or 1;
    // measured within 1e-13 of 1. Bound 1e-9: the linearisation error O(ε Δt / L) ≈ 1e-10.
    CHECK(nested - 1.0 <= 1e-9);
  }
  TEST_CASE(
      "polygon tanks (90 and 60 degree walls, imaginary copies): the nested gradient keeps |lambda| <= 1") {
    for (const double angle : {90.0, 60.0}) {
      cases::polygon_tank_config tc = tank_2d(angle);
      const tank_radii r = tank_spectral_radii<tank_scene>(tc, true);
      std::printf(
          "projection_stability tank %.0f deg, %lld fluid: |lambda|max - 1 = %.3e (second derivatives), %.3e "
          "(filtered, the default), %.3e (nested)\n",
          angle, static_cast<long long>(r.fluid), r.plain - 1.0, r.filtered - 1.0, r.nested - 1.0);
      CHECK(r.plain - 1.0 >= 1e-2);     // measured 1.52e-2 (both tanks), as the slab
      CHECK(r.filtered - 1.0 <= 1e-9);  // measured −1e-4 (every mode decays)
      CHECK(r.nested - 1.0 <= 1e-9);    // measured ≤ 4e-12
    }
  }
  TEST_CASE(
      "3D tanks (box, 60 degree prism): with the filter and the slid-cone surface test every mode decays") {
    // The 4 particles in the vertical edges of a box at the free surface had a solid cone (their normal
    // tilts toward the edge) and were left unflagged: a vertical mode grew 2.2x per step (the 3D box failed
    // at step ~4000). With the cone slid along the walls (surface/geometric.hpp) they are flagged.
    for (const double angle : {90.0, 60.0}) {
      cases::polygon_tank_config tc;
      tc.L = 0.01;
      tc.W = 0.06;
      tc.H = 0.05;
      tc.B = 0.04;
      tc.angle_deg = angle;
      tc.tank_height = 0.1;
      const tank_radii r = tank_spectral_radii<tank_scene_3d>(tc, false);
      std::printf(
          "projection_stability 3D tank %.0f deg, %lld fluid: |lambda|max - 1 = %.3e (filtered, the "
          "default), %.3e (no filter)\n",
          angle, static_cast<long long>(r.fluid), r.filtered - 1.0, r.plain - 1.0);
      CHECK(r.filtered - 1.0 <= 1e-9);  // measured −5.3e-3 (box), −2.2e-3 (60°)
      CHECK(r.plain - 1.0 >= 1e-3);     // measured 8.3e-3 (both): the filter is needed in 3D too
    }
  }

  TEST_CASE("nested gradient: the first step from rest reproduces the hydrostatic pressure") {
    cases::polygon_tank_config tc;
    tc.L = 0.005;
    tc.W = 0.1;
    tc.H = 0.1;
    tc.tank_height = 0.15;
    tc.angle_deg = 60.0;
    const auto tank = cases::make_polygon_tank<2>(tc);
    auto p = rest_params();
    p.g = scheme::semi_implicit_params<2>::gravity();
    p.volume.c_min = 1e-9;
    p.volume.c_max = 1e9;
    p.pressure = scheme::pressure_operator::nested_gradient;
    simulation<tank_scene> sim(p, cases::rest_state(tank), &tank.walls);
    sim.step();
    const auto& P = sim.state().get<field::pressure>();
    const double g = -p.g[1], rho = p.rho;
    double ztop = -1e9, err = 0.0;
    for (index_t i = 0; i < tank.size(); ++i) ztop = std::max(ztop, tank.x(1, i));
    for (index_t i = 0; i < tank.size(); ++i)
      err = std::max(err, std::abs(P[i] - rho * g * (ztop - tank.x(1, i))) / (rho * g * tc.H));
    std::printf("projection_stability nested hydrostatic first step: max |p - rho g d| / (rho g H) = %.2e\n",
                err);
    // LSMPS-A of order 2 differentiates the linear field exactly and its gradient (a constant) to zero, so
    // the hydrostatic field solves the nested rows and the parent-gradient wall rows exactly; UMFPACK's
    // rounding on this ill-conditioned matrix (its near-null checkerboard, see the docs) is the only error.
    // Bound 1e-6.
    CHECK(err <= 1e-6);
  }
  TEST_CASE("bad input: the nested gradient with the constrained-Poisson wall rows is refused") {
    scheme::lsmps_params<2> p;
    p.pressure = scheme::pressure_operator::nested_gradient;
    p.copy_row = scheme::copy_row_kind::constrained_poisson;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("nested_gradient"), mpskit::error);
    p.copy_row = scheme::copy_row_kind::neumann_points;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("neumann_points"), mpskit::error);
    p.pressure = scheme::pressure_operator::second_derivatives;
    p.copy_two_point = 1.0;  // the two-point term belongs to a copy row, and these copies have none
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("copy_two_point"), mpskit::error);
  }

  TEST_CASE(
      "neumann_points wall rows: hydrostatic first step exact (2D 60 degree, 3D box) and every mode decays") {
    // copy_row = neumann_points (docs/lsmps_scheme.md deviation 11): no copy unknowns; each copy is the
    // Neumann equation n·∇p = ρ (u′_parent − u_wall)·n/Δt in its neighbours' pressure fits.
    for (const int dim : {2, 3}) {
      cases::polygon_tank_config tc;
      tc.L = dim == 2 ? 0.005 : 0.01;
      tc.W = dim == 2 ? 0.1 : 0.06;
      tc.H = dim == 2 ? 0.1 : 0.05;
      tc.B = 0.04;
      tc.tank_height = 0.15;
      tc.angle_deg = dim == 2 ? 60.0 : 90.0;
      double err = 0.0;
      const auto run = [&](auto scene_tag) {
        using Scene = decltype(scene_tag);
        constexpr int D = Scene::dim;
        const auto tank = cases::make_polygon_tank<D>(tc);
        auto p = rest_params<D>();
        p.g = scheme::semi_implicit_params<D>::gravity();
        p.volume.c_min = 1e-9;
        p.volume.c_max = 1e9;
        p.copy_row = scheme::copy_row_kind::neumann_points;
        simulation<Scene> sim(p, cases::rest_state(tank), &tank.walls);
        sim.step();
        const auto& P = sim.state().template get<field::pressure>();
        const double g = -p.g[D - 1], rho = p.rho;
        double ztop = -1e9;
        for (index_t i = 0; i < tank.size(); ++i) ztop = std::max(ztop, tank.x(D - 1, i));
        for (index_t i = 0; i < tank.size(); ++i)
          err = std::max(err, std::abs(P[i] - rho * g * (ztop - tank.x(D - 1, i))) / (rho * g * tc.H));
      };
      if (dim == 2) run(tank_scene{});
      else run(tank_scene_3d{});
      std::printf(
          "projection_stability neumann_points hydrostatic first step %dD: max |p - rho g d| / (rho g H) = "
          "%.2e\n",
          dim, err);
      // Exact: LSMPS-A of order 2 differentiates the linear field exactly and the wall data are its exact
      // normal derivative ρ g·n; the bound is UMFPACK's rounding (measured 2e-15 in 2D).
      CHECK(err <= 1e-9);
    }
    // The linearised step with the filter, 2D tanks of the test above and the 3D box and prism: measured
    // |λ|max − 1 = −1.6e-4 (2D 90°), −1.1e-4 (2D 60°), −5.6e-3 (3D box), −2.3e-3 (3D prism): every mode
    // decays.
    const auto radius = [](auto scene_tag, const cases::polygon_tank_config& tc) {
      using Scene = decltype(scene_tag);
      constexpr int D = Scene::dim;
      const auto tank = cases::make_polygon_tank<D>(tc);
      auto p = rest_params<D>();
      p.volume.c_min = 1e-9;
      p.volume.c_max = 1e9;
      p.copy_row = scheme::copy_row_kind::neumann_points;
      const double r = spectral_radius<Scene>(p, cases::rest_state(tank), &tank.walls);
      std::printf(
          "projection_stability neumann_points %dD tank %.0f deg: |lambda|max - 1 = %.3e (filtered)\n", D,
          tc.angle_deg, r - 1.0);
      return r;
    };
    for (const double angle : {90.0, 60.0}) {
      cases::polygon_tank_config tc = tank_2d(angle);
      CHECK(radius(tank_scene{}, tc) - 1.0 <= 1e-9);
      tc.W = 0.06;  // the 3D tanks of the test "3D tanks (box, 60 degree prism)"
      tc.H = 0.05;
      tc.B = 0.04;
      tc.tank_height = 0.1;
      CHECK(radius(tank_scene_3d{}, tc) - 1.0 <= 1e-9);
    }
  }
}

TEST_SUITE("projection_stability") {
  TEST_CASE(
      "own-loop guard: its blocks are the diagonal blocks of the linearised step; quiet at rest; its "
      "fallback acts") {
    // lsmps_params::own_loop (docs/lsmps_scheme.md deviation 15). The 2D 90 degree tank at rest (g = 0,
    // ν = 0, no shifting) with the two-point copy rows, so that surface parents with copies are checked too.
    // With the velocity filter off the step's velocity map is the projection, whose D×D diagonal blocks the
    // guard computes; the guard never acts here (max_gain = 1e6) and checks every non-surface particle.
    const auto tank = cases::make_polygon_tank<2>(tank_2d(90.0));
    const auto s0 = cases::rest_state(tank);
    auto p = rest_params<2>();
    p.volume.c_min = 1e-9;
    p.volume.c_max = 1e9;
    p.boundary_filter.strength = 0.0;
    p.copy_two_point = 1.0;
    p.own_loop.enabled = true;
    p.own_loop.max_gain = 1e6;
    p.own_loop.candidate_packing = 10.0;
    const index_t n = s0.n_real();
    const double eps = 1e-9;
    const auto gains = [&](double patch_radius) {
      auto q = p;
      q.own_loop.patch_radius = patch_radius;
      simulation<tank_scene> sim(q, s0, &tank.walls);
      sim.step();
      return std::make_pair(Eigen::VectorXd(sim.own_loop_gains()), sim.state().u().leftCols(n).eval());
    };
    const auto [whole, u0] = gains(100.0);  // the patch holds every unknown: the global system
    const auto [patch, u0_patch] = gains(p.own_loop.patch_radius);
    Eigen::Matrix2d B;
    double err_whole = 0.0, err_patch = 0.0;
    long checked = 0, surface_checked = 0;
    for (index_t i = 0; i < n; ++i) {
      if (std::isnan(whole[i])) continue;
      for (int a = 0; a < 2; ++a) {
        auto s = s0;
        s.u()(a, i) += eps;
        simulation<tank_scene> sim(p, std::move(s), &tank.walls);
        sim.step();
        B.col(a) = (sim.state().u().col(i) - u0.col(i)) / eps;
        if (a == 0)
          surface_checked += (sim.state().flags()[static_cast<std::size_t>(i)] & flag::surface) != 0;
      }
      const double exact = Eigen::EigenSolver<Eigen::Matrix2d>(B, false).eigenvalues().cwiseAbs().maxCoeff();
      err_whole = std::max(err_whole, std::abs(whole[i] - exact));
      err_patch = std::max(err_patch, std::abs(patch[i] - exact));
      ++checked;
    }
    std::printf("projection_stability own-loop guard, 2D 90 deg tank: %ld particles checked (%ld surface), "
                "max |rho(B) - rho(J_ii)| = %.2e (patch: every unknown), %.2e (patch 1.5 R_e)\n",
                checked, surface_checked, err_whole, err_patch);
    CHECK(checked > n / 2);      // every non-surface particle (candidate_packing = 10)
    CHECK(surface_checked >= 2);  // the surface particles in the two top corners have copies
    // Both are finite differences of the same linear map (ε = 1e-9 m/s here, 1e-6 L/Δt in the guard): the
    // 100 R_e patch holds every unknown (the global solve), so they agree to the differences' rounding.
    CHECK(err_whole <= 1e-5);
    // The 1.5 R_e patch (δp = 0 beyond it) is an approximation; bound set from the measured value above.
    CHECK(err_patch <= 0.05);

    // Quiet at rest with gravity: at the defaults (max_gain 1.1) nothing acts and the step is bitwise the
    // step without the guard (the hydrostatic first step of the 90 degree tank).
    auto h = p;
    h.g = scheme::semi_implicit_params<2>::gravity();
    h.own_loop = {};
    simulation<tank_scene> off(h, s0, &tank.walls);
    off.step();
    h.own_loop.enabled = true;
    simulation<tank_scene> on(h, s0, &tank.walls);
    on.step();
    CHECK(on.counters().own_loop_checked > 0);
    CHECK(on.counters().own_loop_dirichlet + on.counters().own_loop_one_point == 0);
    CHECK(on.counters().own_loop_solves == 0);
    CHECK(on.state().template get<field::pressure>() == off.state().template get<field::pressure>());
    CHECK(on.state().u() == off.state().u());

    // Wall candidates (own_loop_guard_params::wall_candidate_packing): with no packing candidates
    // (candidate_packing = 0) and wall_candidate_packing = 10, the non-surface particles checked are exactly
    // those with wall copies: the first layer, 0.5 L from a wall (α_w L = L; the second layer is at 1.5 L).
    auto w = h;
    w.own_loop.candidate_packing = 0.0;
    w.own_loop.wall_candidate_packing = 10.0;
    simulation<tank_scene> wc(w, s0, &tank.walls);
    wc.step();
    const auto tc = tank_2d(90.0);
    long wall_checked = 0, mismatched = 0;
    for (index_t i = 0; i < n; ++i) {
      if ((wc.state().flags()[static_cast<std::size_t>(i)] & flag::surface) != 0) continue;
      const auto x = s0.x().col(i);  // rest_params: no reordering, the step keeps the particle order
      const bool near = std::min({x[0], tc.W - x[0], x[1]}) < tc.L;
      const bool checked = !std::isnan(wc.own_loop_gains()[i]);
      wall_checked += checked;
      mismatched += checked != near;
    }
    std::printf(
        "projection_stability own-loop guard, wall candidates: %ld non-surface particles checked, %ld "
        "mismatched\n",
        wall_checked, mismatched);
    CHECK(wall_checked >= 10);  // the first layer of the floor and both walls below the surface
    CHECK(mismatched == 0);

    // The fallback: with every non-surface particle a candidate and max_gain = 0.5 (below the blocks, ≈ 0.95
    // in the interior) each marked non-surface particle is solved at p = 0 and each marked surface parent
    // keeps the two-point term off; the PPE is solved again.
    h.own_loop.max_gain = 0.5;
    h.own_loop.candidate_packing = 10.0;
    simulation<tank_scene> act(h, s0, &tank.walls);
    act.step();
    const auto& P = act.state().template get<field::pressure>();
    const auto& gain = act.own_loop_gains();
    long marked = 0, zero = 0;
    for (index_t i = 0; i < n; ++i)
      if (gain[i] > 0.5 && (act.state().flags()[static_cast<std::size_t>(i)] & flag::surface) == 0) {
        ++marked;
        zero += P[i] == 0.0;
      }
    std::printf(
        "projection_stability own-loop guard at max_gain 0.5: %ld p = 0 rows, %ld surface parents, %ld "
        "solves\n",
        act.counters().own_loop_dirichlet, act.counters().own_loop_one_point, act.counters().own_loop_solves);
    CHECK(act.counters().own_loop_solves >= 1);
    CHECK(act.counters().own_loop_dirichlet == marked);  // each marked once, every mark followed by a solve
    CHECK(zero == marked);
  }
  TEST_CASE(
      "own-loop guard: two surface particles alone in a corner get p = 0 copies, not a singular group") {
    // The failure of the guard's one-point fallback measured on Tanaka's dam break at 3.0, 3.4 and 4.4 mm
    // (docs/lsmps_scheme.md deviation 15): two surface particles alone in the bottom-right corner, each with
    // a floor and a wall copy. Each fit sees the other particle and the four copies (five points, five
    // unknowns of the second-order fit: exactly determined), so one-point copy rows (the parents' gradients)
    // are singular: ((x − x₁)·m)², m ⊥ x₂ − x₁, vanishes with its gradient at both parents and not at the
    // copies. Positions as at 3.4 mm (in units of L from the corner). The direct solver refuses a singular
    // system, so without the closure test this step throws.
    const auto tc = tank_2d(90.0);
    const auto tank = cases::make_polygon_tank<2>(tc);
    const double L = tc.L;
    scheme::lsmps_state<2> s0(2);
    s0.x().col(0) << tc.W - 0.935 * L, 0.268 * L;
    s0.x().col(1) << tc.W - 0.847 * L, 0.497 * L;
    s0.u().col(0) << 0.3, -0.3;
    s0.u().col(1) << 0.3, -0.2;
    s0.template get<field::volume>().setConstant(L * L);
    auto p = rest_params<2>();
    p.g = scheme::semi_implicit_params<2>::gravity();
    p.copy_two_point = 1.0;
    p.own_loop.enabled = true;
    p.own_loop.max_gain = 0.0;  // every candidate marked (their blocks here: printed below)
    simulation<tank_scene> sim(p, s0, &tank.walls);
    CHECK_NOTHROW(sim.step());
    const index_t n = sim.state().n_real();
    const auto& P = sim.state().template get<field::pressure>();
    const auto& gain = sim.own_loop_gains();
    std::printf(
        "projection_stability own-loop guard, two particles in a corner: %ld copies, gains %.3f %.3f, "
        "%ld p = 0 marks, %ld one-point, pressures at the copies %g\n",
        static_cast<long>(sim.state().n_ghost()), gain[0], gain[1], sim.counters().own_loop_dirichlet,
        sim.counters().own_loop_one_point, P.segment(n, sim.state().n_ghost()).cwiseAbs().maxCoeff());
    REQUIRE(n == 2);
    CHECK(sim.state().n_ghost() == 4);  // a floor and a wall copy each
    CHECK((sim.state().flags()[0] & flag::surface) != 0);
    CHECK((sim.state().flags()[1] & flag::surface) != 0);
    CHECK(sim.counters().own_loop_dirichlet == 2);  // both parents' copies made p = 0 rows
    CHECK(sim.counters().own_loop_one_point == 0);
    CHECK(P.segment(n, 4).cwiseAbs().maxCoeff() == 0.0);
  }

  TEST_CASE(
      "solver fallback: a failed Krylov solve is made by the direct solver and counted (ppe_fallbacks)") {
    // ppe::with_fallback in a scene: the 90 degree tank with gravity from rest, 20 steps. With BiCGSTAB
    // capped at one iteration every solve fails (the cold restart from 0 too) and SparseLU makes it: counted
    // once per solve, and the pressures are UMFPACK's (another direct solver) to rounding. Tolerance 1e-9 ρ g
    // H: measured 7.6e-14 (SparseLU against UMFPACK, both to residuals ≤ 1e-10, rest_params) and 6.5e-13
    // (BiCGSTAB to 1e-10), four orders of margin for other compilers' rounding, while the failed
    // one-iteration iterate is off by O(1) (label solver's test). Uncapped, BiCGSTAB converges every step and
    // the fallback is never used.
    const auto tc = tank_2d(90.0);
    const auto tank = cases::make_polygon_tank<2>(tc);
    const auto s0 = cases::rest_state(tank);
    auto p = rest_params<2>();
    p.g = scheme::semi_implicit_params<2>::gravity();
    const int steps = 20;
    simulation<tank_scene> direct(p, s0, &tank.walls);
    auto pc = p;
    pc.solver.max_iterations = 1;
    simulation<tank_fallback_scene> capped(pc, s0, &tank.walls);
    simulation<tank_fallback_scene> free(p, s0, &tank.walls);
    for (int k = 0; k < steps; ++k) {
      direct.step();
      capped.step();
      free.step();
    }
    const index_t n = direct.state().n_real();
    const auto& pd = direct.state().template get<field::pressure>();
    const auto& pcap = capped.state().template get<field::pressure>();
    const auto& pf = free.state().template get<field::pressure>();
    const double scale = p.rho * 9.81 * tc.H;
    const double dcap = (pcap.head(n) - pd.head(n)).cwiseAbs().maxCoeff() / scale;
    const double dfree = (pf.head(n) - pd.head(n)).cwiseAbs().maxCoeff() / scale;
    std::printf(
        "projection_stability solver fallback: %ld fallbacks in %ld steps (capped), %ld (free); max |dp| / "
        "rho g H against UMFPACK %.2e (capped), %.2e (free)\n",
        capped.counters().ppe_fallbacks, capped.counters().steps, free.counters().ppe_fallbacks, dcap, dfree);
    REQUIRE(capped.state().n_real() == n);
    CHECK(capped.counters().steps == steps);
    CHECK(capped.counters().ppe_fallbacks == steps);  // one PPE solve per step here (no active set, no guard)
    // Every solve but the first (from the rest state's p = 0) starts from the previous pressures, fails and
    // is repeated from 0 (solver_params::cold_restart, one iteration again) before the LU makes it.
    CHECK(capped.counters().ppe_cold_restarts == steps - 1);
    // one per attempt
    CHECK(capped.counters().ppe_iterations == steps + capped.counters().ppe_cold_restarts);
    CHECK(free.counters().ppe_cold_restarts == 0);
    CHECK(dcap <= 1e-9);
    CHECK(free.counters().ppe_fallbacks == 0);
    CHECK(free.counters().ppe_iterations > steps);
  }

  TEST_CASE(
      "active set with copies: a wall does not pull fluid leaving it (copies solved below 0 become p = 0)") {
    // lsmps_params::active_set_copies (ours, opt-in). The 90 degree tank with gravity, the water moving up at
    // 0.3 m/s (leaving the floor): the floor copies' two-point rows (eq. 83) ask the floor to stop it, a
    // suction (copy pressures < 0: measured, printed). With the copies in the active set the step ends with
    // every copy and fluid pressure ≥ 0 and the copies counted in active_set_rows.
    const auto tc = tank_2d(90.0);
    const auto tank = cases::make_polygon_tank<2>(tc);
    auto s0 = cases::rest_state(tank);
    s0.u().row(1).setConstant(0.3);
    auto p = rest_params<2>();
    p.g = scheme::semi_implicit_params<2>::gravity();
    p.copy_two_point = 1.0;
    p.active_set_solves = 10;
    simulation<tank_scene> fluid_only(p, s0, &tank.walls);
    fluid_only.step();
    p.active_set_copies = true;
    simulation<tank_scene> with_copies(p, s0, &tank.walls);
    with_copies.step();
    const auto lowest = [](const auto& sim, bool copies) {
      const auto& P = sim.state().template get<field::pressure>();
      const index_t n = sim.state().n_real();
      return copies ? P.segment(n, sim.state().n_ghost()).minCoeff() : P.head(n).minCoeff();
    };
    std::printf(
        "projection_stability active set with copies: lowest copy pressure %.1f Pa (fluid only) -> %.1f Pa; "
        "active-set rows %ld -> %ld\n",
        lowest(fluid_only, true), lowest(with_copies, true), fluid_only.counters().active_set_rows,
        with_copies.counters().active_set_rows);
    REQUIRE(lowest(fluid_only, true) < -1.0);  // the premise: the floor pulls without the option
    CHECK(lowest(fluid_only, false) >= 0.0);
    CHECK(lowest(with_copies, true) >= 0.0);
    CHECK(lowest(with_copies, false) >= 0.0);
    CHECK(with_copies.counters().active_set_rows > fluid_only.counters().active_set_rows);
    // The reference path (every row rebuilt for each repeat) gives bitwise the same step.
    p.active_set_reuse_rows = false;
    simulation<tank_scene> rebuilt(p, s0, &tank.walls);
    rebuilt.step();
    CHECK(rebuilt.state().template get<field::pressure>() ==
          with_copies.state().template get<field::pressure>());
    CHECK(rebuilt.state().u() == with_copies.state().u());
    // Bad input: the option without the active set, or without copy unknowns, would do nothing.
    p.active_set_solves = 0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("active_set_copies"), mpskit::error);
    p.active_set_solves = 10;
    p.copy_two_point = 0.0;
    p.copy_row = scheme::copy_row_kind::neumann_points;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("active_set_copies: needs copy rows"),
                         mpskit::error);
  }

  TEST_CASE(
      "own-loop guard: the closed-form spectral radius of 2x2 and 3x3 matrices equals Eigen's eigensolver") {
    // scheme/detail/spectral_radius.hpp (characteristic polynomial; Eigen's general eigensolver cost 60 % of
    // a test unit's compile time). Random matrices with entries in [-2, 2], and the identity, a rotation
    // (complex pair), a double root and a defective block. Tolerance: rounding of the cubic's closed form.
    std::srand(7);
    const auto rnd = [] { return 4.0 * std::rand() / RAND_MAX - 2.0; };
    double err2 = 0.0, err3 = 0.0;
    for (int k = 0; k < 2000; ++k) {
      Eigen::Matrix2d A;
      Eigen::Matrix3d B;
      for (int i = 0; i < 4; ++i) A(i % 2, i / 2) = rnd();
      for (int i = 0; i < 9; ++i) B(i % 3, i / 3) = rnd();
      const double ea = Eigen::EigenSolver<Eigen::Matrix2d>(A, false).eigenvalues().cwiseAbs().maxCoeff();
      const double eb = Eigen::EigenSolver<Eigen::Matrix3d>(B, false).eigenvalues().cwiseAbs().maxCoeff();
      err2 = std::max(err2, std::abs(scheme::detail::spectral_radius<2>(A) - ea) / std::max(1.0, ea));
      err3 = std::max(err3, std::abs(scheme::detail::spectral_radius<3>(B) - eb) / std::max(1.0, eb));
    }
    std::printf("projection_stability closed-form spectral radius: max relative error 2x2 %.1e, 3x3 %.1e\n",
                err2, err3);
    CHECK(err2 <= 1e-9);
    CHECK(err3 <= 1e-6);
    CHECK(scheme::detail::spectral_radius<3>(Eigen::Matrix3d::Identity()) == doctest::Approx(1.0));
    Eigen::Matrix3d R;
    R << 0.0, -2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.5;  // eigenvalues ±2i and 0.5
    CHECK(scheme::detail::spectral_radius<3>(R) == doctest::Approx(2.0));
    Eigen::Matrix2d J2;
    J2 << 1.5, 1.0, 0.0, 1.5;  // defective, double root 1.5
    CHECK(scheme::detail::spectral_radius<2>(J2) == doctest::Approx(1.5));
  }
  TEST_CASE("bad input: own-loop guard parameters out of range are refused") {
    scheme::lsmps_params<2> p;
    p.own_loop.max_gain = -0.1;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("max_gain"), mpskit::error);
    p.own_loop = {};
    p.own_loop.patch_radius = 0.5;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("patch_radius"), mpskit::error);
    p.own_loop = {};
    p.own_loop.rounds = 0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("rounds"), mpskit::error);
    p.own_loop = {};
    p.own_loop.wall_candidate_packing = -1.0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("wall_candidate_packing"), mpskit::error);
  }
  TEST_CASE(
      "boundary filter: quadratic velocity fields are unchanged, a one-particle spike is damped by about "
      "epsilon") {
    // û_i is the LSMPS-B order-2 fit over j ≠ i: exact for quadratics, so u_i + ε(û_i − u_i) = u_i to
    // rounding.
    const int nx = 12, ny = 10;
    const double L = 0.01;
    points<2> x(2, nx * ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        x.col(j * nx + i) << (i + 0.5) * L + 1e-3 * L * std::sin(7.0 * i + 3.0 * j), (j + 0.5) * L;
    const index_t n = x.cols();
    const Eigen::VectorXd Ls = Eigen::VectorXd::Constant(n, L);
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::per_particle_radius{&Ls, 3.1}, {0.0, search::domain<2>{}});
    const search::support<search::per_particle_radius> sup{search::per_particle_radius{&Ls, 3.1},
                                                           search::radius_rule::pair_mean};
    points<2> u(2, n), du;
    for (index_t i = 0; i < n; ++i) {
      const double a = x(0, i), b = x(1, i);
      u.col(i) << 0.3 + 2.0 * a - 5.0 * b + 40.0 * a * a - 7.0 * a * b,
          -1.0 + 3.0 * a + 60.0 * b * b + 11.0 * a * b;
    }
    const points<2> u0 = u;
    regularize::boundary_filter_params fp;  // ε = 0.05
    fp.max_amplification = 20.0;  // the opt-in bound: no fit of this lattice (corners included) reaches it
    const auto all = [](index_t) { return true; };
    const regularize::boundary_filter_report fr = regularize::boundary_filter(
        exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, all, n, fp, u0, u, du);
    CHECK(fr.filtered == n);
    CHECK(fr.amplifying == 0);  // Σ|w| ≤ 5.86 at this lattice's corners (measured), far below 20
    {  // the opt-in taper at 6 leaves every fit of this lattice at full strength: bitwise the same result
      points<2> ut = u0;
      regularize::boundary_filter_params tp;
      tp.taper_amplification = 6.0;
      const auto tr = regularize::boundary_filter(exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, all,
                                                  n, tp, u0, ut, du);
      CHECK(tr.tapered == 0);
      CHECK(tr.filtered == n);
      CHECK((ut - u).cwiseAbs().maxCoeff() == 0.0);
    }
    const double err = (u - u0).cwiseAbs().maxCoeff() / u0.cwiseAbs().maxCoeff();
    std::printf("projection_stability boundary filter on a quadratic field: max relative change %.2e\n", err);
    CHECK(err <= 1e-10);  // rounding of a 6×6 least-squares fit (measured ≈ 1e-14)
    // A spike of 1 at an interior particle: û = 0 there (its neighbours are 0), so it drops to 1 − ε.
    points<2> s = points<2>::Zero(2, n);
    const index_t k = 5 * nx + 6;
    s(1, k) = 1.0;
    const points<2> s0 = s;
    regularize::boundary_filter(exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, all, n, fp, s0, s, du);
    CHECK(s(1, k) == doctest::Approx(1.0 - fp.strength).epsilon(1e-12));
    fp.strength = 1.5;
    CHECK_THROWS_AS(fp.validate(), mpskit::error);
    fp.strength = 0.05;
    fp.max_amplification = 0.5;  // below 1 no fit passes (Σ|w| ≥ |Σ w| = 1)
    CHECK_THROWS_AS(fp.validate(), mpskit::error);
    fp.max_amplification = 20.0;
    fp.taper_amplification = 0.5;
    CHECK_THROWS_WITH_AS(fp.validate(), doctest::Contains("taper_amplification"), mpskit::error);
  }

  TEST_CASE("boundary filter: a one-sided fit that amplifies its values (sum |w| > 20) is left alone") {
    // The neighbourhood of the particle that left Tanaka's 4 mm dam break at 75 m/s in the far-wall impact
    // (scratch trace, 2026-12-01, step 1476; offsets in L, velocities in m/s, the last one a wall copy at 0):
    // six neighbours for the six coefficients of the order-2 fit, all on one side.
    const double L = 0.004;
    const double off[7][2] = {{0, 0},          {2.921, 0.537},  {1.684, 1.116}, {-0.340, 0.460},
                              {-0.534, 1.097}, {-1.395, 1.227}, {-1.856, 1.272}};
    const double vel[7][2] = {{6.2843, 4.8448}, {2.795, 0.557},  {1.677, 0.671}, {0.992, -1.434},
                              {-4.426, -5.085}, {-0.056, 7.868}, {0, 0}};
    const index_t n = 7;
    points<2> x(2, n), u(2, n), du;
    for (index_t k = 0; k < n; ++k) {
      x.col(k) << 0.1 + off[k][0] * L, 0.01 + off[k][1] * L;
      u.col(k) << vel[k][0], vel[k][1];
    }
    const Eigen::VectorXd Ls = Eigen::VectorXd::Constant(n, L);
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::per_particle_radius{&Ls, 3.1}, {0.0, search::domain<2>{}});
    const search::support<search::per_particle_radius> sup{search::per_particle_radius{&Ls, 3.1},
                                                           search::radius_rule::pair_mean};
    const auto all = [](index_t) { return true; };
    const auto first = [](index_t i) { return i == 0; };
    const points<2> u0 = u;
    double spread = 0.0;
    for (index_t k = 1; k < n; ++k) spread = std::max(spread, (u0.col(k) - u0.col(0)).norm());
    regularize::boundary_filter_params fp;  // ε = 0.05, unbounded (the default)
    regularize::boundary_filter(exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, first, n, fp, u0, u,
                                du);
    const double jump = (u.col(0) - u0.col(0)).norm() / fp.strength;  // |û − u| of the unbounded fit
    std::printf(
        "projection_stability boundary filter, one-sided splash: |u_hat - u| = %.1f m/s, neighbour spread "
        "%.1f m/s\n",
        jump, spread);
    CHECK(jump > spread);  // the fit extrapolates beyond every value it is given
    u = u0;
    fp.max_amplification = 20.0;  // the fit here has Σ|w| = 66.6
    const regularize::boundary_filter_report fr = regularize::boundary_filter(
        exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, first, n, fp, u0, u, du);
    CHECK(fr.filtered == 0);
    CHECK(fr.amplifying == 1);
    CHECK((u - u0).cwiseAbs().maxCoeff() == 0.0);  // left alone, bitwise
    // Tapered at 6 instead (no bound): filtered with ε 6/Σ|w|, i.e. the unbounded change scaled by 6/66.6
    // (the fit's Σ|w|, 66.6 to three digits): parallel to it, 0.0901 of its length to 1e-3.
    points<2> full = u0, tap = u0;
    regularize::boundary_filter_params up;  // unbounded
    regularize::boundary_filter(exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, first, n, up, u0, full,
                                du);
    up.taper_amplification = 6.0;
    const regularize::boundary_filter_report tr = regularize::boundary_filter(
        exec::seq{}, x, Ls, nl, sup, op::lsmps_params{}, all, first, n, up, u0, tap, du);
    CHECK(tr.filtered == 1);
    CHECK(tr.tapered == 1);
    CHECK(tr.amplifying == 0);
    const vec<2> dfull = full.col(0) - u0.col(0), dtap = tap.col(0) - u0.col(0);
    const double ratio = dtap.norm() / dfull.norm();
    CHECK(ratio == doctest::Approx(6.0 / 66.6).epsilon(1e-3));
    // parallel
    CHECK(std::abs(dfull[0] * dtap[1] - dfull[1] * dtap[0]) <= 1e-12 * dfull.norm() * dtap.norm());
    // only the selected particle
    CHECK((tap.rightCols(n - 1) - u0.rightCols(n - 1)).cwiseAbs().maxCoeff() == 0.0);
  }
}
