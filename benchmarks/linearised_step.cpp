// The linearised step at snapshots of a running case (docs/lsmps_scheme.md "Stability of the projection", "On
// a running dam break"): Tanaka's dam break (cases/tanaka_dam_break_run.hpp) is run with the given wall
// variant to each snapshot; there the real particles are taken as they are, and the Jacobian J of one step's
// velocity map u^n → u^{n+1} (positions, flags and Δt frozen at the snapshot's) is built column by column by
// central differences: two steps per unit perturbation ±ε of one velocity component (ε = 1e-6 m/s against
// speeds of 0.1–3 m/s; the det F source is quadratic in ∇u′ beyond the linear term), with UMFPACK so that the
// difference is not the iterative solver's tolerance. An eigenvalue |λ| > 1 of J is a velocity mode that one
// step amplifies. tests/test_projection.cpp does the same about a state at rest (label projection_stability);
// this tool does it on a moving, irregular state, where the dam break fails.
//
//   OMP_NUM_THREADS=1 build/bench/benchmarks/bench_linearised_step --L 6 (--T 0.5,1,3 | --before 8,4,2
//       [--T-end 3.2]) [--walls NAME] [--courant A] [--modes K] [--filter-strength EPS] [--header]
//
// --T: snapshots at the first step ending at or after these times T = t √(2g/h0), with that step's Δt.
// --before: the run goes on to T-end (default 3.2) and, when it fails (the blow-up bound or any other
// mpskit::error), the snapshots are the states these many steps before the failing step (1: the start of the
// last step that completed; kept in a ring buffer), each with the Δt of the step that followed it; a run that
// does not fail prints nothing.
//
// One CSV row per snapshot and mode (the K largest |λ|): the mode's dominant particle (largest share of the
// eigenvector's squared norm), its position, packing ratio, surface flag, distance to the nearest wall (inf:
// none within 10 L), the largest |eigenvalue| of its own 2×2 block of J (the loop through its own velocity
// alone) and the number of kinked columns (below). Cost: 4n steps and a dense eigenvalue problem of size 2n
// per snapshot (6 mm, n = 561: ≈ 40 s on one core).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "mpskit/ppe/suitesparse.hpp"
#include "reporter.hpp"

using namespace mpskit;

namespace {
/// The dam break's scene with a direct PPE solver (the finite differences need the exact solve).
struct direct_scene : lsmps_defaults<2> {
  using solver = mpskit::ppe::umfpack;
};
}  // namespace

int main(int argc, char** argv) {
  try {
    std::vector<double> snapshots, before;
    double T_end = 3.2;
    double L_mm = 0.0, courant = 0.1, filter_eps = 0.05, modes = 3;
    std::string walls_name = "two_point_wall_only_active_set";
    bool header = false;
    for (int a = 1; a < argc; ++a) {
      const bool v = a + 1 < argc;
      if (!std::strcmp(argv[a], "--L") && v) L_mm = bench::parse_number("--L (mm)", argv[++a], 1e-6);
      else if (!std::strcmp(argv[a], "--T") && v) snapshots = bench::parse_numbers("--T", argv[++a], 0.0);
      else if (!std::strcmp(argv[a], "--before") && v)
        before = bench::parse_numbers("--before (steps)", argv[++a], 1.0);
      else if (!std::strcmp(argv[a], "--T-end") && v) T_end = bench::parse_number("--T-end", argv[++a], 1e-9);
      else if (!std::strcmp(argv[a], "--walls") && v) walls_name = argv[++a];
      else if (!std::strcmp(argv[a], "--courant") && v)
        courant = bench::parse_number("--courant", argv[++a], 1e-6);
      else if (!std::strcmp(argv[a], "--filter-strength") && v)
        filter_eps = bench::parse_number("--filter-strength", argv[++a], 0.0);
      else if (!std::strcmp(argv[a], "--modes") && v) modes = bench::parse_number("--modes", argv[++a], 1.0);
      else if (!std::strcmp(argv[a], "--header")) header = true;
      else
        fail("bench_linearised_step: unexpected argument '", argv[a],
             "' (see the file's comment for the usage)");
    }
    if (header)
      std::printf(
          "walls,courant,filter_strength,L_mm,T,n,dt,rank,lambda_re,lambda_im,lambda_abs,above_1,x_mm,y_mm,c,"
          "surface,wall_distance_L,share,self_block,kinked_columns\n");
    if (!(L_mm > 0.0) || snapshots.empty() == before.empty())
      fail("bench_linearised_step: --L and one of --T or --before are required");
    if (!std::is_sorted(snapshots.begin(), snapshots.end()))
      fail("bench_linearised_step: --T must be increasing");
    std::sort(before.begin(), before.end(), std::greater<>());
    const cases::tanaka_wall_variant& walls =
        cases::tanaka_wall_variant_named(walls_name, "bench_linearised_step --walls");
    cases::tanaka_dam_break_config c;
    c.L = 1e-3 * L_mm;
    c.validate();
    const auto db = cases::make_tanaka_dam_break(c);
    scheme::lsmps_params<2> p;
    walls.apply(p);
    p.time.courant = courant;
    p.boundary_filter.strength = filter_eps;
    cases::set_tanaka_case_params(c, p);  // as run_tanaka_dam_break
    simulation<lsmps_defaults<2>> sim(p, cases::tanaka_initial_state(c, db), &db.walls);
    struct snapshot {
      scheme::lsmps_state<2> state;
      double dt = 0.0, t = 0.0;
    };
    std::vector<snapshot> todo;
    const auto take = [&]() {
      snapshot k{sim.state(), sim.dt(), sim.time()};
      k.state.clear_ghosts();
      return k;
    };
    if (before.empty()) {
      for (const double T_snap : snapshots) {
        while (db.t_star(sim.time()) < T_snap) sim.step();
        todo.push_back(take());
      }
    } else {
      // The states before each step (the step's Δt is the controller's choice inside it: the snapshot gets
      // the Δt of the step that followed it, read after that step).
      const std::size_t keep = static_cast<std::size_t>(before.front()) + 1;
      std::vector<snapshot> ring;
      bool failed = false;
      try {
        while (db.t_star(sim.time()) < T_end) {
          snapshot k = take();
          sim.step();
          k.dt = sim.dt();
          ring.push_back(std::move(k));
          if (ring.size() > keep) ring.erase(ring.begin());
        }
      } catch (const mpskit::error&) {
        failed = true;
      }
      if (!failed) return 0;
      // ring.back() is the last completed step's start; the failing step started after it
      for (const double b : before) {
        const std::size_t back = static_cast<std::size_t>(b);
        if (back <= ring.size()) todo.push_back(ring[ring.size() - back]);
      }
    }
    for (snapshot& snap : todo) {
      auto& s = snap.state;
      const index_t n = s.n_real();
      scheme::lsmps_params<2> q = p;  // one step at the snapshot's Δt, particles in place
      q.time.mode = scheme::time_step_mode::fixed;
      q.time.dt_fixed = snap.dt;
      q.time.max_speed = std::numeric_limits<double>::infinity();
      q.reorder_every = 0;
      q.solver.tolerance = 1e-12;
      const double eps = 1e-6;
      points<2> u0;
      Eigen::VectorXd cpack;
      std::vector<std::uint8_t> surface(static_cast<std::size_t>(n));
      {
        simulation<direct_scene> a(q, s, &db.walls);
        a.step();
        u0 = a.state().u().leftCols(n);
        cpack = a.packing_ratio().head(n);
        for (index_t i = 0; i < n; ++i)
          surface[static_cast<std::size_t>(i)] =
              (a.state().flags()[static_cast<std::size_t>(i)] & flag::surface) != 0;
      }
      // Forward and backward differences: a column whose two differ by more than 1e-3 of its size (plus 1e-3)
      // has a kink at the snapshot (a particle joining or leaving the active set, a flag or a guard switched
      // by the perturbation); the map is then not differentiable there and its eigenvalues are not a growth
      // rate.
      Eigen::MatrixXd J(2 * n, 2 * n);
      long kinked = 0;
      for (index_t col = 0; col < 2 * n; ++col) {
        Eigen::VectorXd side[2];
        for (int sg = 0; sg < 2; ++sg) {
          auto t = s;
          t.u()(col % 2, col / 2) += sg == 0 ? eps : -eps;
          simulation<direct_scene> a(q, std::move(t), &db.walls);
          a.step();
          side[sg].resize(2 * n);
          for (index_t r = 0; r < 2 * n; ++r)
            side[sg][r] = (a.state().u()(r % 2, r / 2) - u0(r % 2, r / 2)) / eps;
        }
        J.col(col) = 0.5 * (side[0] - side[1]);
        if ((side[0] + side[1]).norm() > 1e-3 * (1.0 + J.col(col).norm())) ++kinked;
      }
      const Eigen::EigenSolver<Eigen::MatrixXd> es(J, true);
      const Eigen::VectorXcd ev = es.eigenvalues();
      std::vector<index_t> order(static_cast<std::size_t>(ev.size()));
      std::iota(order.begin(), order.end(), index_t{0});
      std::sort(order.begin(), order.end(),
                [&](index_t a, index_t b) { return std::abs(ev[a]) > std::abs(ev[b]); });
      const long above =
          std::count_if(ev.begin(), ev.end(), [](const auto& l) { return std::abs(l) > 1.0 + 1e-6; });
      for (index_t r = 0; r < std::min<index_t>(static_cast<index_t>(modes), ev.size()); ++r) {
        const index_t k = order[static_cast<std::size_t>(r)];
        const Eigen::VectorXcd v = es.eigenvectors().col(k);
        index_t best = 0;
        double share = -1.0;
        for (index_t i = 0; i < n; ++i) {
          const double m = std::norm(v[2 * i]) + std::norm(v[2 * i + 1]);
          if (m > share) share = m, best = i;
        }
        share /= v.squaredNorm();
        const Eigen::Matrix2d B = J.block(2 * best, 2 * best, 2, 2);
        const double self = Eigen::EigenSolver<Eigen::Matrix2d>(B, false).eigenvalues().cwiseAbs().maxCoeff();
        const auto w = db.walls.query(s.x().col(best), 10.0 * c.L);
        std::printf("%s,%g,%g,%g,%.4f,%ld,%.4g,%ld,%.6f,%.6f,%.6f,%ld,%.2f,%.2f,%.3f,%d,%.2f,%.3f,%.4f,%ld\n",
                    walls.name.c_str(), courant, filter_eps, L_mm, db.t_star(snap.t), static_cast<long>(n),
                    snap.dt, static_cast<long>(r), ev[k].real(), ev[k].imag(), std::abs(ev[k]), above,
                    1e3 * s.x()(0, best), 1e3 * s.x()(1, best), cpack[best],
                    int(surface[static_cast<std::size_t>(best)]),
                    w.found() ? w.signed_distance / c.L : std::numeric_limits<double>::infinity(), share,
                    self, kinked);
      }
      std::fflush(stdout);
    }
    return 0;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
