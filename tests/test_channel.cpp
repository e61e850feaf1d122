// Channel flows (issue #8): periodic Poiseuille between polygon walls (label poiseuille) and periodic
// unit tests (label periodic); checkpoint and restart of the LSMPS scheme on the multi-resolution
// multi-diameter channel (label restart: split/merge, pressure faces and walls in one scene).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "cases/channel_options.hpp"
#include "cases/duct.hpp"
#include "cases/multi_diameter_channel.hpp"
#include "cases/pipe.hpp"
#include "cases/poiseuille.hpp"
#include "cases/taylor_green.hpp"
#include "mpskit/io/lsmps_checkpoint.hpp"
#include "mpskit/io/simulation_checkpoint.hpp"
#include "mpskit/resolution/split_merge.hpp"
#include "support/support.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

using namespace mpskit;

TEST_SUITE("poiseuille") {
  TEST_CASE("channel: periodic Poiseuille between polygon walls, body force G/rho (Tanaka 2018 §5.2, D1)") {
    cases::poiseuille_config c;
    const auto r = cases::run_poiseuille_periodic(c);
    for (const auto& pr : r.probes)
      std::printf("poiseuille periodic t = %.4f s: max err %.4f rms %.4f |v|max %.2e\n", pr.t, pr.max_error,
                  pr.rms_error, pr.max_cross);
    std::printf(
        "poiseuille periodic end t = %.4f: series err %.4f, steady err %.4f, centre %.5f m/s, steps %ld, "
        "guarded %ld, pinned %ld, iterations %ld, %lld particles, %.1f s\n",
        r.end.t, r.end.max_error, r.steady_error, r.centre_velocity, r.steps, r.guarded, r.pinned,
        r.ppe_iterations, static_cast<long long>(r.particles), r.wall_seconds);
    // Issue #8: the profile within 2 % of the analytic steady profile (u_max = G H²/(8μ) = 0.125 m/s). At
    // t = 0.5 s the slowest mode of the start-up (time constant H²/(π²ν) = 0.10 s) still holds 0.7 % of
    // u_max, so the steady comparison measures 0.76 %; against the series it is 0.02 %.
    CHECK(r.steady_error <= 0.02);
    CHECK(r.end.max_error <= 0.01);
    // The start-up transient against the series at 0.05 s and 0.1 s (half and one time constant): measured
    // 0.13 % and 0.17 % of u_max (row averages, 20 rows); 1 % leaves room for rounding and platform.
    REQUIRE(r.probes.size() == 2);
    for (const auto& pr : r.probes) {
      CAPTURE(pr.t);
      CHECK(pr.max_error <= 0.01);
      CHECK(pr.max_cross <= 1e-3);  // measured 2.6e-5: the flow stays parallel
    }
    CHECK(r.guarded == 0);
    CHECK(r.pinned == r.steps);  // the periodic channel's PPE has no Dirichlet row: pinned every step

    // The same channel mirrored (flow along y, periodic in y, walls at x = 0 and x = H) to 0.1 s: the same
    // transient errors (the mirrored lattice is the same problem; only the cell order differs).
    cases::poiseuille_config cy = c;
    cy.axis = 1;
    cy.t_end = 0.1;
    cy.probe_times = {0.05};
    const auto ry = cases::run_poiseuille_periodic(cy);
    std::printf("poiseuille periodic in y: t = %.4f max err %.4f; t = %.4f max err %.4f\n", ry.probes[0].t,
                ry.probes[0].max_error, ry.end.t, ry.end.max_error);
    CHECK(ry.probes[0].max_error == doctest::Approx(r.probes[0].max_error).epsilon(1e-3));
    CHECK(ry.end.max_error == doctest::Approx(r.probes[1].max_error).epsilon(1e-3));
  }
}

TEST_SUITE("poiseuille") {
  TEST_CASE(
      "channel: pressure-driven Poiseuille through pressure inflow/outflow boundaries (Tanaka 2018 §4.5.2)") {
    // Issue #8's CI case: 10 mm × 20 mm, Δp = 20 Pa (G = 1000 Pa/m), ρ = 1000, μ = 0.1 Pa s, L = 0.5 mm, to
    // 0.5 s, profile on the mid-length slice |x − ℓ/2| ≤ 2 L.
    cases::poiseuille_config c;
    c.length = 0.02;
    const auto r = cases::run_poiseuille_pressure(c);
    for (const auto& pr : r.probes)
      std::printf("poiseuille pressure t = %.4f s: max err %.4f rms %.4f |v|max %.2e\n", pr.t, pr.max_error,
                  pr.rms_error, pr.max_cross);
    std::printf(
        "poiseuille pressure end t = %.4f: series err %.4f, steady err %.4f, centre %.5f m/s, p err %.4f, "
        "volume [%.4f, %.4f], in %ld out %ld behind %ld, ledger %.1e, steps %ld, guarded %ld, %.1f s\n",
        r.end.t, r.end.max_error, r.steady_error, r.centre_velocity, r.pressure_error, r.volume_min,
        r.volume_max, r.inflow, r.outflow, r.outflow_behind, r.ledger_error, r.steps, r.guarded,
        r.wall_seconds);
    // The start-up transient against the series at 0.05 s and 0.1 s: measured 0.13 % and 0.14 % of u_max with
    // the normal-tube boundary velocity (0.19 % and 0.56 % with the paper's isotropic mean); 1.5 % leaves
    // room for rounding (the in/outflow events make this run sensitive to the last digit).
    REQUIRE(r.probes.size() == 2);
    for (const auto& pr : r.probes) {
      CAPTURE(pr.t);
      CHECK(pr.max_error <= 0.015);
    }
    // The whole channel is renewed (u ≈ 0.12 m/s for 0.5 s through 20 mm): both boundaries act.
    CHECK(r.inflow > 500);
    CHECK(r.outflow > 500);
    // The volume ledger closes exactly: V(t) − V(0) = V_in − V_out (every creation and removal counted).
    CHECK(r.ledger_error <= 1e-12);
    // Measured 0.95: the spacing of inflow creation (α_J L plus one step's travel) and the empty band
    // within α_o L of the outlet; 0.93 leaves room.
    CHECK(r.volume_min >= 0.93);
    CHECK(r.guarded == 0);
    CHECK(r.pinned == 0);  // Dirichlet boundary rows: nothing floats
    // Issue #8: the mid-length profile within 2 % of the analytic steady profile (u_max 0.125 m/s). Measured
    // 0.85 % (0.11 % against the series at 0.5 s: the slowest mode, time constant H²/(π²ν) = 0.10 s, still
    // holds 0.7 % of u_max); with the paper's isotropic boundary mean 2.9 % (docs/channel.md).
    CHECK(r.steady_error <= 0.02);
    CHECK(r.end.max_error <= 0.01);
    // No pressure lost at the faces: RMS |p − Δp (1 − x/ℓ)| measured 0.6 % of Δp (2.8 % with the isotropic
    // mean, which drags the fluid beside both faces); 2 % separates the two.
    CHECK(r.pressure_error <= 0.02);
  }
}

TEST_SUITE("poiseuille") {
  TEST_CASE("channel: 3D pipe periodic along its axis, body force G/rho, against the Szymanski series") {
    // Issue #8: R = 5 mm, 8 particles per radius (L = 0.625 mm, 1720 particles), period 10 L, 64-facet
    // cylinder, G = 1000 Pa/m, μ = 0.1 Pa s (u_max = G R²/(4μ) = 0.0625 m/s), Δt = 0.1 L²/ν. CI runs to
    // 0.05 s only (128 steps, ≈ 90 s of one core with ILUT-BiCGSTAB); the issue's t = 0.2 s is the example's
    // (`channel --pipe`; docs/channel.md).
    cases::pipe_config c;
    c.t_end = 0.05;
    c.probe_times = {};
    const auto r = cases::run_pipe(c);
    REQUIRE(r.probes.size() == 1);
    std::printf(
        "pipe t = %.4f s: max ring error %.4f rms %.4f; %lld particles, %ld steps, %.0f copies/step, guarded "
        "%ld, %.1f s\n",
        r.probes[0].t, r.probes[0].max_error, r.probes[0].rms_error, static_cast<long long>(r.particles),
        r.steps, r.copies_per_step, r.guarded, r.wall_seconds);
    // Issue #8: within 3 % of u_max (ring averages over 8 rings of width L). Measured 0.52 %.
    CHECK(r.probes[0].max_error <= 0.03);
    CHECK(r.guarded == 0);
  }
}

namespace {

/// The periodic channel of the poiseuille case at rest (g = 0), walls at y = 0 and y = H, flow axis `axis`.
struct channel_at_rest {
  scheme::lsmps_params<2> p;
  geometry::polygon_set<2> walls;
  scheme::lsmps_state<2> s0;
  static channel_at_rest make(double length, double H, double L, int axis) {
    geometry::polygon_mesh<2> m = cases::channel_mesh(0.0, length, H, 8.0 * L);
    scheme::lsmps_state<2> s = cases::channel_state(length, H, L);
    if (axis == 1) cases::mirror_channel(m, s);
    scheme::lsmps_params<2> p;
    p.rho = 1000.0;
    p.nu = 1e-4;
    p.g.setZero();
    p.domain.periodic = {axis == 0, axis == 1};
    p.domain.hi[axis] = length;
    p.domain.hi[1 - axis] = H;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = p.time.dt_max = 2.5e-4;
    p.reorder_every = 0;  // keep the lattice order, to compare with the initial positions
    return {p, geometry::polygon_set<2>(std::move(m)), std::move(s)};
  }
};

/// The channel scene without shifting.
struct rest_no_shift_scene : cases::poiseuille_scene {
  using shifting = scheme::no_regularization;
};

}  // namespace

TEST_SUITE("periodic") {
  TEST_CASE("periodic: neighbours across the seam use the minimum image, in x and in y, copies included") {
    for (int axis : {0, 1}) {
      CAPTURE(axis);
      const double L = 0.5e-3, length = 5e-3, H = 5e-3;
      auto c = channel_at_rest::make(length, H, L, axis);
      simulation<cases::poiseuille_scene> sim(c.p, c.s0, &c.walls);
      sim.step();  // at rest: positions unchanged, the lists and operators of this step are valid at x
      const auto& st = sim.state();
      const auto& nl = sim.neighbours();
      const index_t n = st.n_real();
      long across = 0, copies_across = 0;
      double worst = 0.0;
      for (index_t i = 0; i < st.size(); ++i)
        for (const auto jj : nl.neighbours(i)) {
          const index_t j = static_cast<index_t>(jj);
          vec<2> d = st.x().col(j) - st.x().col(i);
          const bool wraps = std::abs(d[axis]) > 0.5 * length;
          c.p.domain.minimum_image(d);
          worst = std::max(worst, (nl.displacement(st.x(), i, j) - d).norm());
          across += wraps;
          copies_across += wraps && (i >= n || j >= n);
        }
      CHECK(worst <= 1e-15);
      // Particles within R (1 + skin) = 1.86 mm of the seam have partners across it, copies included.
      CHECK(across > 0);
      CHECK(copies_across > 0);
      // Every first-row particle has exactly one copy, also at the seam (the walls overhang the period box).
      CHECK(st.n_ghost() == 2 * std::lround(length / L));
      // The LSMPS gradient of the periodic field sin(2π x/P) is as accurate at the seam as inside.
      Eigen::VectorXd f(st.size());
      const double k = 2.0 * std::numbers::pi / length;
      for (index_t i = 0; i < st.size(); ++i) f[i] = std::sin(k * st.x()(axis, i));
      double err_seam = 0.0, err_inner = 0.0;
      for (index_t i = 0; i < n; ++i) {
        const double xa = st.x()(axis, i), xc = st.x()(1 - axis, i);
        if (xc < 4 * L || xc > H - 4 * L) continue;  // away from the walls
        const double g = sim.op().gradient(st.x(), nl, i, f, [](index_t) { return true; })[axis];
        const double e = std::abs(g - k * std::cos(k * xa)) / k;
        double& slot = xa < 2 * L || xa > length - 2 * L ? err_seam : err_inner;
        slot = std::max(slot, e);
      }
      std::printf(
          "periodic axis %d: %ld pairs across the seam (%ld with copies), gradient error seam %.2e inner "
          "%.2e\n",
          axis, across, copies_across, err_seam, err_inner);
      // On a lattice the stencils at the seam are those inside, translated: the same error up to rounding.
      CHECK(err_seam <= err_inner * (1.0 + 1e-6) + 1e-12);
      CHECK(err_inner > 0.0);
    }
  }

  TEST_CASE("periodic: a periodic box at rest stays at rest, without walls and between walls") {
    {  // doubly periodic box, no walls
      scheme::lsmps_params<2> p;
      p.g.setZero();
      p.domain.periodic = {true, true};
      p.domain.hi = vec<2>(0.5, 0.5);
      p.time.mode = scheme::time_step_mode::fixed;
      p.time.dt_fixed = p.time.dt_max = 1e-3;
      p.reorder_every = 0;
      const auto s0 = cases::channel_state(0.5, 0.5, 0.025);
      simulation<cases::taylor_green_scene> sim(p, s0);
      sim.run_until(0.1);
      const double du = sim.state().u().leftCols(sim.state().n_real()).cwiseAbs().maxCoeff();
      const double dx = (sim.state().x().leftCols(s0.n_real()) - s0.x()).cwiseAbs().maxCoeff();
      std::printf("periodic box at rest: %ld steps, max |u| %.2e m/s, max |dx| %.2e m\n",
                  sim.counters().steps, du, dx);
      CHECK(du <= 1e-12);
      CHECK(dx <= 1e-12);
    }
    for (int axis : {0, 1}) {  // the periodic channel between walls, with and without Tanaka's shifting
      CAPTURE(axis);
      auto c = channel_at_rest::make(5e-3, 5e-3, 0.5e-3, axis);
      const auto run = [&](auto scene_tag, const char* what) {
        using Scene = decltype(scene_tag);
        simulation<Scene> sim(c.p, c.s0, &c.walls);
        sim.run_until(0.05);
        const double du = sim.state().u().leftCols(sim.state().n_real()).cwiseAbs().maxCoeff();
        const double dx = (sim.state().x().leftCols(c.s0.n_real()) - c.s0.x()).cwiseAbs().maxCoeff();
        std::printf("periodic channel at rest (axis %d, %s): %ld steps, max |u| %.2e m/s, max |dx| %.2e m\n",
                    axis, what, sim.counters().steps, du, dx);
        CHECK(du <= 1e-12);
        CHECK(sim.counters().guarded == 0);
        return dx;
      };
      // Without shifting nothing moves. With it the second row from each wall (c = 1.12: the wall copies
      // add to its packing ratio) is pushed 0.1 L toward the centre within 10 steps (α_S L = 0.01 L per
      // step) and stays there; the velocity stays exactly 0 (δu = ∇u δx, eq. 91).
      CHECK(run(rest_no_shift_scene{}, "no shifting") <= 1e-12);
      CHECK(run(cases::poiseuille_scene{}, "shifting") <= 0.11 * 0.5e-3);
    }
  }

  TEST_CASE(
      "periodic: a uniform body force accelerates a translating periodic box uniformly across the seams") {
    // Every particle starts at u0 and feels g: u = u0 + g t exactly (no velocity gradient, no pressure
    // gradient), the lattice moves rigidly through both seams and stays wrapped in the period box.
    scheme::lsmps_params<2> p;
    p.g = vec<2>(2.0, -1.0);
    p.nu = 1e-3;
    p.domain.periodic = {true, true};
    p.domain.hi = vec<2>(0.5, 0.4);
    const double L = 0.025, dt = 1e-3;
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = p.time.dt_max = dt;
    p.reorder_every = 10;  // cell reorders on: ids, not slots, are compared
    auto s0 = cases::channel_state(0.5, 0.4, L);
    const vec<2> u0(1.5, 1.0);
    for (index_t i = 0; i < s0.n_real(); ++i) s0.u().col(i) = u0;
    const points<2> x0 = s0.x();
    simulation<cases::taylor_green_scene> sim(p, s0);
    sim.run_until(0.3);  // x moves by (0.54, 0.255): every particle crosses a seam at least once
    const auto& st = sim.state();
    const double t = sim.time();
    const vec<2> u_exact = u0 + t * p.g;
    const vec<2> shift = u0 * t + 0.5 * p.g * t * t;
    double du = 0.0, dx = 0.0;
    bool inside = true;
    for (index_t i = 0; i < st.n_real(); ++i) {
      du = std::max(du, (st.u().col(i) - u_exact).norm());
      const auto id = static_cast<index_t>(st.ids()[static_cast<std::size_t>(i)]);
      vec<2> d = st.x().col(i) - (x0.col(id) + shift);  // ids are the initial slots
      p.domain.minimum_image(d);
      dx = std::max(dx, d.norm());
      for (int a = 0; a < 2; ++a) inside = inside && st.x()(a, i) >= 0.0 && st.x()(a, i) < p.domain.hi[a];
    }
    std::printf("periodic translating box: %ld steps, max |u - u0 - g t| %.2e, max position error %.2e m\n",
                sim.counters().steps, du, dx);
    CHECK(inside);
    CHECK(du <= 1e-10 * u_exact.norm());
    // Explicit Euler with the corrected velocity: x gains Δt u^{k+1}, so Σ Δt² g/2 = g t Δt/2 beyond the
    // exact shift.
    CHECK(dx <= 0.5 * p.g.norm() * t * dt * (1.0 + 1e-6) + 1e-12);
  }
}

namespace {

/// The 20 mm pressure-driven channel of issue #8 (walls y = 0 and H, inlet x = 0 at Δp, outlet x = ℓ at 0).
struct pressure_channel {
  double H = 0.01, ell = 0.02, L = 0.5e-3, dp = 20.0;
  geometry::polygon_set<2> walls{cases::channel_mesh(0.0, 0.02, 0.01, 4.0 * 0.5e-3)};
  static geometry::polygon_set<2> faces(double H, double ell) {
    geometry::polygon_mesh<2> m;
    m.vertices.resize(2, 4);
    m.vertices.col(0) = vec<2>(0.0, H);
    m.vertices.col(1) = vec<2>(0.0, 0.0);
    m.vertices.col(2) = vec<2>(ell, 0.0);
    m.vertices.col(3) = vec<2>(ell, H);
    m.elements.resize(2, 2);
    m.elements.col(0) << 0, 1;
    m.elements.col(1) << 2, 3;
    return geometry::polygon_set<2>(std::move(m));
  }
  boundary::pressure_boundary<2> pb{faces(0.01, 0.02), {20.0, 0.0}, 0.5e-3};
  scheme::lsmps_params<2> params() const {
    scheme::lsmps_params<2> p;
    p.nu = 1e-4;
    p.g.setZero();
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = p.time.dt_max = 2.5e-4;
    p.reorder_every = 0;
    return p;
  }
};

}  // namespace

TEST_SUITE("pressure_boundary") {
  TEST_CASE(
      "boundary: pressure-boundary particles are placed on the faces with the element normal and pressure") {
    const auto faces = pressure_channel::faces(0.01, 0.02);
    const boundary::pressure_boundary<2> pb(faces, {20.0, 0.0}, 0.5e-3);
    REQUIRE(pb.size() == 40);
    for (index_t k = 0; k < pb.size(); ++k) {
      const bool inlet = pb.element(k) == 0;
      CHECK(pb.x()(0, k) == doctest::Approx(inlet ? 0.0 : 0.02));
      CHECK(pb.normals()(0, k) == doctest::Approx(inlet ? 1.0 : -1.0));  // into the fluid
      CHECK(pb.diameters()[k] == doctest::Approx(0.5e-3));
      CHECK(pb.pressures()[k] == (inlet ? 20.0 : 0.0));
    }
    // A segment that is not a multiple of L: equal pieces no longer than L.
    geometry::polygon_mesh<2> m;
    m.vertices.resize(2, 2);
    m.vertices.col(0) = vec<2>(0.0, 0.0);
    m.vertices.col(1) = vec<2>(1.1e-3, 0.0);
    m.elements.resize(2, 1);
    m.elements.col(0) << 0, 1;
    const boundary::pressure_boundary<2> pb3(geometry::polygon_set<2>(m), {5.0}, 0.5e-3);
    CHECK(pb3.size() == 3);
    CHECK(pb3.diameters()[0] == doctest::Approx(1.1e-3 / 3));
    // 3D: a right triangle with legs 2 L (area 2 L²): n = ⌈√2⌉ = 2, 4 sub-triangles of L_p = 0.71 L, the
    // diameters' squares add up to the area.
    geometry::polygon_mesh<3> t;
    t.vertices.resize(3, 3);
    t.vertices.col(0) = vec<3>(0, 0, 0);
    t.vertices.col(1) = vec<3>(1e-3, 0, 0);
    t.vertices.col(2) = vec<3>(0, 1e-3, 0);
    t.elements.resize(3, 1);
    t.elements.col(0) << 0, 1, 2;
    const boundary::pressure_boundary<3> pt(geometry::polygon_set<3>(t), {1.0}, 0.5e-3);
    CHECK(pt.size() == 4);  // ⌈√(0.5 mm²) / 0.5 mm⌉ = 2 → 4 sub-triangles
    CHECK(pt.diameters().maxCoeff() <= 0.5e-3);
    CHECK(pt.diameters().array().square().sum() == doctest::Approx(0.5e-6));
    CHECK(pt.normals()(2, 0) == doctest::Approx(1.0));
  }

  TEST_CASE("boundary: bad pressure-boundary input is refused with a clear message") {
    const auto faces = pressure_channel::faces(0.01, 0.02);
    CHECK_THROWS_WITH_AS(boundary::pressure_boundary<2>(faces, {20.0}, 0.5e-3),
                         doctest::Contains("1 pressures for 2 face elements"), mpskit::error);
    CHECK_THROWS_AS(boundary::pressure_boundary<2>(faces, {20.0, 0.0}, 0.0), mpskit::error);
    CHECK_THROWS_AS(boundary::pressure_boundary<2>(faces, {20.0, std::nan("")}, 0.5e-3), mpskit::error);
    boundary::pressure_params bad;
    bad.alpha_o = 0.0;
    CHECK_THROWS_WITH_AS(boundary::pressure_boundary<2>(faces, {20.0, 0.0}, 0.5e-3, bad),
                         doctest::Contains("alpha_o"), mpskit::error);
    pressure_channel c;
    CHECK_THROWS_WITH_AS(simulation<cases::poiseuille_pressure_scene>(
                             c.params(), cases::channel_state(c.ell, c.H, c.L), &c.walls),
                         doctest::Contains("no pressure_boundary"), mpskit::error);
    CHECK_THROWS_WITH_AS(simulation<cases::poiseuille_scene>(
                             c.params(), cases::channel_state(c.ell, c.H, c.L), &c.walls, &c.pb),
                         doctest::Contains("without boundary::pressure"), mpskit::error);
  }

  TEST_CASE(
      "boundary: the normal-tube boundary velocity keeps a developed profile the isotropic mean flattens") {
    // Fluid lattice (spacing L, 8 columns × 20 rows) beside the inlet face x = 0 of a 10 mm channel, carrying
    // the steady profile u_x = u(y) = 4 U y (H − y)/H²; the boundary particles sit on the face in line with
    // the rows. The normal tube (half-width L_p) holds only the boundary particle's own row, in which u is
    // constant along the normal: exact. The isotropic mean (Tanaka §4.5.2) flattens the profile by
    // ½ u'' ⟨Δy²⟩_w = −4 U ⟨Δy²⟩_w / H² (u'' = −8 U/H²): at the centre ≈ 1 % of U, the drag that cost the
    // pressure-driven channel 2 % of its flow (docs/channel.md).
    pressure_channel c;
    const double L = c.L, H = c.H, U = 0.125;
    const auto prof = [&](double y) { return 4.0 * U * y * (H - y) / (H * H); };
    const index_t nf = 8 * 20;
    boundary::pressure_params iso;
    iso.velocity = boundary::boundary_velocity::isotropic;
    const boundary::pressure_boundary<2> tube_pb(c.faces(H, c.ell), {0.0, 0.0}, L);
    const boundary::pressure_boundary<2> iso_pb(c.faces(H, c.ell), {0.0, 0.0}, L, iso);
    const index_t nb = tube_pb.size();
    points<2> x(2, nf + nb), u = points<2>::Zero(2, nf + nb);
    for (index_t i = 0; i < 8; ++i)
      for (index_t j = 0; j < 20; ++j) {
        const index_t q = i * 20 + j;
        x.col(q) = vec<2>((i + 0.5) * L, (j + 0.5) * L);
        u(0, q) = prof(x(1, q));
      }
    for (index_t k = 0; k < nb; ++k) x.col(nf + k) = tube_pb.x().col(k);
    Eigen::VectorXd Ls = Eigen::VectorXd::Constant(nf + nb, L);
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::per_particle_radius{&Ls, 3.1});
    const auto all = [](index_t) { return true; };
    double tube_err = 0.0, iso_centre = 0.0;
    for (index_t k = 0; k < nb; ++k) {
      if (tube_pb.normals()(0, k) <= 0.0) continue;  // the inlet face only (normal +x)
      const double y = tube_pb.x()(1, k), exact = prof(y);
      const vec<2> vt = tube_pb.averaged_velocity(x, nl, nf + k, k, nf, Ls, 3.1, u, all);
      const vec<2> vi = iso_pb.averaged_velocity(x, nl, nf + k, k, nf, Ls, 3.1, u, all);
      // rows more than R from the walls: the isotropic mean's stencil is not truncated by the wall there
      if (y > 3.5 * L && y < H - 3.5 * L) tube_err = std::max(tube_err, std::abs(vt[0] - exact) / U);
      if (std::abs(y - 0.5 * H) < 0.5 * L + 1e-12) iso_centre = (vi[0] - exact) / U;
      CHECK(vt[1] == 0.0);  // normal component only (n_p = +x)
    }
    std::printf(
        "boundary velocity of a developed profile: normal tube max err %.2e U, isotropic mean at the centre "
        "%.4f U\n",
        tube_err, iso_centre);
    CHECK(tube_err <= 1e-14);
    CHECK(iso_centre < -0.005);  // the flattening, measured −0.0096 U (sign: slower than the fluid)
    boundary::pressure_params bad;
    bad.tube_width = 0.0;
    CHECK_THROWS_WITH_AS(boundary::pressure_boundary<2>(c.faces(H, c.ell), {0.0, 0.0}, L, bad),
                         doctest::Contains("tube_width"), mpskit::error);
  }

  TEST_CASE("boundary: pressure-boundary spacing follows a target diameter along the face") {
    const auto faces = pressure_channel::faces(0.01, 0.02);
    // A constant spacing function places exactly what the constant-L constructor places.
    const boundary::pressure_boundary<2> a(faces, {20.0, 0.0}, 0.5e-3);
    const boundary::pressure_boundary<2> b(faces, {20.0, 0.0}, [](const vec<2>&) { return 0.5e-3; });
    REQUIRE(a.size() == b.size());
    CHECK((a.x() - b.x()).cwiseAbs().maxCoeff() == 0.0);
    CHECK((a.diameters() - b.diameters()).cwiseAbs().maxCoeff() == 0.0);
    // Fine at the walls (0.25 mm within 1.5 mm), a ramp to 0.5 mm at the centre: the pieces tile each face
    // (Σ L_p = 10 mm) and each is within 10 % of L* at its centre (measured 3.2 %: a piece is ≈ L* where it
    // lies, rounded so that a whole number of pieces fits).
    const auto target = [](const vec<2>& y) {
      const double d = std::min(y[1], 0.01 - y[1]);
      return 0.25e-3 + std::clamp((d - 1.5e-3) / 2e-3, 0.0, 1.0) * 0.25e-3;
    };
    const boundary::pressure_boundary<2> c(faces, {20.0, 0.0}, target);
    double sum_in = 0.0, worst = 0.0;
    for (index_t k = 0; k < c.size(); ++k) {
      if (c.element(k) == 0) sum_in += c.diameters()[k];
      worst = std::max(worst, std::abs(c.diameters()[k] - target(c.x().col(k))) / target(c.x().col(k)));
    }
    std::printf(
        "variable spacing: %ld boundary particles, sum L_p on the inlet %.15f mm, worst |L_p - L*|/L* %.4f\n",
        static_cast<long>(c.size()), sum_in * 1e3, worst);
    CHECK(sum_in == doctest::Approx(0.01).epsilon(1e-12));
    CHECK(worst <= 0.10);
    CHECK_THROWS_WITH_AS(
        boundary::pressure_boundary<2>(faces, {20.0, 0.0}, [](const vec<2>&) { return -1.0; }),
        doctest::Contains("spacing"), mpskit::error);
  }

  TEST_CASE("boundary: outflow by face distance removes a particle arriving between two boundary particles") {
    // Outlet face x = 20 mm, boundary particles at y = 0.25, 0.75, ... mm (L = 0.5 mm) flowing out. A fluid
    // particle 0.1 L before the face, halfway between two of them (lateral offset L/2): its distance to the
    // nearest boundary particle is √(0.1² + 0.5²) L = 0.51 L > α_o L = 0.25 L, so Tanaka's rule keeps it at
    // the face; the face rule (h = 0.1 L < α_o L) removes it. A particle 0.3 L before the face stays with
    // both.
    const double L = 0.5e-3;
    const auto faces = pressure_channel::faces(0.01, 0.02);
    for (auto rule : {boundary::outflow_rule::particle_distance, boundary::outflow_rule::face_distance}) {
      boundary::pressure_params bp;
      bp.outflow = rule;
      const boundary::pressure_boundary<2> pb(faces, {20.0, 0.0}, L, bp);
      const index_t nf = 2, nb = pb.size();
      points<2> x(2, nf + nb);
      x.col(0) = vec<2>(0.02 - 0.1 * L, 5.0e-3);  // between the boundary particles at y = 4.75 and 5.25 mm
      x.col(1) = vec<2>(0.02 - 0.3 * L, 2.5e-3);
      for (index_t k = 0; k < nb; ++k) x.col(nf + k) = pb.x().col(k);
      Eigen::VectorXd Ls = Eigen::VectorXd::Constant(nf + nb, L),
                      V = Eigen::VectorXd::Constant(nf + nb, L * L);
      search::neighbour_list<2> nl;
      nl.build(exec::seq{}, x, search::per_particle_radius{&Ls, 3.1});
      points<2> ub(2, nb);
      for (index_t k = 0; k < nb; ++k)
        ub.col(k) = 0.1 * pb.normals().col(k) * (pb.element(k) == 1 ? -1.0 : 1.0);
      std::vector<std::uint8_t> remove(static_cast<std::size_t>(nf), 0);
      boundary::pressure_flux flux;
      pb.mark_outflow(x, Ls, nf, nf, ub, nl, remove, flux, V);
      CAPTURE(static_cast<int>(rule));
      CHECK(remove[0] == (rule == boundary::outflow_rule::face_distance ? 1 : 0));
      CHECK(remove[1] == 0);
    }
  }

  TEST_CASE(
      "boundary: the PPE with Dirichlet pressure boundaries and no free surface gives the linear pressure") {
    // First step from rest: u′ = 0, so the det F source vanishes and the PPE is Laplace's equation with
    // p = Δp at the inlet particles, 0 at the outlet and the wall rows: p = Δp (1 − x/ℓ), which LSMPS of
    // order 2 reproduces exactly; the corrected velocity is Δt G/ρ everywhere.
    pressure_channel c;
    const auto s0 = cases::channel_state(c.ell, c.H, c.L);
    simulation<cases::poiseuille_pressure_scene> sim(c.params(), s0, &c.walls, &c.pb);
    sim.step();
    const auto& st = sim.state();
    const auto& P = st.get<field::pressure>();
    double ep = 0.0, eu = 0.0;
    const double G = c.dp / c.ell, u1 = 2.5e-4 * G / 1000.0;
    for (index_t i = 0; i < st.n_real(); ++i) {
      ep = std::max(ep, std::abs(P[i] - c.dp * (1.0 - s0.x()(0, i) / c.ell)) / c.dp);
      // Beside the walls the shifting's δu = ∇u δx (eq. 91) sees the no-slip copies: interior only.
      if (s0.x()(1, i) > 3.0 * c.L && s0.x()(1, i) < c.H - 3.0 * c.L)
        eu = std::max(eu, (st.u().col(i) - vec<2>(u1, 0.0)).norm() / u1);
    }
    std::printf(
        "pressure boundary first step: max |p - lin|/dp %.2e, max |u - dt G/rho|/(dt G/rho) %.2e, pinned "
        "%ld\n",
        ep, eu, sim.counters().pinned_components);
    CHECK(ep <= 1e-7);  // solver tolerance 1e-8 (relative residual)
    CHECK(eu <= 1e-5);
    // the boundary particles are Dirichlet rows: nothing floats
    CHECK(sim.counters().pinned_components == 0);
    CHECK(st.n_ghost() == 0);  // pressure-boundary scenes end a step with the ghosts cleared (resize path)
  }
}

namespace {
/// The multi-diameter channel's shared checks: the issue's volume balance (2 % of Q_in over the last 0.1 s),
/// a flow established and renewed through both faces (Bernoulli from 100 Pa: ≈ 0.45 m/s in the narrow
/// section, Q_in ≈ 0.1 m/s across 30 mm), the particle ledger V(t) − V(0) = V_in − V_out, no guard
/// activation.
void check_multi_diameter_flow(const cases::multi_diameter_result& r) {
  CHECK(r.balance <= 0.02);
  CHECK(r.q_in > 1e-3);
  CHECK(r.inflow > 300);
  CHECK(r.outflow + r.outflow_behind > 300);
  CHECK(r.ledger_error <= 1e-12);
  CHECK(r.guarded == 0);
}
}  // namespace

TEST_SUITE("multi_diameter_channel") {
  TEST_CASE("channel: multi-diameter channel, 30 mm -> 10 mm taper, 100 Pa -> 0 Pa (Tanaka 2018 §5.3, A3)") {
    // Issue #8's CI case: L = 1 mm, μ = 0.001 Pa s, to 0.3 s; the volume balance |Q_in − Q_out − dV/dt| over
    // the last 0.1 s, Q the velocity fluxes through slabs 3 L inside the faces (the particle ledger closes by
    // construction and is checked apart). α_o = 0.5 (the case's choice, docs/channel.md).
    cases::multi_diameter_config c;
    const auto r = cases::run_multi_diameter(c);
    std::printf(
        "multi-diameter channel: balance %.4f (Q_in %.3e, Q_out %.3e, dV/dt %.1e m^2/s), in %ld out %ld "
        "behind %ld, guarded %ld, ledger %.1e, p in [%.0f, %.0f] Pa, |u|max %.3f m/s, %ld steps, %.1f s\n",
        r.balance, r.q_in, r.q_out, r.dvdt, r.inflow, r.outflow, r.outflow_behind, r.guarded, r.ledger_error,
        r.p_min, r.p_max, r.u_max, r.steps, r.wall_seconds);
    // measured (ILUT): balance 0.64 % (1.02 % with thin_walls on, 1.23 % before deviation 14 of
    // docs/lsmps_scheme.md), Q_in 2.86e-3 m²/s, 562 created, 582 removed
    check_multi_diameter_flow(r);
    // Not an explosion: |u| below the Bernoulli speed of the whole 100 Pa drop, √(2Δp/ρ) = 0.45 m/s, with
    // room for the pressure pulses (measured max 0.44 m/s; pressure in [−1210, 1162] Pa: one-step pulses over
    // the whole channel after discrete events, reported, not bounded: docs/channel.md).
    CHECK(r.u_max <= 1.0);
  }
}

TEST_SUITE("multi_diameter_channel_multires") {
  TEST_CASE(
      "channel: multi-diameter channel with splitting into the narrow section, 2:1 (Tanaka 2018 §5.3, A3)") {
    // Issue #9: the channel of the multi_diameter_channel label started at L = 1 mm everywhere; the target
    // diameter depends on the distance d from the outlet's midpoint (90, 0) mm, as in the paper (Fig. 12b;
    // the function is not in the text, this one is ours): 0.5 mm for d ≤ 30 mm (the narrow section), a linear
    // ramp to 1.05 mm at d = 60 mm, so particles split twice (1 → 0.71 → 0.5 mm) entering the narrow section.
    // 2:1 in diameter (the paper 0.25–0.75 mm, 3:1). The faces carry the target spacing (outlet 0.5 mm, inlet
    // 1 mm), so inflow creates coarse particles. Same balance as the single-resolution label, over the last
    // 0.1 s, here of 0.25 s (0.3 s until 2026-11-29, cut for issue #9's CI budget: 119 -> 95 s; the balance
    // is a conservation check, it needs no steady flow: measured 0.93 % at 0.3 s, 0.18 % at 0.25 s, Q_in
    // 3.07e-3 and 2.67e-3 m²/s, with thin walls on; 0.07 % at 0.25 s with thin walls off, the case's setting
    // since 2026-11-29).
    cases::multi_diameter_config c;
    const double Lc = c.L, Lf = 0.5 * c.L;
    c.t_end = 0.25;
    cases::refine_narrow_section(c, Lf);
    // ILUT factors kept across changes of the unknowns (opt-in, docs/lsmps_scheme.md deviation 7; `channel
    // --multi --ilut-across`): since 2026-12-04, for issue #9's CI budget on a slower machine. ILUT
    // (factorisation and triangular solves) took 42 % of the first 40 s of this run with a fresh
    // factorisation at every solve (the unknowns change at every step: inflow, outflow, splits) and 29 % with
    // the kept factors (perf samples); 75 s alone (measured). Each solve still reaches the same tolerance on
    // the current matrix, and the printed numbers are those of fresh factors but for the last digit of p_min:
    // balance 0.07 %, |u| 0.366 m/s, p in [−745, 1209] Pa (−744 fresh), 2585 splits, 438 created, 1772
    // removed, 1442 steps (both measured 2026-12-04).
    c.params.solver.ilut_reuse_across_changes = true;
    const auto r = cases::run_multi_diameter<cases::multi_diameter_multires_scene>(c);
    std::printf(
        "multi-diameter channel multires: balance %.4f (Q_in %.3e, Q_out %.3e, dV/dt %.1e m^2/s), particles "
        "%ld -> "
        "%ld, L in [%.3f, %.3f] mm, splits %ld merges %ld, in %ld out %ld behind %ld, guarded %ld, ledger "
        "%.1e, p in "
        "[%.0f, %.0f] Pa (min at (%.1f, %.1f) mm, t = %.4f s; max at (%.1f, %.1f) mm, t = %.4f s), |u|max "
        "%.3f m/s (last 0.1 s: %.3f), %ld steps, %.1f s\n",
        r.balance, r.q_in, r.q_out, r.dvdt, static_cast<long>(r.particles),
        static_cast<long>(r.particles_end), r.L_min * 1e3, r.L_max * 1e3, r.splits, r.merges, r.inflow,
        r.outflow, r.outflow_behind, r.guarded, r.ledger_error, r.p_min, r.p_max, r.p_min_at[0] * 1e3,
        r.p_min_at[1] * 1e3, r.p_min_t, r.p_max_at[0] * 1e3, r.p_max_at[1] * 1e3, r.p_max_t, r.u_max,
        r.u_max_window, r.steps, r.wall_seconds);
    // Particles split entering the narrow section: the fine size is reached and the coarse one kept upstream.
    CHECK(r.L_min == doctest::Approx(Lf).epsilon(1e-12));
    CHECK(r.L_max == doctest::Approx(Lc).epsilon(1e-12));
    CHECK(r.splits > 1000);  // measured 2585 (3064 to 0.3 s with thin walls on)
    // Measured (ILUT, thin walls on) to 0.25 s: balance 0.18 %, Q_in 2.67e-3 m²/s, 438 created, 1773 removed
    // (to 0.3 s: 0.93 %, 0.57 % with the Jacobi BiCGSTAB, single resolution 1.23 %; 598 created, 2410
    // removed); the ledger closes through every split as through the boundary events (splits halve the volume
    // exactly).
    check_multi_diameter_flow(r);
    // Not an explosion once established: over the window |u| below twice the Bernoulli speed of the whole
    // drop (0.45 m/s). The start-up too: over the whole run |u| ≤ 0.6 m/s (measured 0.364 to 0.25 s, 0.405 to
    // 0.3 s; p in [−455, 870] Pa to 0.25 s; [−622, 870] Pa with deviation 14 of docs/lsmps_scheme.md; with
    // thin_walls off, the case's setting since 2026-11-29: balance 0.07 %, |u| 0.366 m/s, p in [−744,
    // 1209] Pa). Before fluid rows with a diagonal ≥ 0 became p = 0 rows (docs/lsmps_scheme.md,
    // deviation 10), the first splits at the convex corner (60, −5) mm gave p in [−8.8, +38] kPa and |u|
    // 0.73 m/s at t ≈ 8 ms.
    CHECK(r.u_max_window <= 1.0);
    CHECK(r.u_max <= 0.6);
  }
}

using cases::poiseuille_multires_scene;
using cases::poiseuille_pressure_multires_scene;

TEST_SUITE("pressure_boundary") {
  TEST_CASE("boundary: with split/merge, faces coarser than the target at their inflow points are refused") {
    // Inflow creates particles of the boundary particle's diameter L_p; where L* < β_s L_p they would split
    // on arrival beside the face. The 0.5 mm faces of pressure_channel against a target of 0.25 mm within
    // 1.5 mm of a wall are refused; the same faces against a target of 0.5 mm everywhere (keep), and finer
    // faces (0.25 mm, their inflow particles merge in the fluid) against that target, are accepted.
    pressure_channel c;
    auto p = c.params();
    const double H = c.H;
    p.resolution.target_diameter = [H](const vec<2>& x) {
      return std::min(x[1], H - x[1]) < 1.5e-3 ? 0.25e-3 : 0.5e-3;
    };
    CHECK_THROWS_WITH_AS(simulation<poiseuille_pressure_multires_scene>(
                             p, cases::channel_state(c.ell, H, c.L), &c.walls, &c.pb),
                         doctest::Contains("split on arrival"), mpskit::error);
    p.resolution.split = false;  // nothing splits: accepted
    CHECK_NOTHROW(simulation<poiseuille_pressure_multires_scene>(p, cases::channel_state(c.ell, H, c.L),
                                                                 &c.walls, &c.pb));
    p.resolution.split = true;
    p.resolution.target_diameter = [](const vec<2>&) { return 0.5e-3; };
    CHECK_NOTHROW(simulation<poiseuille_pressure_multires_scene>(p, cases::channel_state(c.ell, H, c.L),
                                                                 &c.walls, &c.pb));
    const boundary::pressure_boundary<2> fine(pressure_channel::faces(H, c.ell), {20.0, 0.0}, 0.25e-3);
    CHECK_NOTHROW(simulation<poiseuille_pressure_multires_scene>(p, cases::channel_state(c.ell, H, c.L),
                                                                 &c.walls, &fine));
    // Context targets (wall distance) are evaluated at the inflow point x_p + α_i L_p n_p as well.
    p.resolution.target_diameter = [](const resolution::target_point<2>& tp) {
      return tp.wall_distance < 1.5e-3 ? 0.25e-3 : 0.5e-3;
    };
    CHECK_THROWS_WITH_AS(simulation<poiseuille_pressure_multires_scene>(
                             p, cases::channel_state(c.ell, H, c.L), &c.walls, &c.pb),
                         doctest::Contains("split on arrival"), mpskit::error);
  }
}

TEST_SUITE("poiseuille_multires") {
  TEST_CASE("channel: periodic Poiseuille with a 2:1 size ratio, refined at the walls by splitting") {
    // Issue #9's [poiseuille_multires] with the channel periodic in x (body force G/ρ; split_merge with
    // boundary::pressure is not composed yet, docs/resolution.md). Starts from the 0.5 mm lattice; target
    // L* = 0.25 mm within 1.5 mm of a wall, a linear ramp to 1.05 × 0.5 mm at 3.5 mm, so the particles near
    // the walls split twice in the first steps (0.5 → 0.354 → 0.25 mm) — the paper's A2 layout (0.125 mm at
    // the walls to 0.5 mm at the centre) at a 2:1 instead of 4:1 ratio. Δt = 0.1 L_f²/ν = 6.25e-5 s.
    cases::poiseuille_config c;
    const double Lf = 0.25e-3, H = c.H, Lc = c.L;
    c.dt = 0.1 * Lf * Lf / (c.mu / c.rho);
    // To 0.1 s (one time constant H²/(π²ν) = 0.1 s of the slowest mode): the start-up series (the analytic
    // transient) at 0.05 s and the end. The steady profile is not checked here: at 0.1 s the flow itself
    // still misses it by 32/π³ e⁻¹ = 38 %; to 0.5 s the same run gives 0.74 % against it and 0.11 % against
    // the series (docs/resolution.md "Poiseuille flow with a 2:1 size ratio"). The label ran this to 0.5 s
    // until 2026-11-29; cut to 0.3 s (84 → ≈ 50 s) when the obstacle case joined dam_break_multires, to 0.2 s
    // (≈ 38 s) on 2026-11-29 after a fresh-clone run on a slower machine measured issue #9's labels at 555 s
    // against their 8 minutes, and to 0.1 s (38 → 14 s solo) on 2026-12-04 on a slower machine still (the
    // series is the analytic transient: it checks the profile at any time).
    c.t_end = 0.1;
    c.probe_times = {0.05};
    c.params.resolution.target_diameter = cases::a2_target(H, Lf, Lc);
    const auto r = cases::run_poiseuille_periodic<poiseuille_multires_scene>(c);
    for (const auto& pr : r.probes)
      std::printf("poiseuille multires t = %.4f s: max err %.4f rms %.4f\n", pr.t, pr.max_error,
                  pr.rms_error);
    std::printf(
        "poiseuille multires end t = %.4f: series err %.4f, steady err %.4f, centre %.5f m/s, particles %ld "
        "-> %ld, L in [%.3f, %.3f] mm, splits %ld merges %ld, %ld steps, %.1f s\n",
        r.end.t, r.end.max_error, r.steady_error, r.centre_velocity, static_cast<long>(r.particles),
        static_cast<long>(r.particles_end), r.L_min * 1e3, r.L_max * 1e3, r.splits, r.merges, r.steps,
        r.wall_seconds);
    // The resolution really is 2:1: fine particles at the walls, the coarse ones kept in the centre.
    CHECK(r.L_min == doctest::Approx(Lf).epsilon(1e-12));
    CHECK(r.L_max == doctest::Approx(Lc).epsilon(1e-12));
    CHECK(r.splits > 100);
    CHECK(r.particles_end > r.particles);
    // Issue #9: the profile within 2 % of analytic, the start-up series at 0.05 and 0.1 s (measured 0.05 %
    // and 0.06 %; 0.06 % at 0.2 s; against the steady profile 38 % at 0.1 s, the flow's own lag).
    for (const auto& pr : r.probes) {
      CAPTURE(pr.t);
      CHECK(pr.max_error <= 0.02);
    }
    CHECK(r.end.max_error <= 0.02);
  }
}

TEST_SUITE("graded_start") {
  // Label graded_start (poiseuille_multires until 2026-12-06): resolution::graded_lattice is ours, not one of
  // issue #9's cases, so it runs under its own label and issue #9's CI budget counts the issue's cases.
  TEST_CASE(
      "channel: periodic Poiseuille 2:1 from a graded start: the split start's particles, no event, the "
      "series") {
    // The periodic 2:1 channel above started from resolution::graded_lattice
    // (poiseuille_config::graded_start) instead of splitting the 0.5 mm lattice in its first steps. Two
    // independent paths to the same layout: the stepper's split_merge, run from the lattice until its splits
    // stop (10 steps; they all happen in the first two), and the graded lattice must give the same particle
    // count and size range; the graded start is a fixed point of the trigger, so no particle splits or merges
    // while the flow starts up (to 0.05 s, 800 steps); and the profile is within the issue's 2 % of the
    // start-up series (measured 0.05 % at 0.05 s, as the split start).
    cases::poiseuille_config c;
    const double Lf = 0.25e-3, H = c.H, Lc = c.L;
    c.dt = 0.1 * Lf * Lf / (c.mu / c.rho);
    c.params.resolution.target_diameter = cases::a2_target(H, Lf, Lc);
    c.probe_times = {};
    cases::poiseuille_config split = c;
    split.t_end = 10 * c.dt;
    const auto rs = cases::run_poiseuille_periodic<poiseuille_multires_scene>(split);
    c.graded_start = true;
    c.t_end = 0.05;
    const auto rg = cases::run_poiseuille_periodic<poiseuille_multires_scene>(c);
    std::printf(
        "poiseuille 2:1 graded start: %ld particles (split start after %ld steps: %ld, %ld splits), L in "
        "[%.3f, %.3f] mm, splits %ld merges %ld to t = %.3f s, series err %.4f, %.1f s\n",
        static_cast<long>(rg.particles), rs.steps, static_cast<long>(rs.particles_end), rs.splits,
        rg.L_min * 1e3, rg.L_max * 1e3, rg.splits, rg.merges, rg.end.t, rg.end.max_error, rg.wall_seconds);
    CHECK(rs.splits > 100);
    CHECK(rg.particles == rs.particles_end);
    CHECK(rg.particles_end == rg.particles);
    CHECK(rg.L_min == doctest::Approx(rs.L_min).epsilon(1e-12));
    CHECK(rg.L_max == doctest::Approx(rs.L_max).epsilon(1e-12));
    CHECK(rg.splits == 0);
    CHECK(rg.merges == 0);
    CHECK(rg.guarded == 0);
    CHECK(rg.end.max_error <= 0.02);
    // The two paths give the same count but not the same points (split children sit on the parent's split
    // line). Refused: a graded start without a target, and along y (the graded lattice grades across y).
    cases::poiseuille_config bad = c;
    bad.params.resolution.target_diameter = {};
    CHECK_THROWS_WITH_AS(cases::channel_start(bad, bad.length), doctest::Contains("graded_start needs"),
                         mpskit::error);
    bad = c;
    bad.axis = 1;
    CHECK_THROWS_WITH_AS(cases::channel_start(bad, bad.length), doctest::Contains("axis 0"), mpskit::error);
    // A layer at an odd generation beside the walls (L* = 0.31 mm: one split, 0.354 mm diagonal pairs
    // 0.125 mm from the wall) would start with a gap there: refused, with the remedy.
    bad = c;
    bad.params.resolution.target_diameter = [](const vec<2>&) { return 0.31e-3; };
    CHECK_THROWS_WITH_AS(cases::channel_start(bad, bad.length),
                         doctest::Contains("odd number of splits beside a wall"), mpskit::error);
  }
}

TEST_SUITE("poiseuille_multires") {
  TEST_CASE(
      "channel: pressure-driven Poiseuille with a 2:1 size ratio (split/merge with pressure boundaries)") {
    // The 20 mm channel of the poiseuille label driven by Δp = 20 Pa through pressure boundaries, with the
    // target of the periodic multi-resolution case (0.25 mm within 1.5 mm of a wall, ramp to 0.525 mm at
    // 3.5 mm): the wall rows split in the first steps, the boundary particles are placed with the target
    // spacing (capped at 0.5 mm) so inflow creates particles of the local target diameter. Fixed Δt = 0.1
    // (0.24 mm)²/ν (the smallest boundary piece is 0.248 mm). To 0.05 s in CI (0.1 s until 2026-11-29, 0.07 s
    // until 2026-12-04, 0.06 s until 2026-12-06, cut for issue #9's CI budget; 33.3 -> 28.6 s from 0.06 s,
    // one thread; by 0.05 s 64 particles created and 85 removed, 89 / 109 by 0.06 s, 118 / 143 by 0.07 s;
    // 0.5 s in docs/resolution.md: 0.21 % / 0.78 %). The probe is at half the run (0.025 s), so the two
    // profile checks below see the start-up at two stages.
    cases::poiseuille_config c;
    c.length = 0.02;
    c.t_end = 0.05;
    c.probe_times = {0.025};
    const double Lf = 0.25e-3, H = c.H, Lc = c.L;
    c.dt = 0.1 * 0.24e-3 * 0.24e-3 / (c.mu / c.rho);
    const auto target = cases::a2_target(H, Lf, Lc);
    c.params.resolution.target_diameter = target;
    c.boundary_spacing = [=](const vec<2>& x) { return std::min(Lc, target(x)); };
    const auto r = cases::run_poiseuille_pressure<poiseuille_pressure_multires_scene>(c);
    std::printf(
        "pressure-driven poiseuille multires: t = %.3f s max err %.4f; end t = %.3f s series err %.4f, "
        "particles %ld "
        "-> %ld, L in [%.3f, %.3f] mm, splits %ld merges %ld, in %ld out %ld, ledger %.1e, guarded %ld, "
        "%.1f s\n",
        r.probes[0].t, r.probes[0].max_error, r.end.t, r.end.max_error, static_cast<long>(r.particles),
        static_cast<long>(r.particles_end), r.L_min * 1e3, r.L_max * 1e3, r.splits, r.merges, r.inflow,
        r.outflow, r.ledger_error, r.guarded, r.wall_seconds);
    CHECK(r.splits > 500);
    CHECK(r.L_min < 0.26e-3);
    CHECK(r.L_max > 0.45e-3);
    CHECK(r.inflow > 50);
    CHECK(r.outflow > 50);
    // Volume: V(t) − V(0) = V_in − V_out through every split and boundary event (splits halve exactly).
    CHECK(r.ledger_error <= 1e-12);
    CHECK(r.guarded == 0);
    // Issue #9: the profile within 2 % of analytic (the series; measured 0.05 % at 0.025 s, 0.06 % at
    // 0.05 s).
    CHECK(r.probes[0].max_error <= 0.02);
    CHECK(r.end.max_error <= 0.02);
  }
}

TEST_SUITE("poiseuille") {
  TEST_CASE(
      "channel: 3D square duct driven through pressure inflow/outflow faces, against the start-up series") {
    // Issue #8 item 1 in 3D: W = 4 mm square duct, ℓ = 8 mm, L = 0.5 mm (1024 particles), Δp = 8 Pa (G = 1000
    // Pa/m), μ = 0.1 Pa s, the faces two triangles each (boundary particles L_p = 0.47 mm), to 0.05 s (six
    // times the slowest mode's time constant W²/(2π²ν) = 8 ms). Error: max over the (y, z) cells of the
    // mid-length slab of |ū − u(y, z, t)| / u_c against the double sine series (examples/cases/duct.hpp),
    // u_c = 0.0118 m/s the steady centre velocity. Measured 1.34 % (RMS 0.85 %; 2.0 % when the case was
    // written, docs/channel.md); the same duct periodic with the body force: 2.1 % (1.4 %), so the faces add
    // nothing measurable; 3 % is the issue's 3D tolerance (pipe).
    cases::duct_config c;
    const auto r = cases::run_duct(c);
    std::printf(
        "3D pressure duct: max err %.4f rms %.4f of u_c = %.5f m/s, %ld steps, in %ld out %ld, particles %ld "
        "-> %ld, ledger %.1e, guarded %ld, %.1f s\n",
        r.max_error, r.rms_error, r.u_centre, r.steps, r.inflow, r.outflow, static_cast<long>(r.particles),
        static_cast<long>(r.particles_end), r.ledger_error, r.guarded, r.wall_seconds);
    CHECK(r.max_error <= 0.03);
    CHECK(r.outflow > 20);  // the first layer has left through the outlet face
    CHECK(r.inflow > 0);
    CHECK(r.ledger_error <= 1e-12);
    CHECK(r.guarded == 0);
  }
}

TEST_SUITE("poiseuille_multires") {
  TEST_CASE(
      "channel: 3D square duct through pressure faces, split near the walls (split/merge with pressure "
      "boundaries in 3D)") {
    // Issue #9 item 3 in 3D: the duct of the poiseuille label (W = 4 mm, ℓ = 8 mm, L = 0.5 mm, Δp = 8 Pa,
    // μ = 0.1 Pa s) refined by cases::refine_duct_walls: target L* = 0.75 L within 0.75 mm of a wall, a
    // linear ramp to 1.05 L at 1.5 mm (ours): the particles of the outer band split once (β_s
    // L = 0.897 L > 0.75 L; children 2^(-1/3) L = 0.397 mm), the core stays coarse. The faces carry the
    // target spacing (boundary particles L_p = 0.354 mm). With the uniform 0.47 mm face spacing of the
    // single-resolution case instead, the refined flow lags by 3.8 % at 0.02 s: the mid-length pressure
    // gradient is 4.4 % low, the extra drop sits in the slabs beside the faces (measured 2026-11-26). To
    // 0.02 s in CI (2.5 time constants W²/(2π²ν) = 8 ms); 0.05 s in docs/resolution.md and `channel
    // --duct-multires`.
    cases::duct_config c;
    const double L = c.L;
    c.t_end = 0.02;
    cases::refine_duct_walls(c);
    const auto r = cases::run_duct_impl<cases::duct_pressure_multires_scene>(c);
    std::printf(
        "3D pressure duct multires: max err %.4f rms %.4f of u_c = %.5f m/s, %ld steps, in %ld out %ld, "
        "particles "
        "%ld -> %ld, L in [%.3f, %.3f] mm, splits %ld merges %ld, ledger %.1e, guarded %ld, |u|max %.4f m/s, "
        "%.1f s\n",
        r.max_error, r.rms_error, r.u_centre, r.steps, r.inflow, r.outflow, static_cast<long>(r.particles),
        static_cast<long>(r.particles_end), r.L_min * 1e3, r.L_max * 1e3, r.splits, r.merges, r.ledger_error,
        r.guarded, r.u_max, r.wall_seconds);
    // Refined: every particle of the outer band (the two rings of the 8 × 8 cross-section, 48 per slab of 16)
    // split once, and no inflow yet, so the children are the smallest particles.
    CHECK(r.inflow == 0);
    CHECK(r.splits == 768);
    CHECK(r.L_min == doctest::Approx(std::cbrt(0.5) * L).epsilon(1e-12));
    CHECK(r.L_max == doctest::Approx(L).epsilon(1e-12));
    CHECK(r.outflow > 0);
    // Volume: V(t) − V(0) = V_in − V_out through every split and boundary event (splits halve exactly).
    CHECK(r.ledger_error <= 1e-12);
    CHECK(r.guarded == 0);
    // The issue's 3D tolerance against the start-up series (the pipe's 3 %); measured 0.73 % (single
    // resolution with the uniform faces: 1.59 % at Δt = 1.58e-4 s, the refined run's is 1.25e-4 s).
    CHECK(r.max_error <= 0.03);
  }
}

namespace {
using md_sim = simulation<cases::multi_diameter_multires_scene>;

/// The 2:1 multi-diameter channel at L = 2 mm (coarse: these tests are about restart), its faces' spacing and
/// target as in the multi_diameter_channel_multires label. ILUT factors are not kept across solves
/// (ilut_reuse = 1): a lagged factorisation is not saved, so only then is a restart bitwise (docs/run.md).
cases::multi_diameter_config restart_channel() {
  cases::multi_diameter_config c;
  c.L = 2e-3;
  cases::refine_narrow_section(c, 0.5 * c.L);
  c.params.solver.ilut_reuse = 1;
  return c;
}

using mpskit::test::same_bits;

/// Every counter of the two runs equal.
void check_same_counters(const scheme::lsmps_counters& a, const scheme::lsmps_counters& b) {
  for (long scheme::lsmps_counters::*f : scheme::lsmps_counter_fields) CHECK(a.*f == b.*f);
  CHECK(std::bit_cast<std::uint64_t>(a.inflow_volume) == std::bit_cast<std::uint64_t>(b.inflow_volume));
  CHECK(std::bit_cast<std::uint64_t>(a.outflow_volume) == std::bit_cast<std::uint64_t>(b.outflow_volume));
  CHECK(std::bit_cast<std::uint64_t>(a.left_domain_volume) ==
        std::bit_cast<std::uint64_t>(b.left_domain_volume));
}
}  // namespace

TEST_SUITE("restart") {
  TEST_CASE("restart: LSMPS multi-resolution channel, 60 steps + save + 60 equals load + 60 bitwise") {
    // The scene has everything a checkpoint must carry: split/merge (ledger totals, volumes), pressure faces
    // (inflow/outflow counters and volumes, new ids) and walls (copies are ghosts: not saved, made anew).
    // Step 60 is not a multiple of reorder_every (25): the list is built from the state at every step start.
    mpskit::test::scratch tmp("mpskit_test_channel", "restart");
    const auto c = restart_channel();
    cases::multi_diameter_setup su = cases::make_multi_diameter(c);
    const auto initial = su.initial;
    md_sim a(su.params, initial, &su.walls, &*su.boundary);
    for (int k = 0; k < 60; ++k) a.step();
    REQUIRE(60 % su.params.reorder_every != 0);
    const long splits_before = a.counters().splits;
    const long boundary_before = a.counters().inflow + a.counters().outflow;
    io::checkpoint_sections mine;
    mine.add("case.note", 42.0);
    io::save_simulation(tmp / "c.mpscp", a, mine);
    for (int k = 0; k < 60; ++k) a.step();

    md_sim b(su.params, initial, &su.walls, &*su.boundary);
    io::checkpoint_sections back;
    io::load_simulation(tmp / "c.mpscp", b, &back);
    CHECK(back.get_double("case.note") == 42.0);  // the caller's own sections come back
    CHECK(b.counters().steps == 60);
    CHECK(b.time() > 0.0);
    for (int k = 0; k < 60; ++k) b.step();

    // The run exercised what the checkpoint carries, before and after it (measured: splits at the start,
    // inflow and outflow from the first steps).
    CHECK(splits_before > 0);
    CHECK(a.counters().inflow + a.counters().outflow > boundary_before);
    const auto& sa = a.state();
    const auto& sb = b.state();
    REQUIRE(sa.n_real() == sb.n_real());
    const index_t n = sa.n_real();
    CHECK(same_bits(Eigen::MatrixXd(sa.x().leftCols(n)), Eigen::MatrixXd(sb.x().leftCols(n))));
    CHECK(same_bits(Eigen::MatrixXd(sa.u().leftCols(n)), Eigen::MatrixXd(sb.u().leftCols(n))));
    CHECK(same_bits(Eigen::VectorXd(sa.get<field::pressure>().head(n)),
                    Eigen::VectorXd(sb.get<field::pressure>().head(n))));
    CHECK(same_bits(Eigen::VectorXd(sa.get<field::volume>().head(n)),
                    Eigen::VectorXd(sb.get<field::volume>().head(n))));
    CHECK(std::equal(sa.ids().begin(), sa.ids().begin() + n, sb.ids().begin()));
    CHECK(std::equal(sa.flags().begin(), sa.flags().begin() + n, sb.flags().begin()));
    CHECK(sa.next_id() == sb.next_id());
    CHECK(std::bit_cast<std::uint64_t>(a.time()) == std::bit_cast<std::uint64_t>(b.time()));
    CHECK(std::bit_cast<std::uint64_t>(a.dt()) == std::bit_cast<std::uint64_t>(b.dt()));
    check_same_counters(a.counters(), b.counters());
    const auto& ta = a.time_step().state();
    const auto& tb = b.time_step().state();
    CHECK(ta.halvings == tb.halvings);
    CHECK(ta.held == tb.held);
    CHECK(ta.changes == tb.changes);
    const auto& la = a.ledger().totals();
    const auto& lb = b.ledger().totals();
    CHECK(a.ledger().steps() == b.ledger().steps());
    CHECK(la.splits == lb.splits);
    CHECK(la.merges == lb.merges);
    CHECK(std::bit_cast<std::uint64_t>(la.dV) == std::bit_cast<std::uint64_t>(lb.dV));
    CHECK(std::bit_cast<std::uint64_t>(la.dKE) == std::bit_cast<std::uint64_t>(lb.dKE));
    CHECK(same_bits(la.dVu, lb.dVu));
    CHECK(same_bits(la.dL, lb.dL));
    REQUIRE(la.fluxes.size() == lb.fluxes.size());
    CHECK(!la.fluxes.empty());
    for (std::size_t f = 0; f < la.fluxes.size(); ++f) {
      CHECK(la.fluxes[f].name == lb.fluxes[f].name);
      CHECK(std::bit_cast<std::uint64_t>(la.fluxes[f].volume) ==
            std::bit_cast<std::uint64_t>(lb.fluxes[f].volume));
      CHECK(same_bits(la.fluxes[f].momentum, lb.fluxes[f].momentum));
      CHECK(la.fluxes[f].particles == lb.fluxes[f].particles);
    }
  }

  TEST_CASE("restart: the channel case stopped and resumed gives the uninterrupted run's numbers bitwise") {
    // cases::run_multi_diameter in two processes' worth of pieces: stopped after its first step (stop_after
    // 1e-9 wall seconds), written with its running measurements, resumed to the end. Every number of the
    // result equals the straight run's (window 0.01 s of 0.03 s: the resume starts before the window, so the
    // window's sums are all made after it).
    mpskit::test::scratch tmp("mpskit_test_channel", "resume");
    auto c = restart_channel();
    c.t_end = 0.03;
    c.window = 0.01;
    const auto straight = cases::run_multi_diameter<cases::multi_diameter_multires_scene>(c);
    auto first = c;
    first.pieces.checkpoint = (tmp / "case.mpscp").string();
    first.pieces.stop_after = 1e-9;
    const auto part = cases::run_multi_diameter<cases::multi_diameter_multires_scene>(first);
    CHECK_FALSE(part.finished);
    CHECK(part.steps == 1);
    CHECK(std::isnan(part.balance));
    auto second = c;
    second.pieces.resume = first.pieces.checkpoint;
    const auto r = cases::run_multi_diameter<cases::multi_diameter_multires_scene>(second);
    CHECK(r.finished);
    CHECK(r.resumed_at == part.t_reached);
    CHECK(same_bits(r.balance, straight.balance));
    CHECK(same_bits(r.q_in, straight.q_in));
    CHECK(same_bits(r.q_out, straight.q_out));
    CHECK(same_bits(r.dvdt, straight.dvdt));
    CHECK(same_bits(r.p_min, straight.p_min));
    CHECK(same_bits(r.p_max, straight.p_max));
    CHECK(same_bits(r.u_max, straight.u_max));
    CHECK(same_bits(r.u_max_window, straight.u_max_window));
    CHECK(same_bits(r.ledger_error, straight.ledger_error));
    CHECK(r.steps == straight.steps);
    CHECK(r.particles == straight.particles);
    CHECK(r.particles_end == straight.particles_end);
    CHECK(r.splits == straight.splits);
    CHECK(r.inflow == straight.inflow);
    CHECK(r.outflow == straight.outflow);
    // Another L or t_end than the file's is refused.
    auto other = second;
    other.t_end = 0.04;
    CHECK_THROWS_WITH_AS(cases::run_multi_diameter<cases::multi_diameter_multires_scene>(other),
                         doctest::Contains("was written with"), mpskit::error);
  }

  TEST_CASE("restart: LSMPS loads refuse stepped targets, foreign files, missing sections and bad values") {
    mpskit::test::scratch tmp("mpskit_test_channel", "refuse");
    const auto c = restart_channel();
    cases::multi_diameter_setup su = cases::make_multi_diameter(c);
    md_sim a(su.params, su.initial, &su.walls, &*su.boundary);
    a.step();
    io::save_simulation(tmp / "c.mpscp", a);
    // A stepped target.
    CHECK_THROWS_WITH_AS(io::load_simulation(tmp / "c.mpscp", a), doctest::Contains("already stepped"),
                         mpskit::error);
    md_sim fresh(su.params, su.initial, &su.walls, &*su.boundary);
    // The particles alone (no sections).
    io::save_checkpoint(tmp / "plain.mpscp", su.initial);
    CHECK_THROWS_WITH_AS(io::load_simulation(tmp / "plain.mpscp", fresh),
                         doctest::Contains("no section 'lsmps.time'"), mpskit::error);
    // A classic scheme's checkpoint: other fields.
    {
      simulation<defaults<2>>::state_type classic(4);
      for (index_t i = 0; i < 4; ++i) classic.x().col(i) = vec<2>(0.01 * i, 0.0);
      io::save_checkpoint(tmp / "classic.mpscp", classic);
      CHECK_THROWS_WITH_AS(io::load_simulation(tmp / "classic.mpscp", fresh),
                           doctest::Contains("classic.mpscp"), mpskit::error);
    }
    // Reserved section names in the caller's sections.
    io::checkpoint_sections bad;
    bad.add("lsmps.mine", 1.0);
    CHECK_THROWS_WITH_AS(io::save_simulation(tmp / "r.mpscp", a, bad), doctest::Contains("reserved"),
                         mpskit::error);
    // restore() itself: negative counters, a rung off the ladder, a bad time, ghosts, a non-fluid particle.
    scheme::lsmps_counters k;
    k.splits = -1;
    CHECK_THROWS_WITH_AS(fresh.restore(su.initial, 0.1, 1e-3, k, {}, {}, 0),
                         doctest::Contains("counter is negative"), mpskit::error);
    scheme::time_step_state ts;
    ts.halvings = fresh.time_step().max_rungs() + 1;
    CHECK_THROWS_WITH_AS(fresh.restore(su.initial, 0.1, 1e-3, {}, ts, {}, 0),
                         doctest::Contains("out of range"), mpskit::error);
    CHECK_THROWS_WITH_AS(fresh.restore(su.initial, -1.0, 1e-3, {}, {}, {}, 0),
                         doctest::Contains("finite and >= 0"), mpskit::error);
    CHECK_THROWS_WITH_AS(fresh.restore(su.initial, 0.1, 1e-3, {}, {}, {}, -3),
                         doctest::Contains("negative count"), mpskit::error);
    auto wall = su.initial;
    wall.kinds()[0] = kind::wall;
    CHECK_THROWS_WITH_AS(fresh.restore(wall, 0.1, 1e-3, {}, {}, {}, 0),
                         doctest::Contains("fluid particles only"), mpskit::error);
    // Nothing above changed `fresh`: it loads the good file.
    CHECK(fresh.time() == 0.0);
    io::load_simulation(tmp / "c.mpscp", fresh);
    CHECK(fresh.time() == a.time());
    CHECK(fresh.counters().steps == 1);
  }
  TEST_CASE(
      "restart: LSMPS counters section of 43 values, or of 24 to 42 (older files), the missing ones read as "
      "0") {
    mpskit::test::scratch tmp("mpskit_test_channel", "counters");
    cases::multi_diameter_setup su = cases::make_multi_diameter(restart_channel());
    md_sim a(su.params, su.initial, &su.walls, &*su.boundary);
    a.step();
    io::checkpoint_sections all;
    io::add_simulation_sections(all, a);
    auto real = a.state();
    real.clear_ghosts();
    // The file with its counters section replaced by `counters` (every other section as save_simulation
    // writes it, but the boundary volumes when `volumes` is given, and without the active set's held ids,
    // which files before 2026-12-05 lack: they load with an empty set).
    const auto write = [&](const std::string& name, const std::vector<std::int64_t>& counters,
                           const std::vector<double>& volumes = {}) {
      io::checkpoint_sections s;
      for (const std::string& n : all.names()) {
        if (n == "lsmps.active_set_held") continue;
        if (n == "lsmps.counters") s.add_int64s(n, counters);
        else if (n == "lsmps.boundary_volumes" && !volumes.empty()) s.add_doubles(n, volumes);
        else if (n == "lsmps.ledger.flux_names") s.add_bytes(n, all.get_bytes(n));
        else if (n == "lsmps.time_step" || n == "lsmps.ledger.counts" || n == "lsmps.ledger.flux_particles")
          s.add_int64s(n, all.get_int64s(n));
        else s.add_doubles(n, all.get_doubles(n));
      }
      io::save_checkpoint(tmp / name, real, s);
      return tmp / name;
    };
    std::vector<std::int64_t> v = all.get_int64s("lsmps.counters");
    REQUIRE(v.size() == 43);
    v[24] = 7;   // filter_amplifying
    v[25] = 9;   // filter_tapered
    v[26] = 11;  // own_loop_checked
    v[27] = 12;  // own_loop_dirichlet
    v[28] = 13;  // own_loop_one_point
    v[29] = 14;  // own_loop_solves
    v[30] = 15;  // ppe_fallbacks
    v[31] = 16;  // shift_velocity_clipped
    v[32] = 17;  // ppe_breakdown_restarts
    v[33] = 18;  // collisions
    v[34] = 19;  // collision_coincident
    v[35] = 20;  // shift_coincident
    v[36] = 21;  // left_domain
    v[37] = 22;  // active_set_released
    v[38] = 23;  // ppe_cold_restarts
    v[39] = 24;  // ppe_solves
    v[40] = 25;  // ppe_factorisations
    v[41] = 26;  // ppe_repeat_solves
    v[42] = 27;  // ppe_repeat_iterations, the last value
    const auto head = [&](std::size_t k) {
      return std::vector<std::int64_t>(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k));
    };
    md_sim b(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("43.mpscp", v, {0.5, 0.25, 0.125}), b);
    CHECK(b.counters().ppe_repeat_solves == 26);
    CHECK(b.counters().ppe_repeat_iterations == 27);
    CHECK(b.counters().ppe_cold_restarts == 23);
    CHECK(b.counters().ppe_solves == 24);
    CHECK(b.counters().ppe_factorisations == 25);
    CHECK(b.counters().left_domain == 21);
    CHECK(b.counters().active_set_released == 22);
    CHECK(b.active_set_held().empty());  // no lsmps.active_set_held section: an empty set
    CHECK(b.counters().inflow_volume == 0.5);
    CHECK(b.counters().outflow_volume == 0.25);
    CHECK(b.counters().left_domain_volume == 0.125);
    CHECK(b.counters().net_boundary_volume() == 0.125);  // 0.5 − 0.25 − 0.125, exact in binary
    CHECK(b.counters().filter_amplifying == 7);
    CHECK(b.counters().filter_tapered == 9);
    CHECK(b.counters().own_loop_checked == 11);
    CHECK(b.counters().own_loop_dirichlet == 12);
    CHECK(b.counters().own_loop_one_point == 13);
    CHECK(b.counters().own_loop_solves == 14);
    CHECK(b.counters().ppe_fallbacks == 15);
    CHECK(b.counters().shift_velocity_clipped == 16);
    CHECK(b.counters().ppe_breakdown_restarts == 17);
    CHECK(b.counters().collisions == 18);
    CHECK(b.counters().collision_coincident == 19);
    CHECK(b.counters().shift_coincident == 20);
    CHECK(b.counters().steps == 1);
    CHECK(b.counters().copies == a.counters().copies);
    md_sim b41(su.params, su.initial, &su.walls, &*su.boundary);  // before the repeats' ledger: 41 counters
    io::load_simulation(write("41.mpscp", head(41), {0.5, 0.25, 0.125}), b41);
    CHECK(b41.counters().ppe_factorisations == 25);
    CHECK(b41.counters().ppe_repeat_solves == 0);
    CHECK(b41.counters().ppe_repeat_iterations == 0);
    md_sim b39(su.params, su.initial, &su.walls, &*su.boundary);  // before the solve ledger: 39 counters
    io::load_simulation(write("39.mpscp", head(39), {0.5, 0.25, 0.125}), b39);
    CHECK(b39.counters().ppe_cold_restarts == 23);
    CHECK(b39.counters().ppe_solves == 0);
    CHECK(b39.counters().ppe_factorisations == 0);
    md_sim b38(su.params, su.initial, &su.walls, &*su.boundary);  // before cold_restart: 38 counters
    io::load_simulation(write("38.mpscp", head(38), {0.5, 0.25, 0.125}), b38);
    CHECK(b38.counters().active_set_released == 22);
    CHECK(b38.counters().ppe_cold_restarts == 0);
    md_sim b37(su.params, su.initial, &su.walls, &*su.boundary);  // before active_set_release: 37 counters
    io::load_simulation(write("37.mpscp", head(37), {0.5, 0.25, 0.125}), b37);
    CHECK(b37.counters().left_domain == 21);
    CHECK(b37.counters().active_set_released == 0);
    md_sim b36(su.params, su.initial, &su.walls,
               &*su.boundary);  // before remove_outside: 36 counters, 2 volumes
    io::load_simulation(write("36.mpscp", head(36), {0.5, 0.25}), b36);
    CHECK(b36.counters().shift_coincident == 20);
    CHECK(b36.counters().left_domain == 0);
    CHECK(b36.counters().outflow_volume == 0.25);
    CHECK(b36.counters().left_domain_volume == 0.0);
    md_sim b26(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("26.mpscp", head(26)), b26);
    CHECK(b26.counters().filter_tapered == 9);
    CHECK(b26.counters().own_loop_checked == 0);
    CHECK(b26.counters().own_loop_solves == 0);
    md_sim b30(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("30.mpscp", head(30)), b30);
    CHECK(b30.counters().own_loop_solves == 14);
    CHECK(b30.counters().ppe_fallbacks == 0);
    md_sim b31(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("31.mpscp", head(31)), b31);
    CHECK(b31.counters().ppe_fallbacks == 15);
    CHECK(b31.counters().shift_velocity_clipped == 0);
    md_sim b32(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("32.mpscp", head(32)), b32);
    CHECK(b32.counters().shift_velocity_clipped == 16);
    CHECK(b32.counters().ppe_breakdown_restarts == 0);
    md_sim b33(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("33.mpscp", head(33)), b33);
    CHECK(b33.counters().ppe_breakdown_restarts == 17);
    CHECK(b33.counters().collisions == 0);
    md_sim b34(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("34.mpscp", head(34)), b34);
    CHECK(b34.counters().collisions == 18);
    CHECK(b34.counters().collision_coincident == 0);
    CHECK(b34.counters().shift_coincident == 0);
    md_sim b25(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("25.mpscp", head(25)), b25);
    CHECK(b25.counters().filter_amplifying == 7);
    CHECK(b25.counters().filter_tapered == 0);
    md_sim d(su.params, su.initial, &su.walls, &*su.boundary);
    io::load_simulation(write("24.mpscp", head(24)), d);
    CHECK(d.counters().filter_amplifying == 0);
    CHECK(d.counters().filter_tapered == 0);
    CHECK(d.counters().outflow_behind == a.counters().outflow_behind);
    CHECK(d.counters().steps == 1);
    CHECK(d.time() == a.time());
    md_sim e(su.params, su.initial, &su.walls, &*su.boundary);
    CHECK_THROWS_WITH_AS(io::load_simulation(write("23.mpscp", head(23)), e),
                         doctest::Contains("'lsmps.counters' holds 23 values, expected 43"), mpskit::error);
    CHECK_THROWS_WITH_AS(io::load_simulation(write("4v.mpscp", v, {0.5, 0.25, 0.125, 1.0}), e),
                         doctest::Contains("'lsmps.boundary_volumes' holds 4 values, expected 3"),
                         mpskit::error);
    v.push_back(0);
    CHECK_THROWS_WITH_AS(io::load_simulation(write("44.mpscp", v), e),
                         doctest::Contains("'lsmps.counters' holds 44 values, expected 43"), mpskit::error);
  }
}

// examples/channel.cpp's command line (cases/channel_options.hpp): the examples are not built in CI, so each
// mode's readings and every kind of refusal are checked here.
TEST_SUITE("bad_input") {
  TEST_CASE("channel's command line: modes, positional numbers, options and refusals") {
    const auto read = [](std::vector<const char*> args) {
      args.insert(args.begin(), "channel");
      return cases::read_channel_options(static_cast<int>(args.size()), args.data());
    };
    using mode = cases::channel_mode;
    // The default mode: the 20 mm channel at 0.5 mm; L sets Δt = 0.1 L²/ν with it (2.5e-4 s at 0.5 mm).
    const cases::channel_options d = read({});
    CHECK(d.mode == mode::poiseuille);
    CHECK(d.poiseuille.length == 0.02);
    CHECK(d.poiseuille.L == 0.5e-3);
    CHECK(d.poiseuille.dt == 2.5e-4);
    CHECK(d.poiseuille.t_end == 0.5);
    CHECK_FALSE(d.full);
    CHECK_FALSE(d.periodic_only);
    // Each mode's defaults (the example's header): the pipe to 0.2 s probed at 0.05 s, the duct at 0.5 mm to
    // 0.05 s, A2 at R = 4 to 0.1 s periodic with the single run, the multi-diameter channel at 1 mm to 0.3 s
    // single resolution.
    const cases::channel_options pd = read({"--pipe"});
    CHECK(pd.pipe.t_end == 0.2);
    CHECK(pd.pipe.probe_times == std::vector<double>{0.05});
    const cases::channel_options dd = read({"--duct"});
    CHECK(dd.duct.t_end == 0.05);
    CHECK(dd.duct.L == 0.5e-3);
    const cases::channel_options ad = read({"--a2"});
    CHECK(ad.a2_t_end == 0.1);
    CHECK(ad.a2_ratio == 4.0);
    CHECK_FALSE(ad.a2_pressure);
    CHECK(ad.a2_single);
    const cases::channel_options md = read({"--multi"});
    CHECK(md.multi.L == 1e-3);
    CHECK(md.multi.t_end == 0.3);
    CHECK(md.refine == 0.0);  // single resolution unless --refine
    CHECK_NOTHROW(md.validate());
    // --full in any position
    CHECK(read({"0.25e-3", "0.2", "--full"}).poiseuille.length == 0.1);
    const cases::channel_options p = read({"0.25e-3", "0.2", "--periodic-only"});
    CHECK(p.poiseuille.L == 0.25e-3);
    CHECK(p.poiseuille.dt == doctest::Approx(6.25e-5).epsilon(1e-14));
    CHECK(p.poiseuille.t_end == 0.2);
    CHECK(p.periodic_only);
    CHECK(p.poiseuille.probe_times == std::vector<double>{0.05, 0.1});  // both inside the run
    // probe times at or past t_end are dropped (the case would step on to them, beyond the end asked for)
    CHECK(read({"0.5e-3", "0.07"}).poiseuille.probe_times == std::vector<double>{0.05});
    CHECK(read({"0.5e-3", "0.005"}).poiseuille.probe_times.empty());
    CHECK(read({"--pipe", "0.05"}).pipe.probe_times.empty());
    const cases::channel_options f = read({"--full"});
    CHECK(f.full);
    CHECK(f.poiseuille.length == 0.1);
    // Each mode and its positional numbers.
    const cases::channel_options pipe = read({"--pipe", "0.1"});
    CHECK(pipe.mode == mode::pipe);
    CHECK(pipe.pipe.t_end == 0.1);
    CHECK(pipe.pipe.probe_times == std::vector<double>{0.05});
    const cases::channel_options duct = read({"--duct", "0.02", "1e-3"});
    CHECK(duct.mode == mode::duct);
    CHECK(duct.duct.t_end == 0.02);
    CHECK(duct.duct.L == 1e-3);
    CHECK(read({"--duct-multires", "0.03"}).duct.t_end == 0.03);
    const cases::channel_options a2 = read({"--a2", "0.05", "--ratio", "2", "--pressure", "--no-single"});
    CHECK(a2.mode == mode::a2);
    CHECK(a2.a2_t_end == 0.05);
    CHECK(a2.a2_ratio == 2.0);
    CHECK(a2.a2_pressure);
    CHECK_FALSE(a2.a2_single);
    const cases::channel_options m = read({"--multi",
                                           "0.5e-3",
                                           "0.4",
                                           "--refine",
                                           "2",
                                           "--graded",
                                           "--neumann-points",
                                           "--thin-walls",
                                           "--dt-ratio",
                                           "1.5",
                                           "--progress",
                                           "30",
                                           "--checkpoint",
                                           "ck.bin",
                                           "--every",
                                           "600",
                                           "--stop-after",
                                           "60",
                                           "--resume",
                                           "r.bin",
                                           "--ilut-across"});
    CHECK(m.mode == mode::multi);
    CHECK(m.multi.L == 0.5e-3);
    CHECK(m.multi.t_end == 0.4);
    CHECK(m.refine == 2.0);
    CHECK(m.multi.graded_start);
    CHECK(m.multi.params.copy_row == scheme::copy_row_kind::neumann_points);
    CHECK(m.multi.params.thin_walls);
    CHECK(m.multi.params.time.ratio == 1.5);
    CHECK(m.multi.progress_interval == 30.0);
    CHECK(m.multi.pieces.checkpoint == "ck.bin");
    CHECK(m.multi.pieces.checkpoint_interval == 600.0);
    CHECK(m.multi.pieces.stop_after == 60.0);
    CHECK(m.multi.pieces.resume == "r.bin");
    CHECK(m.multi.params.solver.ilut_reuse_across_changes);
    CHECK_NOTHROW(m.validate());
    // Reading refusals: not wholly a number, not > 0 (or >= 1 for a ratio), a number beyond the mode's, an
    // option of another mode, a missing value, an unknown option; each names its mode.
    CHECK_THROWS_WITH_AS(read({"0.5mm"}), doctest::Contains("channel: L '0.5mm'"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"-1"}), doctest::Contains("channel: L '-1': must be > 0"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"1e-3", "0.5", "7"}),
                         doctest::Contains("unexpected '7' (at most L and t_end)"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--pipe", "0.1", "3"}), doctest::Contains("channel --pipe: unexpected '3'"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--duct", "0.1", "1e-3", "2"}), doctest::Contains("at most t_end and L"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--duct-multires", "0"}), doctest::Contains("t_end '0': must be > 0"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--duct-multires", "0.03", "1e-3"}), doctest::Contains("(at most t_end)"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--a2", "0.1", "0.2"}), doctest::Contains("channel --a2: unexpected '0.2'"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--a2", "--ratio", "0.5"}), doctest::Contains("--ratio '0.5': must be >= 1"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--multi", "--refine"}), doctest::Contains("--refine needs a value"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--multi", "--progress", "abc"}), doctest::Contains("--progress 'abc'"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--pipe", "--full"}),
                         doctest::Contains("channel --pipe: unknown option '--full'"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--ratio", "2"}), doctest::Contains("channel: unknown option '--ratio'"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--multi", "--pressure"}), doctest::Contains("unknown option '--pressure'"),
                         mpskit::error);
    // Validation: --multi's end beyond its balance window, --graded only with --refine.
    CHECK_THROWS_WITH_AS(read({"--multi", "1e-3", "0.05"}).validate(),
                         doctest::Contains("t_end 0.05 must exceed the 0.1 s balance window"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--multi", "--dt-ratio", "3"}).validate(), doctest::Contains("ratio"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--multi", "--every", "600"}).validate(),
                         doctest::Contains("channel --multi: checkpoint_interval (--every)"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--multi", "--graded"}).validate(),
                         doctest::Contains("--graded needs --refine"), mpskit::error);
    // The usage line names the mode's options.
    CHECK(std::string(cases::channel_usage(mode::a2)).find("--ratio R") != std::string::npos);
    CHECK(cases::read_channel_mode(2, std::vector<const char*>{"channel", "--multi"}.data()) == mode::multi);
  }
}
