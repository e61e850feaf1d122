// scheme/semi_implicit with wall + dummy layers: hydrostatic tank (label hydrostatic), Koshizuka & Oka
// dam break (label dam_break), and the scheme's bad-input, conservation and thread checks (label solver).
#include <doctest/doctest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "cases/dam_break.hpp"
#include "cases/hydrostatic.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/ppe/fallback.hpp"
#include "mpskit/ppe/floating_parts.hpp"
#include "mpskit/ppe/ilu0.hpp"
#include "mpskit/ppe/ilut.hpp"
#include "mpskit/ppe/interleaved_product.hpp"
#include "mpskit/ppe/sparse_lu.hpp"
#include "mpskit/wall/polygon_layers.hpp"

using namespace mpskit;

namespace {
std::vector<cases::front_series> front_data() {
  return cases::read_front_data(std::string(MPSKIT_TEST_DATA_DIR) + "/dam_break_front");
}
/// A non-symmetric convection–diffusion matrix on a g × g grid in the PPE's CSR type: 5-point −∇² with the
/// diagonal 5 and the upstream (i − 1) neighbour −2 (diagonally dominant).
ppe::matrix convection_diffusion(int g) {
  std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
  const auto id = [g](int i, int j) { return static_cast<std::ptrdiff_t>(i) * g + j; };
  for (int i = 0; i < g; ++i)
    for (int j = 0; j < g; ++j) {
      t.emplace_back(id(i, j), id(i, j), 5.0);
      if (i > 0) t.emplace_back(id(i, j), id(i - 1, j), -2.0);
      if (i + 1 < g) t.emplace_back(id(i, j), id(i + 1, j), -1.0);
      if (j > 0) t.emplace_back(id(i, j), id(i, j - 1), -1.0);
      if (j + 1 < g) t.emplace_back(id(i, j), id(i, j + 1), -1.0);
    }
  ppe::matrix A(g * g, g * g);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}
/// The restarts one solver made (ppe::detail::eigen_iterative's counters).
struct restart_counts {
  long breakdown = 0, cold = 0;
};
/// One BiCGSTAB-Jacobi solve of A x = b from x with params sp (a fresh solver): the report, the iterate and
/// the solver's restart counters.
std::tuple<ppe::solve_report, Eigen::VectorXd, restart_counts> run_bicgstab_jacobi(
    const ppe::solver_params& sp, const ppe::matrix& A, const Eigen::VectorXd& b, Eigen::VectorXd x) {
  ppe::bicgstab_jacobi s(sp);
  REQUIRE(s.compute(A) == Eigen::Success);
  const ppe::solve_report r = s.solve(b, x);
  return {r, std::move(x), restart_counts{s.breakdown_restarts(), s.cold_restarts()}};
}
/// A known solution u_k = sin(0.37 k) + 0.01 k (b = A u in the solver tests).
Eigen::VectorXd known_solution(int n) {
  Eigen::VectorXd u(n);
  for (int k = 0; k < n; ++k) u[k] = std::sin(0.37 * k) + 0.01 * k;
  return u;
}
}  // namespace

TEST_SUITE("hydrostatic") {
  TEST_CASE("hydrostatic: 2D tank, time-averaged pressure against rho g d, wall particles included") {
    cases::hydrostatic_config<2> cfg;  // H = W = 0.1 m, averaged over [20, 40] sqrt(H/g)
    cfg.l0 = cfg.depth / 40;
    cfg.params.time.dt_max = 1e-3;
    const auto r = cases::run_hydrostatic<defaults<2>>(cfg);
    MESSAGE("2D: max bin error " << r.max_bin_error << " rho g H; RMS speed " << r.rms_speed << ", max "
                                 << r.max_speed << " sqrt(gH); " << r.steps << " steps, " << r.wall_seconds
                                 << " s");
    // Reference p = rho g d (validation-cases.md D3), the issue's 2 % per bin below the top two layers.
    // Measured 0.0168 at l0 = H/40 (0.025-0.027 at H/20: a near-uniform offset of about +0.4 l0 rho g).
    CHECK(r.max_bin_error < 0.02);
    // Residual motion: measured RMS 0.033, max 0.104 sqrt(gH) — the classic scheme's free-surface noise,
    // far above the issue's 1e-3 / 1e-2 (docs/solver.md). Bounds with ~50 % margin catch a drift.
    CHECK(r.rms_speed < 0.05);
    CHECK(r.max_speed < 0.2);
    // Wall loads (validation-cases.md D3: bottom = fluid weight, side = ½ ρ g H², H = volume / width).
    // Measured 0.986 and 0.983 at H/40 (0.979, 0.974 at H/20; antisymmetric pair form, docs/solver.md).
    MESSAGE("2D loads: bottom " << r.bottom_force_ratio << ", side " << r.side_force_ratio);
    CHECK(r.bottom_force_ratio == doctest::Approx(1.0).epsilon(0.05));
    CHECK(r.side_force_ratio == doctest::Approx(1.0).epsilon(0.05));
    CHECK(r.min_fluid_height > 0.0);   // nothing through the bottom wall
    CHECK(r.max_fluid_offset <= 0.0);  // nothing through a side wall
    CHECK(r.fluid_end == r.fluid);     // particle count conserved
  }

  TEST_CASE(
      "hydrostatic: the corrected pressure gradient (bmmr.md eq. 29) removes the surface offset, 2D and 3D") {
    // The d/n0 gradient of a half stencil at the free surface is about half the hydrostatic one; the
    // correction matrix makes it exact for linear fields (Wang et al. 2017), so the +0.4 l0 ρg offset of the
    // default goes. Measured (max bin error / ρgH, RMS / max speed / √(gH)): 2D H/20 0.0033, 0.018 / 0.074
    // (default gradient: 0.024, 0.042 / 0.126); 3D H/10, W = 0.03 m 0.0102, 0.034 / 0.098 (default 0.041);
    // a rounding-level change of the inversion moved them from 0.0037 / 0.0112 (docs/solver.md).
    // Bounds: the issue's 2 % per bin; speeds with ~50 % margin (the residual noise is not removed).
    // Wall loads are not asserted: they come from the antisymmetric plain pair form, which does not match a
    // corrected gradient (measured bottom 0.96 / side 0.91 in 2D, docs/solver.md).
    cases::hydrostatic_config<2> c2;
    c2.l0 = c2.depth / 20;
    c2.params.gradient = scheme::pressure_gradient::corrected_minimum;
    const auto r2 = cases::run_hydrostatic<defaults<2>>(c2);
    cases::hydrostatic_config<3> c3;
    c3.depth = 0.05;
    c3.width = 0.03;
    c3.l0 = c3.depth / 10;
    c3.params.gradient = scheme::pressure_gradient::corrected_minimum;
    const auto r3 = cases::run_hydrostatic<defaults<3>>(c3);
    for (const auto* r : {&r2, &r3}) {
      MESSAGE("corrected gradient: max bin error " << r->max_bin_error << " rho g H; RMS " << r->rms_speed
                                                   << ", max " << r->max_speed << " sqrt(gH); " << r->steps
                                                   << " steps");
      CHECK(r->max_bin_error < 0.02);
      CHECK(r->min_fluid_height > 0.0);
      CHECK(r->max_fluid_offset <= 0.0);
      CHECK(r->fluid_end == r->fluid);
    }
    CHECK(r2.max_bin_error < 0.01);  // measured 0.0033–0.0037: the offset of the default (0.024) is gone
    CHECK(r2.rms_speed < 0.03);
    CHECK(r2.max_speed < 0.15);
    CHECK(r3.rms_speed < 0.05);
    CHECK(r3.max_speed < 0.17);
  }

  TEST_CASE("hydrostatic: the quiet configuration meets issue #4's residual speeds, 2D (H/20) and 3D") {
    // quiet_defaults<D> (mixed source, Tanaka eq. 25) with quiet_params (corrected gradient bmmr.md eq. 29
    // with p̂ = p_i, one-sided-band velocity filter ε = 0.1; docs/solver.md "Quiet configuration"). Why the
    // defaults are noisy: the linearised step (positions and velocities) of a 10 × 10 tank has |λ| = 1.028,
    // an odd-even shear of the rows below the surface that neither the number density nor the divergence
    // sees, grown by the eq. 22 gradient at ≈ 0.56 √(g/l0) per second; all three changes are needed (each
    // alone: 1e-2 to 5e-2). Issue #4: bins (pressure averaged over [20, 40] √(H/g)) within 2 % of ρgH below
    // the top two layers, RMS ≤ 1e-3 and max ≤ 1e-2 √(gH) (speeds at t = 40 √(H/g)). Measured 2D H/20: bins
    // 5e-5, RMS 1.45e-4, max 3.9e-4 (H/40, docs/solver.md: 2e-5, 4.7e-4, 3.0e-3; run at H/20 so the label
    // stays within the issue's 5 min with every earlier case kept); 3D H/10: bins 4e-4, RMS 3.6e-4, max
    // 2.2e-3 (defaults: 0.024, 0.042, 0.126 at H/20 and 0.0411, 0.046, 0.124 in 3D).
    cases::hydrostatic_config<2> c2;
    c2.l0 = c2.depth / 20;
    c2.params = scheme::quiet_params<2>();
    c2.params.time.dt_max = 1e-3;
    const auto r2 = cases::run_hydrostatic<quiet_defaults<2>>(c2);
    cases::hydrostatic_config<3> c3;
    c3.depth = 0.05;
    c3.width = 0.03;
    c3.l0 = c3.depth / 10;
    c3.params = scheme::quiet_params<3>();
    c3.params.time.dt_max = 1e-3;
    const auto r3 = cases::run_hydrostatic<quiet_defaults<3>>(c3);
    for (const auto* r : {&r2, &r3}) {
      MESSAGE("quiet: max bin error " << r->max_bin_error << " rho g H; RMS " << r->rms_speed << ", max "
                                      << r->max_speed << " sqrt(gH); loads bottom " << r->bottom_force_ratio
                                      << ", side " << r->side_force_ratio << "; " << r->steps << " steps, "
                                      << r->wall_seconds << " s");
      CHECK(r->max_bin_error < 0.02);
      CHECK(r->rms_speed <= 1e-3);
      CHECK(r->max_speed <= 1e-2);
      CHECK(r->min_fluid_height > 0.0);
      CHECK(r->max_fluid_offset <= 0.0);
      CHECK(r->fluid_end == r->fluid);
    }
  }

  TEST_CASE("hydrostatic: 3D tank at CI size") {
    cases::hydrostatic_config<3> cfg;
    cfg.depth = 0.05;
    cfg.width = 0.03;
    cfg.l0 = cfg.depth / 10;
    cfg.params.time.dt_max = 1e-3;
    const auto r = cases::run_hydrostatic<defaults<3>>(cfg);
    MESSAGE("3D: max bin error " << r.max_bin_error << " rho g H; RMS speed " << r.rms_speed << ", max "
                                 << r.max_speed << " sqrt(gH); " << r.steps << " steps, " << r.wall_seconds
                                 << " s");
    // Measured 0.0411 at l0 = H/10 (the same +0.4 l0 rho g offset, relative to a 10-layer column). The
    // issue's 2 % needs l0 <= H/20, about 8x the CI cost: asserted 5 % here, a documented deviation.
    CHECK(r.max_bin_error < 0.05);
    CHECK(r.rms_speed < 0.07);  // measured 0.047
    CHECK(r.max_speed < 0.25);  // measured 0.134
    CHECK(r.min_fluid_height > 0.0);
    CHECK(r.max_fluid_offset <= 0.0);
    CHECK(r.fluid_end == r.fluid);
  }
}

TEST_SUITE("dam_break") {
  TEST_CASE("dam_break: surge front inside the Martin & Moyce / Koshizuka & Oka band for T <= 3") {
    const auto data = front_data();
    // The defaults, and the quiet configuration of the hydrostatic test (measured in one harness: defaults 0
    // of 61 samples outside the band, mean +4.2 % from its centre, largest 10.1 %; quiet 0 of 61, +2.4 %,
    // 8.6 %).
    for (const bool quiet : {false, true}) {
      CAPTURE(quiet);
      cases::dam_break_config cfg;  // a = 0.146 m, l0 = a/20
      if (quiet) cfg.params = scheme::quiet_params<2>();
      const auto r =
          quiet ? cases::run_dam_break<quiet_defaults<2>>(cfg) : cases::run_dam_break<defaults<2>>(cfg);
      MESSAGE("dam break: " << r.steps << " steps, " << r.wall_seconds << " s, "
                            << double(r.particles) * double(r.steps) / r.wall_seconds << " particle-steps/s");
      int outside = 0;
      for (std::size_t k = 0; k < r.T.size(); ++k) {
        const auto [lo, hi] = cases::front_band(data, r.T[k]);  // [0.9 min, 1.1 max] of the data at T
        CAPTURE(r.T[k]);
        CAPTURE(r.Z[k]);
        if (std::isnan(lo)) continue;
        outside += r.Z[k] < lo || r.Z[k] > hi;
      }
      CHECK(r.T.back() >= 3.0 - 1e-9);
      CHECK(outside == 0);
      CHECK(r.inside_tank);
      CHECK(r.fluid_end == r.fluid);  // particle count conserved
    }
  }
}

TEST_SUITE("solver") {
  TEST_CASE("solver: a closed tank (no Dirichlet row) is pinned each step and gives hydrostatic pressure") {
    // Fluid filling a closed box: no free surface, α_c = 0, so the PPE is singular up to a constant;
    // the scheme must pin one particle per step (counted) and solve. Reference: the pressure difference
    // between the bottom and the top fluid layer is ρ g (H − l0) (validation-cases.md D3); 5 % because the
    // first steps from rest are not yet in equilibrium (measured 898 Pa against 883 Pa, 1.7 %).
    const double l0 = 0.01, H = 0.1;
    auto blk = wall::fill_box<2>(vec<2>::Zero(), vec<2>(0.1, H), l0);
    blk.append(wall::box_walls<2>(vec<2>::Zero(), vec<2>(0.1, H), l0, 3, /*open_top=*/false));
    scheme::semi_implicit_state<2> s(static_cast<index_t>(blk.size()));
    for (std::size_t k = 0; k < blk.size(); ++k) {
      s.x().col(static_cast<index_t>(k)) = blk.x[k];
      s.kinds()[k] = blk.kinds[k];
    }
    scheme::semi_implicit_params<2> p;
    p.l0 = l0;
    p.compressibility = 0.0;
    p.negative = scheme::negative_pressure::keep;
    simulation<defaults<2>> sim(p, s);
    for (int k = 0; k < 5; ++k) sim.step();
    CHECK(sim.counters().pinned_components == 5);
    const auto& st = sim.state();
    double top = 0.0, bottom = 0.0;
    int nt = 0, nb = 0;
    for (index_t i = 0; i < st.n_real(); ++i) {
      if (st.kinds()[static_cast<std::size_t>(i)] != kind::fluid) continue;
      const double y = st.x()(1, i), pi = st.get<field::pressure>()[i];
      if (y < l0) { bottom += pi; ++nb; }
      if (y > H - l0) { top += pi; ++nt; }
    }
    const double dp = bottom / nb - top / nt;
    MESSAGE("closed tank: bottom − top pressure " << dp
                                                  << " Pa, rho g (H − l0) = " << 1000 * 9.81 * (H - l0));
    CHECK(dp == doctest::Approx(1000 * 9.81 * (H - l0)).epsilon(0.05));
  }

  TEST_CASE("solver: floating parts — the union-find check agrees with the search, one-way entries connect") {
    // Rows 0–2 a chain joined only by one-way entries (0 → 1 in row 0, 2 → 1 in row 2: a part of A + Aᵀ, not
    // of A alone), rows 3–4 a pair, row 5 alone. Which parts hold a Dirichlet row decides the answer.
    const auto make = [] {
      ppe::matrix A(6, 6);
      std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t{
          {0, 0, -2.0}, {0, 1, 1.0}, {1, 1, -1.0}, {2, 2, -2.0}, {2, 1, 1.0},
          {3, 3, -1.0}, {3, 4, 1.0}, {4, 4, -1.0}, {4, 3, 1.0},  {5, 5, -1.0}};
      A.setFromTriplets(t.begin(), t.end());
      return A;
    };
    const ppe::matrix A = make();
    const auto key = [](index_t r) { return 10 - r; };  // the pin is the largest row of a part
    const auto parts_of = [&](std::vector<std::uint8_t> d) {
      CHECK(ppe::every_part_anchored(A, d) == ppe::search_floating_parts(A, d, false, key).empty());
      return ppe::find_floating_parts(A, d, false, key);
    };
    CHECK(parts_of({0, 1, 0, 1, 0, 1}).empty());   // each part anchored (the chain through its middle row)
    CHECK(parts_of({1, 0, 0, 0, 1, 1}).empty());   // ... through an end row: row 2 reaches it only via Aᵀ
    auto parts = parts_of({0, 0, 1, 0, 0, 1});     // the pair floats
    REQUIRE(parts.size() == 1);
    CHECK(parts[0].pin == 4);
    CHECK(parts[0].members.size() == 2);
    parts = parts_of({0, 0, 0, 0, 0, 0});          // all three float
    REQUIRE(parts.size() == 3);
    CHECK(parts[0].pin == 2);
    CHECK(parts[0].members.size() == 3);
    CHECK(parts[2].pin == 5);
  }

  TEST_CASE("solver: polygon wall layers match box layers and distance bands on inclined walls") {
    const double l0 = 0.01;
    // Tank polyline: the same particles as box_walls except the two outer corner points of a Chebyshev
    // layering, which lie at sqrt(2)·2.5 l0 > 3 l0 from every wall.
    geometry::polygon_set<2> tank(geometry::tank(vec<2>(0, 0), vec<2>(0.2, 0.1)));
    const auto w = wall::polygon_walls<2>(tank, vec<2>(-0.05, -0.05), vec<2>(0.25, 0.1), l0, 3);
    const auto b = wall::box_walls<2>(vec<2>(0, 0), vec<2>(0.2, 0.1), l0, 3);
    CHECK(w.size() + 2 == b.size());
    index_t matched = 0;
    for (std::size_t k = 0; k < b.size(); ++k)
      for (std::size_t q = 0; q < w.size(); ++q)
        if ((b.x[k] - w.x[q]).norm() < 1e-12 && b.kinds[k] == w.kinds[q]) ++matched;
    CHECK(matched == static_cast<index_t>(w.size()));
    CHECK(wall::polygon_fill<2>(tank, vec<2>(0, 0), vec<2>(0.2, 0.1), l0).size() == 200);  // 20 × 10 lattice
    // A V-shaped valley (walls at ±30° from the horizontal), fluid above: every particle's band is
    // floor(d/l0) with d the exact distance to the two half-lines.
    mpskit::geometry::polygon_mesh<2> v;
    v.vertices.resize(2, 3);
    v.vertices << -0.1, 0.0, 0.1, 0.1 * std::tan(M_PI / 6), 0.0, 0.1 * std::tan(M_PI / 6);
    v.elements.resize(2, 2);
    v.elements << 0, 1, 1, 2;
    geometry::polygon_options<2> opt;
    opt.fluid_seed = vec<2>(0.0, 0.03);
    geometry::polygon_set<2> valley(v, opt);
    const auto vw = wall::polygon_walls<2>(valley, vec<2>(-0.08, -0.06), vec<2>(0.08, 0.04), l0, 3);
    auto seg_dist = [](const vec<2>& p, const vec<2>& a, const vec<2>& c) {
      const vec<2> d = c - a;
      const double t = std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
      return (p - (a + t * d)).norm();
    };
    index_t bad = 0;
    for (std::size_t k = 0; k < vw.size(); ++k) {
      const vec<2> p = vw.x[k];
      const double d = std::min(seg_dist(p, v.vertices.col(0), v.vertices.col(1)),
                                seg_dist(p, v.vertices.col(1), v.vertices.col(2)));
      const int m = static_cast<int>(std::floor(d / l0));
      bad += m > 2 || (m == 0) != (vw.kinds[k] == kind::wall);
    }
    CHECK(vw.size() > 30);
    CHECK(bad == 0);
  }

  TEST_CASE(
      "solver: ILUT factors kept across a change of the unknowns (ilut_reuse_across_changes), by a map") {
    // The 30 × 30 convection-diffusion matrix of the next case (upwind strength 1), its unknowns renumbered
    // by a permutation P (A' = P A Pᵀ: the same system, other order). With the map from the new numbering to
    // the old, the kept factors of A are an exact permutation of the factors A' would get (ILUT drops by row
    // norm and fill per row: invariant under a symmetric renumbering up to ties), so BiCGSTAB takes the same
    // iterations (±1 for rounding) and no factorisation. Then a change with 5 % new unknowns (the map gives
    // −1: a Jacobi step there) is kept and converges to u; one with 20 % new unknowns (above
    // ilut_reuse_unmatched = 10 %) and a solver without the option factorise.
    const int g = 30, n = g * g;
    const ppe::matrix A = convection_diffusion(g);
    const Eigen::VectorXd u = known_solution(n);
    // new index r holds old unknown perm[r]: a fixed pseudo-random permutation
    std::vector<index_t> perm(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) perm[static_cast<std::size_t>(k)] = k;
    for (int k = n - 1; k > 0; --k)
      std::swap(perm[static_cast<std::size_t>(k)], perm[static_cast<std::size_t>((k * 7919) % (k + 1))]);
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, std::ptrdiff_t> P(n);
    for (int r = 0; r < n; ++r) P.indices()[perm[static_cast<std::size_t>(r)]] = r;  // old k -> new row
    const ppe::matrix Ap = P * A * P.transpose();
    const Eigen::VectorXd up = P * u;
    ppe::solver_params sp;
    sp.ilut_reuse_across_changes = true;
    const auto row = [](index_t) { return std::string("row"); };
    ppe::bicgstab solver(sp);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    const auto r0 = ppe::solve_checked(solver, A, Eigen::VectorXd(A * u), x, sp, 0, 0.0, row);
    Eigen::VectorXd xp = Eigen::VectorXd::Zero(n);
    const auto r1 =
        ppe::solve_checked(solver, Ap, Eigen::VectorXd(Ap * up), xp, sp, 1, 0.0, row, false, &perm);
    CHECK(solver.factorisations() == 1);
    CHECK(solver.mapped_reuses() == 1);
    MESSAGE("original: " << r0.iterations
                         << " iterations; renumbered with the mapped factors: " << r1.iterations);
    CHECK(std::abs(r1.iterations - r0.iterations) <= 1);
    CHECK((xp - up).norm() <= 1e-5 * up.norm());  // condition ≈ 160: see the next case
    // 5 % of the unknowns unmatched (as new particles would be): kept, Jacobi on those rows, converged.
    std::vector<index_t> some = perm;
    for (int r = 0; r < n; r += 20) some[static_cast<std::size_t>(r)] = -1;
    Eigen::VectorXd x2 = Eigen::VectorXd::Zero(n);
    ppe::solve_checked(solver, Ap, Eigen::VectorXd(Ap * up), x2, sp, 2, 0.0, row, false, &some);
    CHECK(solver.factorisations() == 1);
    CHECK(solver.mapped_reuses() == 2);
    CHECK((x2 - up).norm() <= 1e-5 * up.norm());
    // 20 % unmatched: factorised.
    std::vector<index_t> many = perm;
    for (int r = 0; r < n; r += 5) many[static_cast<std::size_t>(r)] = -1;
    ppe::bicgstab other(sp);
    Eigen::VectorXd x3 = Eigen::VectorXd::Zero(n);
    ppe::solve_checked(other, A, Eigen::VectorXd(A * u), x3, sp, 0, 0.0, row);
    ppe::solve_checked(other, Ap, Eigen::VectorXd(Ap * up), x3, sp, 1, 0.0, row, false, &many);
    CHECK(other.factorisations() == 2);
    CHECK(other.mapped_reuses() == 0);
    // Without the option the map is ignored: factorised.
    ppe::solver_params off;
    ppe::bicgstab plain(off);
    Eigen::VectorXd x4 = Eigen::VectorXd::Zero(n);
    ppe::solve_checked(plain, A, Eigen::VectorXd(A * u), x4, off, 0, 0.0, row);
    ppe::solve_checked(plain, Ap, Eigen::VectorXd(Ap * up), x4, off, 1, 0.0, row, false, &perm);
    CHECK(plain.factorisations() == 2);
    // Bad input.
    ppe::solver_params bad;
    bad.ilut_reuse_unmatched = 1.5;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("ilut_reuse_unmatched"), mpskit::error);
  }

  TEST_CASE(
      "solver: a lagged ILUT is kept for ilut_reuse solves of the same unknowns, and refactorised on "
      "failure") {
    // A non-symmetric convection-diffusion matrix on a 30 × 30 grid (5-point −∇² plus an upwind x-convection
    // of strength s), as the PPE's CSR type; b = A u for a known u, so every accepted solve is checked
    // against u.
    const int g = 30;
    const auto make = [g](double s, const Eigen::VectorXd* rowscale) {
      std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
      const auto id = [g](int i, int j) { return static_cast<std::ptrdiff_t>(i) * g + j; };
      for (int i = 0; i < g; ++i)
        for (int j = 0; j < g; ++j) {
          const double f = rowscale ? (*rowscale)[id(i, j)] : 1.0;
          t.emplace_back(id(i, j), id(i, j), f * (4.0 + s));
          if (i > 0) t.emplace_back(id(i, j), id(i - 1, j), f * (-1.0 - s));
          if (i + 1 < g) t.emplace_back(id(i, j), id(i + 1, j), -f);
          if (j > 0) t.emplace_back(id(i, j), id(i, j - 1), -f);
          if (j + 1 < g) t.emplace_back(id(i, j), id(i, j + 1), -f);
        }
      ppe::matrix A(g * g, g * g);
      A.setFromTriplets(t.begin(), t.end());
      return A;
    };
    Eigen::VectorXd u(g * g);
    for (int k = 0; k < g * g; ++k) u[k] = std::sin(0.37 * k) + 0.01 * k;
    ppe::solver_params sp;
    sp.ilut_reuse = 3;
    ppe::bicgstab solver(sp);
    std::vector<ppe::matrix> As;
    // slowly changing, same unknowns
    for (int k = 0; k < 5; ++k) As.push_back(make(1.0 + 0.05 * k, nullptr));
    std::vector<long> fact;
    for (int k = 0; k < 5; ++k) {
      const Eigen::VectorXd b = As[static_cast<std::size_t>(k)] * u;
      Eigen::VectorXd x = Eigen::VectorXd::Zero(g * g);
      ppe::solve_checked(
          solver, As[static_cast<std::size_t>(k)], b, x, sp, k, 0.0,
          [](index_t) { return std::string("row"); }, k > 0);
      // the accepted solution is the current matrix's: relative residual ≤ 1e-7 (10 × the tolerance) and
      // these matrices' condition numbers are ≈ 160 (measured), so |x − u| ≤ 1.6e-5 |u| is guaranteed; 1e-5
      // holds with margin because BiCGSTAB stops at its own 1e-8 (measured ≤ 3.2e-8 |u|)
      CHECK((x - u).norm() <= 1e-5 * u.norm());
      fact.push_back(solver.factorisations());
    }
    // factorised at solve 0 (no predecessor), kept for solves 1 and 2 (3 uses), refactorised at 3, kept at 4
    CHECK(fact == std::vector<long>{1, 1, 1, 2, 2});
    // Not the same unknowns (or ilut_reuse = 1): factorised every time.
    Eigen::VectorXd x = Eigen::VectorXd::Zero(g * g);
    ppe::solve_checked(
        solver, As[0], Eigen::VectorXd(As[0] * u), x, sp, 5, 0.0, [](index_t) { return std::string("row"); },
        false);
    CHECK(solver.factorisations() == 3);
    // A lagged solve that fails is repeated with fresh factors: rows scaled by factors 1 to 1e4 make the kept
    // factors of the unscaled matrix a poor preconditioner; with the iteration cap at twice what the fresh
    // factors need, the lagged attempt fails and the repeat succeeds.
    Eigen::VectorXd scale(g * g);
    for (int k = 0; k < g * g; ++k) scale[k] = std::pow(10.0, 4.0 * std::abs(std::sin(1.7 * k)));
    const ppe::matrix S = make(1.0, &scale);
    ppe::bicgstab fresh(sp);
    REQUIRE(fresh.compute(S) == Eigen::Success);
    Eigen::VectorXd xf = Eigen::VectorXd::Zero(g * g);
    const ppe::solve_report rf = fresh.solve(S * u, xf);
    REQUIRE(rf.info == Eigen::Success);
    ppe::solver_params capped = sp;
    capped.max_iterations = 2 * rf.iterations + 2;
    ppe::bicgstab lagged(capped);
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(g * g);
    const auto r0 = ppe::solve_checked(lagged, As[0], Eigen::VectorXd(As[0] * u), x0, capped, 0, 0.0,
                                       [](index_t) { return std::string("row"); });
    CHECK(!r0.lagged_retry);  // fresh factors: nothing to retry
    Eigen::VectorXd x1 = Eigen::VectorXd::Zero(g * g);
    const auto r1 = ppe::solve_checked(lagged, S, Eigen::VectorXd(S * u), x1, capped, 1, 0.0,
                                       [](index_t) { return std::string("row"); }, true);
    MESSAGE("fresh factors: " << rf.iterations << " iterations; lagged then fresh: " << r1.iterations);
    CHECK(lagged.refactorised_after_failure() == 1);
    CHECK(r1.lagged_retry);  // the report says so (the LSMPS stepper counts it in
                             // counters().ppe_lagged_retries)
    CHECK(lagged.factorisations() == 2);
    // S's condition number is ≈ 1.7e5, so the accepted residual alone bounds the error by ≈ 2e-2 |u|; the
    // fresh factors reach 1.3e-8 |u| (measured), which 1e-5 checks with margin (a lagged answer gave 5.8e-6)
    CHECK((x1 - u).norm() <= 1e-5 * u.norm());
    // Bad input.
    ppe::solver_params bad;
    bad.ilut_reuse = 0;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("ilut_reuse"), mpskit::error);
    bad = {};
    bad.parallel_min_rows = -1;
    CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("parallel_min_rows"), mpskit::error);
  }

  TEST_CASE(
      "solver: ILU(0) keeps A's pattern, (LU)_ij = a_ij on it, and is the exact LU of a tridiagonal matrix") {
    // Saad 2003 §10.3.2: ILU(0) (Algorithm 10.4) gives L (unit lower) and U on A's pattern with
    // (LU)_ij = a_ij at every stored (i, j); off the pattern LU has the dropped fill. Checked on the
    // non-symmetric convection-diffusion matrix (the fill of the 5-point stencil is at distance g − 1,
    // dropped: LU ≠ A there), the bound 1e-13 max|a| (max|a| = 5) being ≈ 100 × the rounding of the few
    // products in each entry. A tridiagonal matrix has no fill: ILU(0) is its LU, so M⁻¹ b is A⁻¹ b to
    // rounding and BiCGSTAB stops after one iteration.
    const int g = 20, n = g * g;
    const ppe::matrix A = convection_diffusion(g);
    ppe::incomplete_lu0 ilu(A);
    REQUIRE(ilu.info() == Eigen::Success);
    const ppe::matrix& F = ilu.factors();
    // no fill: the factors' pattern is A's, entry for entry
    REQUIRE(F.nonZeros() == A.nonZeros());
    CHECK(std::equal(F.outerIndexPtr(), F.outerIndexPtr() + n + 1, A.outerIndexPtr()));
    CHECK(std::equal(F.innerIndexPtr(), F.innerIndexPtr() + A.nonZeros(), A.innerIndexPtr()));
    Eigen::MatrixXd Lf = Eigen::MatrixXd::Identity(n, n), Uf = Eigen::MatrixXd::Zero(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (ppe::matrix::InnerIterator it(F, i); it; ++it) (it.col() < i ? Lf : Uf)(i, it.col()) = it.value();
    const Eigen::MatrixXd LU = Lf * Uf;
    const Eigen::MatrixXd Ad = Eigen::MatrixXd(A);
    double on = 0.0, off = 0.0;  // largest |LU − A| on A's pattern and off it
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j) {
        const double e = std::abs(LU(i, j) - Ad(i, j));
        if (A.coeff(i, j) != 0.0)
          on = std::max(on, e);
        else
          off = std::max(off, e);
      }
    MESSAGE("ILU(0) of the convection-diffusion matrix: max |LU - A| on A's pattern " << on << ", off it "
                                                                                      << off);
    CHECK(on <= 1e-13 * 5.0);
    CHECK(off > 1e-3);  // the dropped fill: an incomplete factorisation, not the LU
    // M⁻¹ applied by the two sweeps equals (LU)⁻¹ b computed densely.
    const Eigen::VectorXd b = known_solution(n);
    const Eigen::VectorXd z = ilu.solve(b);
    const Eigen::VectorXd zd = LU.lu().solve(b);
    CHECK((z - zd).norm() <= 1e-12 * zd.norm());
    // A CSR matrix whose rows are not sorted by column (possible through Eigen::Map of raw arrays) is sorted
    // first: the same factors. Rows of the 2 × 2 matrix [[4, 1], [2, 3]] stored as (1, 0) and (0, 1).
    {
      std::ptrdiff_t outer[] = {0, 2, 4}, inner[] = {1, 0, 1, 0};
      double val[] = {1.0, 4.0, 3.0, 2.0};
      const Eigen::Map<const ppe::matrix> M(2, 2, 4, outer, inner, val);
      ppe::incomplete_lu0 m(M);
      REQUIRE(m.info() == Eigen::Success);
      CHECK(m.factors().coeff(1, 0) == 0.5);   // l_10 = 2 / 4
      CHECK(m.factors().coeff(1, 1) == 2.5);   // u_11 = 3 − 0.5 × 1
      CHECK(m.factors().coeff(0, 1) == 1.0);
    }
    // Tridiagonal (non-symmetric): the exact LU.
    std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
    for (int i = 0; i < n; ++i) {
      t.emplace_back(i, i, 3.0 + 0.1 * std::sin(i));
      if (i > 0) t.emplace_back(i, i - 1, -1.2);
      if (i + 1 < n) t.emplace_back(i, i + 1, -0.7);
    }
    ppe::matrix T(n, n);
    T.setFromTriplets(t.begin(), t.end());
    ppe::incomplete_lu0 exact(T);
    REQUIRE(exact.info() == Eigen::Success);
    const Eigen::VectorXd u = known_solution(n);
    CHECK((exact.solve(Eigen::VectorXd(T * u)) - u).norm() <= 1e-13 * u.norm());
    ppe::bicgstab_ilu0 s;
    REQUIRE(s.compute(T) == Eigen::Success);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    const ppe::solve_report r = s.solve(T * u, x);
    CHECK(r.info == Eigen::Success);
    CHECK(r.iterations == 1);
    CHECK((x - u).norm() <= 1e-12 * u.norm());
  }

  TEST_CASE(
      "solver: the interleaved product gives Eigen's bits, and BiCGSTAB-Jacobi through it Eigen's iterates") {
    // ppe::add_product sums four rows side by side, each in storage order from 0, then y_i += α tmp_i:
    // Eigen's row-major sparse × dense product, operation for operation. Checked bit for bit against Eigen's
    // own product (y = A x from 0, y −= A x) and against a row-by-row reference for other α, on matrices
    // whose row lengths differ within each block of four (an empty row in some blocks) and whose entries
    // 1e16, 1, −1e16 make any other summation order visible (1e16 + 1 − 1e16 is 0 in this order, 1 in
    // another), for sizes that are and are not multiples of 4. The bits are Eigen's when the compiler does
    // not fuse multiply-adds (the project's builds: no -march, no -mfma); with FMA the two loops are
    // contracted differently and only a bound is checked.
#if defined(__FMA__) || defined(__FP_FAST_FMA)
    const bool fused = true;
#else
    const bool fused = false;
#endif
    const auto same = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
      if (a.size() != b.size()) return false;
      if (fused) return (a - b).cwiseAbs().maxCoeff() <= 1e-12 * std::max(1.0, a.cwiseAbs().maxCoeff());
      return a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * std::size_t(a.size())) == 0;
    };
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> length(1, 12), pick(0, 2);
    const double magnitudes[] = {1e16, 1.0, -1e16};
    for (const int n : {0, 1, 3, 4, 5, 8, 11, 203}) {
      std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
      std::uniform_int_distribution<int> col(0, std::max(0, n - 1));
      for (int i = 0; i < n; ++i) {
        const int m = i % 13 == 12 ? 0 : length(rng);  // every 13th row empty, the others of 1-12 entries
        for (int k = 0; k < m; ++k) t.emplace_back(i, col(rng), magnitudes[pick(rng)] * (1.0 + 0.125 * k));
      }
      ppe::matrix A(n, n);
      A.setFromTriplets(t.begin(), t.end());  // duplicates summed by Eigen: some rows shorter than drawn
      A.makeCompressed();
      Eigen::VectorXd x(n);
      for (int i = 0; i < n; ++i) x[i] = 1.0 + 0.001 * i;
      const Eigen::VectorXd y0 = Eigen::VectorXd::LinSpaced(n, -3.0, 5.0);
      Eigen::VectorXd eig(n), mine = Eigen::VectorXd::Zero(n);
      eig.noalias() = A * x;
      ppe::add_product(A, x.data(), mine.data(), 1.0);
      CHECK(same(eig, mine));
      const Eigen::VectorXd ax = eig;
      eig = y0;
      eig.noalias() -= A * x;
      mine = y0;
      ppe::add_product(A, x.data(), mine.data(), -1.0);
      CHECK(same(eig, mine));
      Eigen::VectorXd ref = y0;  // row by row, in storage order, y_i += α tmp_i
      for (int i = 0; i < n; ++i) {
        double tmp = 0.0;
        for (ppe::matrix::InnerIterator it(A, i); it; ++it) tmp += it.value() * x[it.col()];
        ref[i] += 0.375 * tmp;
      }
      mine = y0;
      ppe::add_product(A, x.data(), mine.data(), 0.375);
      CHECK(same(ref, mine));
      if (n == 203) {  // the order matters here: a pairwise sum of the rows would differ
        double differ = 0.0;
        for (int i = 0; i < n; ++i) {
          double a = 0.0, b = 0.0;
          int k = 0;
          for (ppe::matrix::InnerIterator it(A, i); it; ++it, ++k)
            (k % 2 ? b : a) += it.value() * x[it.col()];
          differ = std::max(differ, std::abs((a + b) - ax[i]));
        }
        CHECK(differ > 0.0);
      }
    }
    // The solvers: ppe::bicgstab_jacobi and ppe::bicgstab (ILUT) against Eigen's BiCGSTAB with the same
    // preconditioner on the sparse matrix, from 0 and from a warm start (where b − A x₀ goes through the
    // product): the same iterations and the same iterate, bit for bit.
    static_assert(
        std::is_same_v<ppe::bicgstab_jacobi::solver_type::MatrixType, ppe::detail::interleaved_operator>);
    const int g = 30, n = g * g;
    const ppe::matrix A = convection_diffusion(g);
    const Eigen::VectorXd u = known_solution(n);
    const Eigen::VectorXd b = A * u;
    const Eigen::VectorXd warm = 0.9 * u + Eigen::VectorXd::LinSpaced(n, -0.01, 0.02);
    // Eigen's solver e and ours o from x0: the same iterations and the same iterate; returns the iterations.
    const auto compare = [&](auto& e, auto& o, const Eigen::VectorXd& x0) {
      e.setTolerance(1e-8);
      e.compute(A);
      const Eigen::VectorXd xe = e.solveWithGuess(b, x0);
      REQUIRE(o.compute(A) == Eigen::Success);
      Eigen::VectorXd xo = x0;
      const ppe::solve_report r = o.solve(b, xo);
      REQUIRE(r.info == Eigen::Success);
      CHECK(r.iterations == e.iterations());
      CHECK(same(xe, xo));
      return r.iterations;
    };
    for (const Eigen::VectorXd& x0 : {Eigen::VectorXd(Eigen::VectorXd::Zero(n)), warm}) {
      Eigen::BiCGSTAB<ppe::matrix, Eigen::DiagonalPreconditioner<double>> eigen_jacobi;
      ppe::bicgstab_jacobi jacobi;
      CHECK(compare(eigen_jacobi, jacobi, x0) > 10);  // a real iteration (measured 47 from 0)
      Eigen::BiCGSTAB<ppe::matrix, Eigen::IncompleteLUT<double, std::ptrdiff_t>> eigen_ilut;
      eigen_ilut.preconditioner().setDroptol(ppe::solver_params{}.ilut_drop_tolerance);
      eigen_ilut.preconditioner().setFillfactor(ppe::solver_params{}.ilut_fill_factor);
      ppe::bicgstab ilut;
      compare(eigen_ilut, ilut, x0);
    }
  }

  TEST_CASE("solver: ppe::incomplete_lut gives Eigen's ILUT factors and solves bit for bit") {
    // ppe/ilut.hpp re-implements Eigen's IncompleteLUT::factorize (a heap for the elimination order, each
    // row's diagonal position kept) with Eigen's operations in Eigen's order, and the solve with Eigen's
    // sweeps reading those positions: the stored factors (row starts, column indices in their stored order,
    // values) must equal Eigen's exactly, and so must the solves. Matrices: a 3D-like non-symmetric one (a
    // 27-point pattern on a 7³ grid with random weights, about 10 % of the pattern missing, every 17th
    // diagonal zero) whose elimination fills and drops, under Eigen's defaults (drop 1e-12, fill 10), the
    // library's (1e-4, 2), the 3D duct's (1e-3, 2) and no dropping at fill 1, also given uncompressed and
    // column-major; the 2D convection-diffusion matrix; a 2 × 2 matrix with a zero pivot in either order
    // (Eigen's shift to √droptol × the row norm). One of our objects is reused across all of them, after a
    // failed factorisation too. Under FMA contraction the two loops may be contracted differently: a bound.
#if defined(__FMA__) || defined(__FP_FAST_FMA)
    const bool fused = true;
#else
    const bool fused = false;
#endif
    const auto same_values = [&](const double* a, const double* b, std::ptrdiff_t n) {
      if (n == 0) return true;
      if (!fused) return std::memcmp(a, b, sizeof(double) * std::size_t(n)) == 0;
      for (std::ptrdiff_t k = 0; k < n; ++k)
        if (!(std::abs(a[k] - b[k]) <= 1e-10 * std::max(1.0, std::abs(a[k])))) return false;  // NaN fails
      return true;
    };
    // The protected factors of either class.
    struct eigen_peek : Eigen::IncompleteLUT<double, std::ptrdiff_t> {
      const auto& lu() const { return m_lu; }
    };
    struct ours_peek : ppe::incomplete_lut {
      const auto& lu() const { return m_lu; }
    };
    ours_peek reused;
    const auto check_same = [&](const auto& A, double drop, int fill) {
      CAPTURE(A.rows());
      CAPTURE(drop);
      CAPTURE(fill);
      eigen_peek e;
      ours_peek o;
      e.setDroptol(drop);
      e.setFillfactor(fill);
      o.setDroptol(drop);
      o.setFillfactor(fill);
      reused.setDroptol(drop);
      reused.setFillfactor(fill);
      e.compute(A);
      o.compute(A);
      reused.compute(A);
      REQUIRE(e.info() == Eigen::Success);
      const Eigen::VectorXd b = known_solution(int(A.rows()));
      const Eigen::VectorXd xe = e.solve(b);
      const auto& le = e.lu();
      REQUIRE(le.isCompressed());
      for (const ours_peek* q : {&o, &reused}) {
        REQUIRE(q->info() == Eigen::Success);
        const auto& lo = q->lu();
        REQUIRE(lo.isCompressed());
        REQUIRE(lo.nonZeros() == le.nonZeros());
        CHECK(std::equal(le.outerIndexPtr(), le.outerIndexPtr() + le.rows() + 1, lo.outerIndexPtr()));
        CHECK(std::equal(le.innerIndexPtr(), le.innerIndexPtr() + le.nonZeros(), lo.innerIndexPtr()));
        CHECK(same_values(le.valuePtr(), lo.valuePtr(), le.nonZeros()));
        const Eigen::VectorXd xo = q->solve(b);
        CHECK(same_values(xe.data(), xo.data(), xe.size()));
      }
      return std::vector<double>(le.valuePtr(), le.valuePtr() + le.nonZeros());
    };
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> weight(0.2, 1.0);
    std::uniform_int_distribution<int> keep(0, 9);
    const int g = 7;
    const auto id = [g](int i, int j, int k) { return (static_cast<std::ptrdiff_t>(i) * g + j) * g + k; };
    std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
    for (int i = 0; i < g; ++i)
      for (int j = 0; j < g; ++j)
        for (int k = 0; k < g; ++k) {
          double sum = 0.0;
          for (int di = -1; di <= 1; ++di)
            for (int dj = -1; dj <= 1; ++dj)
              for (int dk = -1; dk <= 1; ++dk) {
                const int a = i + di, b = j + dj, c = k + dk;
                if ((di == 0 && dj == 0 && dk == 0) || a < 0 || b < 0 || c < 0 || a >= g || b >= g || c >= g)
                  continue;
                if (keep(rng) == 0) continue;  // about 10 % of the pattern missing: a non-symmetric pattern
                const double w = weight(rng);
                t.emplace_back(id(i, j, k), id(a, b, c), -w);
                sum += w;
              }
          // every 17th diagonal zero, the others near the off-diagonal sum: weakly dominant, so elimination
          // produces fill of every size
          if (id(i, j, k) % 17 != 5) t.emplace_back(id(i, j, k), id(i, j, k), 1.05 * sum);
        }
    ppe::matrix A3(g * g * g, g * g * g);
    A3.setFromTriplets(t.begin(), t.end());
    const std::size_t full = check_same(A3, 1e-12, 10).size();
    const std::size_t library =
        check_same(A3, ppe::solver_params{}.ilut_drop_tolerance, ppe::solver_params{}.ilut_fill_factor)
            .size();
    check_same(A3, 1e-3, 2);
    check_same(A3, 0.0, 1);
    CHECK(full > 2 * std::size_t(A3.nonZeros()));  // the factorisation did fill (Eigen's defaults) ...
    CHECK(library < full);                          // ... and the library's setting dropped
    ppe::matrix U3 = A3;  // the same matrix uncompressed (room left in its rows), and column-major
    U3.reserve(Eigen::VectorXi::Constant(U3.outerSize(), 2));
    REQUIRE(!U3.isCompressed());
    check_same(U3, 1e-4, 2);
    const Eigen::SparseMatrix<double, Eigen::ColMajor, std::ptrdiff_t> C3 = A3;
    check_same(C3, 1e-4, 2);
    check_same(convection_diffusion(30), 1e-4, 2);
    // [[0, 1], [·, 1]] (a stored 0 on the first diagonal, nothing at (1, 0)): in either order AMD may give,
    // the row with the zero diagonal keeps it through elimination (in the given order it has no lower entry;
    // swapped, its multiplier meets an empty U row), so Eigen shifts it to √droptol × |row| = 0.01 × 1:
    // asserted to happen.
    ppe::matrix P2(2, 2);
    P2.insert(0, 0) = 0.0;
    P2.insert(0, 1) = 1.0;
    P2.insert(1, 1) = 1.0;
    P2.makeCompressed();
    const std::vector<double> v2 = check_same(P2, 1e-4, 2);
    CHECK(std::count(v2.begin(), v2.end(), 0.01) == 1);
    // A zero row: NumericalIssue, as Eigen; the reused object factorises the next matrix as a fresh one does.
    ppe::matrix Z(3, 3);
    Z.insert(0, 0) = 1.0;
    Z.insert(2, 2) = 1.0;
    Z.makeCompressed();
    CHECK(Eigen::IncompleteLUT<double, std::ptrdiff_t>(Z).info() == Eigen::NumericalIssue);
    reused.compute(Z);
    CHECK(reused.info() == Eigen::NumericalIssue);
    check_same(convection_diffusion(7), 1e-4, 2);
    // An empty system: empty factors and an empty solve (Eigen's factorize would divide by zero).
    const ppe::matrix E(0, 0);
    const ppe::incomplete_lut empty(E);
    CHECK(empty.info() == Eigen::Success);
    CHECK(empty.solve(Eigen::VectorXd(0)).size() == 0);
    // GMRES (the other ILUT solver) against Eigen's GMRES with Eigen's ILUT, restart 50 as ours: the same
    // iterations and iterate.
    const ppe::matrix A = convection_diffusion(30);
    const Eigen::VectorXd u = known_solution(900);
    const Eigen::VectorXd rhs = A * u;
    Eigen::GMRES<ppe::matrix, Eigen::IncompleteLUT<double, std::ptrdiff_t>> eigen_gmres;
    eigen_gmres.set_restart(50);
    eigen_gmres.setTolerance(ppe::solver_params{}.tolerance);
    eigen_gmres.setMaxIterations(ppe::solver_params{}.max_iterations);
    eigen_gmres.preconditioner().setDroptol(ppe::solver_params{}.ilut_drop_tolerance);
    eigen_gmres.preconditioner().setFillfactor(ppe::solver_params{}.ilut_fill_factor);
    eigen_gmres.compute(A);
    const Eigen::VectorXd xe = eigen_gmres.solve(rhs);
    ppe::gmres ours;
    REQUIRE(ours.compute(A) == Eigen::Success);
    Eigen::VectorXd xo = Eigen::VectorXd::Zero(900);
    const ppe::solve_report r = ours.solve(rhs, xo);
    REQUIRE(r.info == Eigen::Success);
    CHECK(r.iterations == eigen_gmres.iterations());
    CHECK(r.iterations > 1);
    CHECK(same_values(xe.data(), xo.data(), 900));
  }

  TEST_CASE("solver: BiCGSTAB-ILU(0) converges in fewer iterations than Jacobi; zero pivots are refused") {
    // The 30 × 30 convection-diffusion matrix (condition ≈ 160, the lagged-ILUT case's matrix): an accepted
    // solve has a true relative residual ≤ 1e-7 (10 × the tolerance), so |x − u| ≤ 1.6e-5 |u|. ILU(0) at most
    // half Jacobi's iterations (measured 14 against 47; on the LSMPS dam-break PPE the factor is 5.2 at 4 mm
    // and 6.4 at 2 mm: docs/performance.md "ILU(0) for the LSMPS PPE").
    static_assert(ppe::LinearSolver<ppe::bicgstab_ilu0> && !ppe::bicgstab_ilu0::requires_symmetric);
    const int g = 30, n = g * g;
    const ppe::matrix A = convection_diffusion(g);
    const Eigen::VectorXd u = known_solution(n);
    const Eigen::VectorXd b = A * u;
    ppe::bicgstab_ilu0 ilu;
    REQUIRE(ilu.compute(A) == Eigen::Success);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    const ppe::solve_report ri = ilu.solve(b, x);
    const auto [rj, xj, rc] = run_bicgstab_jacobi(ppe::solver_params{}, A, b, Eigen::VectorXd::Zero(n));
    MESSAGE("BiCGSTAB iterations: ILU(0) " << ri.iterations << ", Jacobi " << rj.iterations);
    CHECK(ri.info == Eigen::Success);
    CHECK(rj.info == Eigen::Success);
    CHECK((x - u).norm() <= 1.6e-5 * u.norm());
    CHECK(2 * ri.iterations <= rj.iterations);
    // Lagged like ILUT (solver_params::ilut_reuse): the second solve of the same unknowns keeps the factors.
    Eigen::VectorXd x2 = Eigen::VectorXd::Zero(n);
    REQUIRE(ilu.compute(A, true) == Eigen::Success);
    CHECK(ilu.solve(b, x2).info == Eigen::Success);
    CHECK(ilu.factorisations() == 1);
    // A zero pivot (the first diagonal entry 0) or a row without a stored diagonal: NumericalIssue, not
    // factors used silently; the solver's compute reports it.
    std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t{{0, 0, 0.0}, {0, 1, 1.0}, {1, 0, 1.0}, {1, 1, 2.0}};
    ppe::matrix Z(2, 2);
    Z.setFromTriplets(t.begin(), t.end());
    CHECK(ppe::incomplete_lu0(Z).info() == Eigen::NumericalIssue);
    ppe::bicgstab_ilu0 zs;
    CHECK(zs.compute(Z) == Eigen::NumericalIssue);
    t = {{0, 1, 1.0}, {1, 0, 1.0}, {1, 1, 2.0}};
    Z.setFromTriplets(t.begin(), t.end());
    CHECK(ppe::incomplete_lu0(Z).info() == Eigen::NumericalIssue);
    // A pivot that elimination makes zero: [[1, 1], [1, 1]].
    t = {{0, 0, 1.0}, {0, 1, 1.0}, {1, 0, 1.0}, {1, 1, 1.0}};
    Z.setFromTriplets(t.begin(), t.end());
    CHECK(ppe::incomplete_lu0(Z).info() == Eigen::NumericalIssue);
  }

  TEST_CASE("solver: a BiCGSTAB breakdown from the warm start is restarted from 0 (breakdown_restart)") {
    // A = [[1, 2], [0, 1]] (unit diagonal: Jacobi is the identity), b = (1, 0), exact solution (1, 0). From
    // x0 = (−2, 1) the residual is r0 = (1, −1) and v = A r0 = (−1, −1) is orthogonal to the shadow residual
    // r0 (r0ᵀ A r0 = 0: A's symmetric part [[1, 1], [1, 1]] is singular along r0), so BiCGSTAB's first
    // α = ρ / (r0 · v) divides by exactly 0 and the iterate is not finite. From 0, r0 = b and the 2 × 2 solve
    // ends in one iteration, exact. Eigen's own restart (|ρ| small) does not catch this one (ρ = 2).
    ppe::matrix A(2, 2);
    A.insert(0, 0) = 1.0;
    A.insert(0, 1) = 2.0;
    A.insert(1, 1) = 1.0;
    A.makeCompressed();
    const Eigen::Vector2d b(1.0, 0.0), x0(-2.0, 1.0);
    ppe::solver_params off;
    off.breakdown_restart = false;
    ppe::bicgstab_jacobi plain(off);
    REQUIRE(plain.compute(A) == Eigen::Success);
    Eigen::VectorXd xp = x0;
    const ppe::solve_report rp = plain.solve(b, xp);
    CHECK(rp.info == Eigen::NumericalIssue);
    CHECK(!xp.allFinite());
    CHECK(!rp.breakdown_restart);
    CHECK(plain.breakdown_restarts() == 0);
    ppe::solver_params on;  // the default
    REQUIRE(on.breakdown_restart);
    ppe::bicgstab_jacobi restarted(on);
    REQUIRE(restarted.compute(A) == Eigen::Success);
    Eigen::VectorXd x = x0;
    const ppe::solve_report r = restarted.solve(b, x);
    CHECK(r.info == Eigen::Success);
    CHECK(r.breakdown_restart);
    CHECK(r.iterations == 2);  // the broken one and the restart's
    CHECK(x[0] == doctest::Approx(1.0).epsilon(1e-14));
    CHECK(std::abs(x[1]) <= 1e-14);
    CHECK(restarted.breakdown_restarts() == 1);
    // Through ppe::with_fallback (BiCGSTAB-Jacobi, then SparseLU), from x0: the report and the solution.
    const auto with_lu = [&](const ppe::solver_params& sp) {
      ppe::with_fallback<ppe::bicgstab_jacobi, ppe::sparse_lu> fb(sp);
      REQUIRE(fb.compute(A) == Eigen::Success);
      Eigen::VectorXd xf = x0;
      const ppe::solve_report rf = fb.solve(b, xf);
      CHECK(fb.fallbacks() == (rf.fallback ? 1 : 0));
      return std::pair{rf, xf};
    };
    // The restart succeeds first, so the fallback is not used; the flag passes on.
    const auto [rf, xf] = with_lu(on);
    CHECK(rf.breakdown_restart);
    CHECK(!rf.fallback);
    // Capped at one iteration, which the broken attempt used: the restart is the solve from 0 with a fresh
    // budget (since 2026-12-06; before, it had none left and the LU solved), and one iteration from 0 is
    // exact.
    ppe::solver_params one = on;
    one.max_iterations = 1;
    const auto [r1, x1] = with_lu(one);
    CHECK(!r1.fallback);
    CHECK(r1.breakdown_restart);
    CHECK(r1.iterations == 2);
    CHECK(x1[0] == doctest::Approx(1.0).epsilon(1e-14));
    CHECK(std::abs(x1[1]) <= 1e-14);
    // b = (1, −1) breaks down from 0 too (r0 = b, A b = (−1, −1) ⟂ b): from x0 = (−3, 1) (r0 = (2, −2)) the
    // restart fails as well and the error says both; from 0 there is no restart (it would repeat the solve).
    const Eigen::Vector2d b2(1.0, -1.0), x2(-3.0, 1.0);
    const auto row = [](index_t r) { return "row " + std::to_string(r); };
    ppe::bicgstab_jacobi twice(on);
    Eigen::VectorXd xt = x2;
    std::string message;
    try {
      ppe::solve_checked(twice, A, b2, xt, on, 4, 0.0, row);
    } catch (const mpskit::error& e) {
      message = e.what();
    }
    CHECK(message.find("broke down at step 4") != std::string::npos);
    CHECK(message.find("also after a restart from 0") != std::string::npos);
    CHECK(twice.breakdown_restarts() == 1);
    // Through with_fallback the LU then solves it (b2 is solvable: x = (3, −1)), and the report keeps the
    // flag.
    {
      ppe::with_fallback<ppe::bicgstab_jacobi, ppe::sparse_lu> fb(on);
      REQUIRE(fb.compute(A) == Eigen::Success);
      Eigen::VectorXd xf2 = x2;
      const ppe::solve_report rf2 = fb.solve(b2, xf2);
      CHECK(rf2.info == Eigen::Success);
      CHECK(rf2.fallback);
      CHECK(rf2.breakdown_restart);
      CHECK(xf2[0] == doctest::Approx(3.0).epsilon(1e-14));
      CHECK(xf2[1] == doctest::Approx(-1.0).epsilon(1e-14));
    }
    ppe::bicgstab_jacobi cold(on);
    Eigen::VectorXd xz = Eigen::VectorXd::Zero(2);
    CHECK_THROWS_WITH_AS(ppe::solve_checked(cold, A, b2, xz, on, 5, 0.0, row),
                         doctest::Contains("broke down at step 5"), mpskit::error);
    CHECK(cold.breakdown_restarts() == 0);
  }

  TEST_CASE("solver: a breakdown restart is the solve from 0 with a fresh budget, bitwise") {
    // A = diag([[1, 2], [0, 1]], C), C the convection–diffusion matrix (20 × 20 grid), b = A u. From
    // x0 = (−2, 1, u_C) the residual is exactly (1, −1, 0, …) (b_C and C u_C are the same sums), so
    // BiCGSTAB-Jacobi breaks down at its first α as in the 2 × 2 case above, while from 0 it needs k0
    // iterations and ends at an inexact iterate. Capped at k0 the restart converges only with a fresh budget
    // (before 2026-12-06 it had k0 − 1 and failed), and its iterate is bitwise the solve from 0's (one
    // solver, one matrix, one preconditioner).
    const int g = 20, n = g * g + 2;
    const ppe::matrix C = convection_diffusion(g);
    std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t{{0, 0, 1.0}, {0, 1, 2.0}, {1, 1, 1.0}};
    for (int k = 0; k < C.outerSize(); ++k)
      for (ppe::matrix::InnerIterator it(C, k); it; ++it)
        t.emplace_back(it.row() + 2, it.col() + 2, it.value());
    ppe::matrix A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    Eigen::VectorXd u(n);
    u << 1.0, 0.0, known_solution(g * g);
    const Eigen::VectorXd b = A * u;
    Eigen::VectorXd x0 = u;
    x0[0] = -2.0;
    x0[1] = 1.0;
    REQUIRE((b - A * x0).tail(g * g).isZero(0.0));  // the premise: no residual outside the 2 × 2 block
    ppe::solver_params sp;  // the default
    const auto [rz, xz, free] = run_bicgstab_jacobi(sp, A, b, Eigen::VectorXd::Zero(n));
    REQUIRE(rz.info == Eigen::Success);
    CHECK(!rz.breakdown_restart);
    const long k0 = rz.iterations;
    MESSAGE("BiCGSTAB-Jacobi from 0: " << k0 << " iterations");
    REQUIRE(k0 > 2);
    CHECK((xz - u).norm() > 0.0);  // inexact: the bitwise check below can fail
    ppe::solver_params capped = sp;
    capped.max_iterations = k0;
    ppe::solver_params off = capped;
    off.breakdown_restart = false;
    const auto [rp, xp, plain] = run_bicgstab_jacobi(off, A, b, x0);
    CHECK(rp.info == Eigen::NumericalIssue);  // the breakdown
    CHECK(rp.iterations >= 1);
    const auto [r, x, restarted] = run_bicgstab_jacobi(capped, A, b, x0);
    CHECK(r.info == Eigen::Success);
    CHECK(r.breakdown_restart);
    CHECK(!r.cold_restart);
    CHECK(r.iterations == rp.iterations + k0);
    CHECK(x == xz);  // the restart is the solve from 0
    CHECK(restarted.breakdown == 1);
    // Capped at k0 − 1 the restart does not converge either, and it is not restarted again (no cold restart
    // after a breakdown restart: both would start from 0).
    ppe::solver_params short_cap = sp;
    short_cap.max_iterations = k0 - 1;
    const auto [rs, xs, once] = run_bicgstab_jacobi(short_cap, A, b, x0);
    CHECK(rs.info == Eigen::NoConvergence);
    CHECK(rs.breakdown_restart);
    CHECK(!rs.cold_restart);
    CHECK(rs.iterations == rp.iterations + k0 - 1);
    CHECK(once.breakdown == 1);
    CHECK(once.cold == 0);
  }

  TEST_CASE("solver: a warm-started solve that does not converge is repeated from 0 (cold_restart)") {
    // BiCGSTAB-Jacobi on the convection–diffusion matrix (20 × 20 grid), b = A u. From 0 it converges in k0
    // iterations; from a warm start 1e6 |u| off it has 1e6 more to reduce, so capped at k0 iterations it
    // fails. With cold_restart (the default) that failure is repeated from x = 0 with a fresh budget of k0:
    // the same iterations and the same iterate as the solve from 0, bitwise (one solver, one matrix, one
    // preconditioner).
    const int g = 20;
    const ppe::matrix A = convection_diffusion(g);
    const Eigen::VectorXd u = known_solution(g * g);
    const Eigen::VectorXd b = A * u;
    Eigen::VectorXd w(g * g);
    for (int k = 0; k < g * g; ++k) w[k] = std::cos(0.11 * k);
    const Eigen::VectorXd x0 = u + 1e6 * u.norm() / w.norm() * w;
    ppe::solver_params sp;  // the default
    REQUIRE(sp.cold_restart);
    const auto [rz, xz, free] = run_bicgstab_jacobi(sp, A, b, Eigen::VectorXd::Zero(g * g));
    REQUIRE(rz.info == Eigen::Success);
    CHECK(!rz.cold_restart);  // from 0: nothing to restart
    const long k0 = rz.iterations;
    MESSAGE("BiCGSTAB-Jacobi from 0: " << k0 << " iterations");
    ppe::solver_params capped = sp;
    capped.max_iterations = k0;
    ppe::solver_params off = capped;
    off.cold_restart = false;
    const auto [rp, xp, plain] = run_bicgstab_jacobi(off, A, b, x0);
    CHECK(rp.info == Eigen::NoConvergence);
    CHECK(!rp.cold_restart);
    CHECK(plain.cold == 0);
    const auto [r, x, cold] = run_bicgstab_jacobi(capped, A, b, x0);
    CHECK(r.info == Eigen::Success);
    CHECK(r.cold_restart);
    CHECK(!r.breakdown_restart);
    CHECK(r.iterations == rp.iterations + k0);  // the failed attempt's and the restart's
    CHECK(r.residual <= capped.tolerance);
    CHECK(x == xz);  // the restart is the solve from 0
    CHECK(cold.cold == 1);
    // Through ppe::with_fallback (BiCGSTAB-Jacobi, then SparseLU): the restart succeeds first, the flag
    // passes on.
    ppe::with_fallback<ppe::bicgstab_jacobi, ppe::sparse_lu> fb(capped);
    REQUIRE(fb.compute(A) == Eigen::Success);
    Eigen::VectorXd xf = x0;
    const ppe::solve_report rf = fb.solve(b, xf);
    CHECK(rf.cold_restart);
    CHECK(!rf.fallback);
    CHECK(fb.fallbacks() == 0);
    // Capped at 3 iterations the restart fails too and the error says so; from 0 there is no restart.
    ppe::solver_params three = sp;
    three.max_iterations = 3;
    const auto row = [](index_t r) { return "row " + std::to_string(r); };
    ppe::bicgstab_jacobi twice(three);
    Eigen::VectorXd xt = x0;
    CHECK_THROWS_WITH_AS(ppe::solve_checked(twice, A, b, xt, three, 6, 0.0, row),
                         doctest::Contains("(also after a restart from 0, solver_params::cold_restart)"),
                         mpskit::error);
    CHECK(twice.cold_restarts() == 1);
    ppe::bicgstab_jacobi once(three);
    Eigen::VectorXd x3 = Eigen::VectorXd::Zero(g * g);
    CHECK_THROWS_WITH_AS(ppe::solve_checked(once, A, b, x3, three, 7, 0.0, row),
                         doctest::Contains("did not converge at step 7"), mpskit::error);
    CHECK(once.cold_restarts() == 0);
  }

  /// A solver that counts its incomplete factorisations (ppe::detail::eigen_iterative, ppe::with_fallback of
  /// one).
  template <class S>
  concept counts_factorisations = requires(const S& s) { s.factorisations(); };

  TEST_CASE("solver: with_fallback solves with the direct solver only when the iterative one fails") {
    // ppe/fallback.hpp with BiCGSTAB-Jacobi and Eigen's SparseLU on a non-symmetric convection-diffusion
    // matrix (20 × 20 grid), b = A u for a known u.
    const int g = 20;
    const ppe::matrix A = convection_diffusion(g);
    const Eigen::VectorXd u = known_solution(g * g);
    const Eigen::VectorXd b = A * u;
    const auto row = [](index_t r) { return "row " + std::to_string(r); };
    using solver = ppe::with_fallback<ppe::bicgstab_jacobi, ppe::sparse_lu>;
    static_assert(ppe::LinearSolver<solver> && !solver::requires_symmetric);
    // Converging: the fallback is not used (and not factorised).
    ppe::solver_params sp;
    solver ok(sp);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(g * g);
    const ppe::solve_report r0 = ppe::solve_checked(ok, A, b, x, sp, 0, 0.0, row);
    CHECK(!r0.fallback);
    CHECK(r0.iterations > 1);
    CHECK(ok.fallbacks() == 0);
    // Capped at 1 iteration, BiCGSTAB fails and SparseLU solves: the error bound is the residual check (1e-8)
    // times the condition number (this matrix: ≈ 40, diagonally dominant), so 1e-6 |u| cannot be met by the
    // failed iterate (measured below) and is met with margin by the LU (measured ≈ 1e-15).
    ppe::solver_params capped = sp;
    capped.max_iterations = 1;
    ppe::bicgstab_jacobi alone(capped);
    Eigen::VectorXd xa = Eigen::VectorXd::Zero(g * g);
    REQUIRE(alone.compute(A) == Eigen::Success);
    const ppe::solve_report ra = alone.solve(b, xa);
    REQUIRE(ra.info != Eigen::Success);
    solver fb(capped);
    Eigen::VectorXd xf = Eigen::VectorXd::Zero(g * g);
    const ppe::solve_report rf = ppe::solve_checked(fb, A, b, xf, capped, 1, 0.0, row);
    MESSAGE("capped BiCGSTAB error " << (xa - u).norm() / u.norm() << ", after the fallback "
                                     << (xf - u).norm() / u.norm() << " (residual " << rf.residual << ")");
    CHECK((xa - u).norm() > 1e-6 * u.norm());
    CHECK(rf.fallback);
    CHECK(rf.iterations == 1);  // the primary's, reported with the fallback's 0
    CHECK(rf.residual <= capped.tolerance);
    CHECK((xf - u).norm() <= 1e-6 * u.norm());
    CHECK(fb.fallbacks() == 1);
    // A singular system (two equal rows) still fails, and the message says the fallback failed too.
    ppe::matrix S = A;
    for (std::ptrdiff_t k = S.outerIndexPtr()[1]; k < S.outerIndexPtr()[2]; ++k) S.valuePtr()[k] = 0.0;
    for (std::ptrdiff_t k = S.outerIndexPtr()[0]; k < S.outerIndexPtr()[1]; ++k)
      S.coeffRef(1, S.innerIndexPtr()[k]) = S.valuePtr()[k];
    S.makeCompressed();
    Eigen::VectorXd xs = Eigen::VectorXd::Zero(g * g);
    CHECK_THROWS_WITH_AS(ppe::solve_checked(fb, S, b, xs, capped, 2, 0.0, row),
                         doctest::Contains("the fallback solver failed too"), mpskit::error);
    CHECK(fb.fallbacks() == 2);
    // A non-finite iterate is named as a breakdown at its first non-finite unknown (not a "largest
    // residual").
    Eigen::VectorXd bn = b;
    bn[5] = std::nan("");
    Eigen::VectorXd xn = Eigen::VectorXd::Zero(g * g);
    ppe::bicgstab_jacobi plain(sp);
    CHECK_THROWS_WITH_AS(ppe::solve_checked(plain, A, bn, xn, sp, 3, 0.0, row),
                         doctest::Contains("broke down at step 3"), mpskit::error);
    // The incomplete factorisations are the primary's, counted through with_fallback (the LSMPS stepper's
    // counters().ppe_factorisations reads them there): none for Jacobi; a primary without the count (a direct
    // solver) gives with_fallback none either.
    CHECK(ok.factorisations() == 0);
    static_assert(!counts_factorisations<ppe::with_fallback<ppe::sparse_lu, ppe::sparse_lu>>);
    using ilu_fb = ppe::with_fallback<ppe::bicgstab_ilu0, ppe::sparse_lu>;
    static_assert(counts_factorisations<ilu_fb>);
    ilu_fb fi(sp);
    Eigen::VectorXd xi = Eigen::VectorXd::Zero(g * g);
    CHECK(!ppe::solve_checked(fi, A, b, xi, sp, 4, 0.0, row).fallback);
    CHECK(fi.factorisations() == 1);
    Eigen::VectorXd xi2 = Eigen::VectorXd::Zero(g * g);
    CHECK(!ppe::solve_checked(fi, A, b, xi2, sp, 5, 0.0, row).fallback);  // new unknowns: factorised again
    CHECK(fi.factorisations() == 2);
    CHECK(fi.factorisations() == fi.primary().factorisations());
    ilu_fb fc(capped);  // capped at one iteration: the LU solves, the ILU(0) factors were still made once
    Eigen::VectorXd xc = Eigen::VectorXd::Zero(g * g);
    CHECK(ppe::solve_checked(fc, A, b, xc, capped, 6, 0.0, row).fallback);
    CHECK(fc.factorisations() == 1);
    CHECK(fc.fallbacks() == 1);
  }
}

TEST_SUITE("bad_input") {
  TEST_CASE("solver: a fixed dt above the Courant limit is refused naming step and particle") {
    cases::dam_break_config cfg;
    auto p = cfg.params;
    p.l0 = cfg.l0;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_max = 1e-2;
    p.time.dt_fixed = 5e-3;  // at rest the limit is dt_max; at ~0.15 m/s, 0.1 l0/u < 5e-3 s
    simulation<defaults<2>> sim(
        p, cases::tank_state<2>(vec<2>(cfg.a, 2 * cfg.a), vec<2>(4 * cfg.a, 2.5 * cfg.a), cfg.l0));
    CHECK_THROWS_WITH_AS(sim.run_until(1.0), doctest::Contains("fixed dt = 0.005"), mpskit::error);
    CHECK_THROWS_WITH_AS(sim.run_until(1.0), doctest::Contains("limiting particle"), mpskit::error);
    CHECK(sim.counters().steps > 0);
  }

  TEST_CASE("solver: a NaN in a field is refused naming the particle") {
    auto s = cases::tank_state<2>(vec<2>(0.05, 0.05), vec<2>(0.1, 0.1), 0.005);
    s.template get<field::pressure>()[7] = std::nan("");
    scheme::semi_implicit_params<2> p;
    p.l0 = 0.005;
    CHECK_THROWS_WITH_AS(simulation<defaults<2>>(p, s), doctest::Contains("'pressure' of particle 7"),
                         mpskit::error);
  }

  TEST_CASE("solver: a solver capped at 1 iteration fails with step and residual") {
    scheme::semi_implicit_params<2> p;
    p.l0 = 0.005;
    p.solver.max_iterations = 1;
    simulation<defaults<2>> sim(p, cases::tank_state<2>(vec<2>(0.05, 0.05), vec<2>(0.1, 0.1), 0.005));
    CHECK_THROWS_WITH_AS(sim.step(), doctest::Contains("did not converge at step 0"), mpskit::error);
  }

  TEST_CASE("solver: bad numbers are refused with one line each") {
    scheme::semi_implicit_params<2> p;
    p.l0 = -1.0;
    p.rho = 0.0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("semi_implicit_params.l0 = -1"), mpskit::error);
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("semi_implicit_params.rho = 0"), mpskit::error);
  }
}

TEST_SUITE("solver_threads") {
  TEST_CASE("solver: the interleaved product is bitwise the same on 1 and 2 threads (above 20 000 entries)") {
#ifdef _OPENMP
    // Eigen's rule: more than one Eigen thread and more than 20 000 entries share the blocks of four rows
    // among the threads; each row is one thread's, so the bits do not change. 2003 rows (not a multiple of
    // 4).
    const int n = 2003;
    std::vector<Eigen::Triplet<double, std::ptrdiff_t>> t;
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < 12 + i % 7; ++k)
        t.emplace_back(i, (i * 31 + k * 97) % n, std::sin(0.1 * i + k) * 1e3);
    ppe::matrix A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    A.makeCompressed();
    REQUIRE(A.nonZeros() > 20000);
    const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
    const int before = Eigen::nbThreads();
    Eigen::VectorXd one = Eigen::VectorXd::Zero(n), two = Eigen::VectorXd::Zero(n);
    Eigen::setNbThreads(1);
    ppe::add_product(A, x.data(), one.data(), 1.0);
    Eigen::setNbThreads(2);
    ppe::add_product(A, x.data(), two.data(), 1.0);
    Eigen::setNbThreads(before == max_threads() ? 0 : before);
    CHECK(std::memcmp(one.data(), two.data(), sizeof(double) * std::size_t(n)) == 0);
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
  TEST_CASE("solver: results are bitwise identical for 1 and 2 threads") {
#ifdef _OPENMP
    // The defaults and the quiet configuration (its band filter reads every velocity before writing any), at
    // l0 = a/40: loops shorter than exec::parallel_min_items run sequentially, so the case must be larger
    // (the a/20 case, 1358 particles, compared two sequential runs).
    auto run = []<class Scene>(int threads, Scene, bool quiet) {
      omp_set_num_threads(threads);
      cases::dam_break_config cfg;
      cfg.l0 = cfg.a / 40;
      auto p = quiet ? scheme::quiet_params<2>(cfg.params) : cfg.params;
      p.l0 = cfg.l0;
      simulation<Scene> sim(
          p, cases::tank_state<2>(vec<2>(cfg.a, 2 * cfg.a), vec<2>(4 * cfg.a, 2.5 * cfg.a), cfg.l0));
      REQUIRE(sim.state().n_real() >= parallel_min_items);
      for (int k = 0; k < 60; ++k) sim.step();
      return std::make_pair(points<2>(sim.state().x()),
                            Eigen::VectorXd(sim.state().template get<field::pressure>()));
    };
    const auto a = run(1, defaults<2>{}, false), b = run(2, defaults<2>{}, false);
    CHECK((a.first.array() == b.first.array()).all());
    CHECK((a.second.array() == b.second.array()).all());
    const auto qa = run(1, quiet_defaults<2>{}, true), qb = run(2, quiet_defaults<2>{}, true);
    CHECK((qa.first.array() == qb.first.array()).all());
    CHECK((qa.second.array() == qb.second.array()).all());
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
}
