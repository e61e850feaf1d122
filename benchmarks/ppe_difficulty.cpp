// How hard the PPE is for each preconditioner over Tanaka's obstacle dam break (§5.6.2): why
// BiCGSTAB-ILU(0)'s first solves of a step keep their iteration count after the collapse (T > 0.6) while
// BiCGSTAB-Jacobi's fall (docs/performance.md "First solves and repeats"), and which warm start serves them.
// Runs the 2.5 mm single-resolution obstacle case with lsmps_impact_params (the obstacle reporter's reference
// and `tanaka_dam_break --obstacle --L 2.5`), its own solver being --solver jacobi (default) or ilu0. Every
// --every steps the step's first PPE system (A, b and the warm start x0 the stepper hands the solver: the
// last pressures, wall copies at 0, since they are made anew each step) is solved again beside the run by
// BiCGSTAB-Jacobi and BiCGSTAB-ILU(0) (fresh factors, the run's tolerance, no restarts) from four starts:
// x0; 0; x0 with each copy's unknown at its parent's pressure; x0 with each unknown that was one in the
// previous solve (a copy: the same parent, polygon set and element) at that solve's value. The probes do not
// change the run (its steps are the reporter's: 5482 with Jacobi, 5318 with ILU(0) to T = 3.8). The last
// start needs the map from the stepper, which it computes only with --across 1
// (solver_params::ilut_reuse_across_changes; without it only steps with the previous solve's unknowns get
// that start): that changes no Jacobi run, but an ILU(0) run then keeps its factors across changed unknowns,
// another run. Writes, from the repository root,
//
//   OMP_NUM_THREADS=1 build/b/benchmarks/bench_ppe_difficulty --solver jacobi --T 3.8 --every 10 --across 1
//       --out DIR          (one command)
//
//   DIR/steps.csv   per step: T at its start, the first solve's iterations, the repeated solves and their
//                   iterations
//   DIR/probes.csv  per probed step: T at its start, unknowns, fluid particles, nonzeros, the run's own
//                   iterations, then per start (warm, zero, parent, previous) |b − A x0| / |b| and Jacobi's
//                   and ILU(0)'s iterations (−(iterations + 1) when not converged; empty: no such start),
//                   and the unknowns the previous start took from the last solve (−1: none)
//
// and prints the probes' means before and after T = 0.6. One thread: the numbers are iteration counts, not
// times.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_ilu0_scene.hpp"
#include "reporter.hpp"

using namespace mpskit;

namespace {

/// The iterations of one probe solve: converged, not converged (negative iterations), or no start of that
/// kind (no map: the driver ran without --across 1 and the unknowns changed). A failed factorisation throws.
struct probe_count {
  long iterations = 0;
  bool converged = false, made = false;
  std::string text() const { return !made ? "" : std::to_string(converged ? iterations : -iterations - 1); }
};

/// One start of the probed system: its relative residual |b − A x0| / |b| and both solvers' iterations.
struct probe_start {
  double r0 = std::numeric_limits<double>::quiet_NaN();
  probe_count jacobi, ilu0;
};

/// One probed first solve.
struct probe_record {
  double T = 0.0;
  long unknowns = 0, fluid = 0, nonzeros = 0, own = 0;
  probe_start warm, zero;  ///< from the stepper's x0 (the last pressures; wall copies at 0) and from 0
  probe_start parent;      ///< from x0 with each wall copy's unknown at its parent's pressure
  /// from x0 with each unknown that was one in the previous solve (a copy: the same parent, polygon set and
  /// element) at that solve's value; `mapped` of them (−1: no map)
  probe_start previous;
  long mapped = -1;
};

/// Shared between the observer (arms a probe, says the time) and the solver wrapper (takes it at the next
/// step's first solve of the PPE matrix `target`; not the adjoint solve of floating parts).
struct probe_desk {
  bool armed = false;
  const ppe::matrix* target = nullptr;
  double T = 0.0;
  long fluid = 0;
  /// the parent's pressure of row r's wall copy, NaN for a fluid row (reads the stepper during the solve)
  std::function<double(index_t)> parent_pressure;
  std::vector<probe_record> records;
};
probe_desk desk;

/// The scene's solver, which on an armed solve first solves the same system by both preconditioners.
template <class Primary>
class probing_solver : public Primary {
 public:
  Eigen::ComputationInfo compute(const ppe::matrix& A) {
    track(A, false);
    return Primary::compute(A);
  }
  Eigen::ComputationInfo compute(const ppe::matrix& A, bool same_unknowns) {
    track(A, same_unknowns);
    return Primary::compute(A, same_unknowns);
  }
  /// Called when the unknowns changed and solver_params::ilut_reuse_across_changes is on (--across 1).
  Eigen::ComputationInfo compute(const ppe::matrix& A, const std::vector<index_t>& to_previous) {
    track(A, false);
    to_previous_ = to_previous;
    return Primary::compute(A, to_previous);
  }
  ppe::solve_report solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    if (desk.armed && A_ == desk.target && b.norm() > 0.0) probe(b, x);
    const ppe::solve_report rep = Primary::solve(b, x);
    if (probed_) desk.records.back().own = rep.iterations;
    probed_ = false;
    last_ = x;
    return rep;
  }

 private:
  void track(const ppe::matrix& A, bool same_unknowns) {
    A_ = &A;
    same_ = same_unknowns;
    to_previous_.clear();
  }

  probe_start probe_from(const Eigen::VectorXd& b, const Eigen::VectorXd& x0) const {
    const ppe::matrix& A = *A_;
    ppe::solver_params sp = this->params();
    sp.ilut_reuse = 1;  // fresh factors: what the probe measures is the system, not the lag
    sp.cold_restart = false;  // each count from its own start only
    sp.breakdown_restart = false;
    const auto count = [&](auto solver) {
      solver.set_params(sp);
      if (solver.compute(A) != Eigen::Success) fail("bench_ppe_difficulty: a probe's factorisation failed");
      Eigen::VectorXd y = x0;
      const ppe::solve_report rep = solver.solve(b, y);
      return probe_count{rep.iterations, rep.info == Eigen::Success, true};
    };
    return {(b - A * x0).norm() / b.norm(), count(ppe::bicgstab_jacobi{}), count(ppe::bicgstab_ilu0{})};
  }

  void probe(const Eigen::VectorXd& b, const Eigen::VectorXd& x) {
    desk.armed = false;
    probe_record r;
    r.T = desk.T;
    r.fluid = desk.fluid;
    r.unknowns = A_->rows();
    r.nonzeros = A_->nonZeros();
    r.warm = probe_from(b, x);
    r.zero = probe_from(b, Eigen::VectorXd::Zero(b.size()));
    Eigen::VectorXd xs = x;
    for (Eigen::Index k = 0; k < xs.size(); ++k) {
      const double q = desk.parent_pressure(static_cast<index_t>(k));
      if (!std::isnan(q)) xs[k] = q;
    }
    r.parent = probe_from(b, xs);
    const bool identity = same_ && last_.size() == x.size();
    if (identity || to_previous_.size() == static_cast<std::size_t>(x.size())) {
      xs = x;
      r.mapped = 0;
      for (Eigen::Index k = 0; k < xs.size(); ++k) {
        const index_t q = identity ? static_cast<index_t>(k) : to_previous_[static_cast<std::size_t>(k)];
        if (q < 0 || q >= last_.size()) continue;
        xs[k] = last_[q];
        ++r.mapped;
      }
      r.previous = probe_from(b, xs);
    }
    desk.records.push_back(r);
    probed_ = true;
  }

  const ppe::matrix* A_ = nullptr;
  std::vector<index_t> to_previous_;
  bool same_ = false, probed_ = false;
  Eigen::VectorXd last_;  // the previous solve's solution (in that solve's rows)
};

struct jacobi_scene : lsmps_defaults<2> {
  using solver = probing_solver<ppe::bicgstab_jacobi>;
};
struct ilu0_scene : lsmps_defaults<2> {
  using solver = probing_solver<ppe::bicgstab_ilu0>;
};

struct step_record {
  double T = 0.0;
  long first = 0, repeats = 0, repeat_iterations = 0;
};

template <class Scene>
int run(double T_end, long every, bool across, const std::string& out) {
  const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(0.0025);
  const cases::tanaka_dam_break db = cases::make_tanaka_dam_break(c);
  std::vector<step_record> steps;
  long it_before = 0, rs_before = 0, ri_before = 0;
  double T_before = 0.0;
  long pinned = 0;
  const auto observe = [&](const auto& sim) {
    const scheme::lsmps_counters& k = sim.counters();
    const long it = k.ppe_iterations - it_before, rs = k.ppe_repeat_solves - rs_before,
               ri = k.ppe_repeat_iterations - ri_before;
    it_before = k.ppe_iterations, rs_before = k.ppe_repeat_solves, ri_before = k.ppe_repeat_iterations;
    steps.push_back({T_before, it - ri, rs, ri});  // T at the step's start, as the probes'
    T_before = db.t_star(sim.time());
    pinned = k.pinned_components;
    desk.armed = false;  // a probe not taken in its step (no solve) is dropped, not moved to a later one
    if (k.steps % every == 0) {
      desk.armed = true;
      desk.target = &sim.ppe_matrix();
      desk.T = T_before;  // the probed solve is the next step's
      desk.fluid = sim.state().n_real();
      desk.parent_pressure = [&sim](index_t r) {
        const index_t i = sim.ppe_rows()[static_cast<std::size_t>(r)];
        if (i < sim.state().n_real()) return std::numeric_limits<double>::quiet_NaN();
        const index_t parent = sim.state().template get<field::parent>()[static_cast<std::size_t>(i)];
        return sim.state().template get<field::pressure>()[parent];
      };
    }
  };
  scheme::lsmps_params<2> params = scheme::lsmps_impact_params<2>();
  // --across 1: the stepper then hands the solver the map from this solve's unknowns to the last one's (the
  // "previous" start when the unknowns changed); it changes no Jacobi run, but an ILU(0) run keeps its
  // factors across such changes then, so it is another run
  if (across) params.solver.ilut_reuse_across_changes = true;
  const cases::tanaka_dam_break_result r =
      cases::run_tanaka_dam_break<Scene>(c, T_end, params, true, observe);  // a failure: partial files
  desk.armed = false;
  desk.target = nullptr;
  desk.parent_pressure = nullptr;  // it refers to the run's simulation, which is gone
  std::filesystem::create_directories(out);
  std::ofstream s(out + "/steps.csv");
  s << "T,first_solve_iterations,repeat_solves,repeat_iterations\n";
  for (const step_record& x : steps)
    s << x.T << ',' << x.first << ',' << x.repeats << ',' << x.repeat_iterations << '\n';
  std::ofstream p(out + "/probes.csv");
  p << "T,unknowns,fluid,nonzeros,own";
  for (const char* start : {"warm", "zero", "parent", "previous"})
    p << ",r0_" << start << ",jacobi_" << start << ",ilu0_" << start;
  p << ",mapped\n";
  for (const probe_record& x : desk.records) {
    p << x.T << ',' << x.unknowns << ',' << x.fluid << ',' << x.nonzeros << ',' << x.own;
    for (const probe_start* st : {&x.warm, &x.zero, &x.parent, &x.previous})
      p << ',' << st->r0 << ',' << st->jacobi.text() << ',' << st->ilu0.text();
    p << ',' << x.mapped << '\n';
  }
  std::printf("reached T = %.4f in %ld steps (%s), %zu probes, pinned components %ld\n", r.T_reached, r.steps,
              r.failure.empty() ? "no failure" : r.failure.c_str(), desk.records.size(), pinned);
  for (int phase = 0; phase < 2; ++phase) {
    double n = 0, r0 = 0, u = 0, jw = 0, jz = 0, iw = 0, iz = 0, own = 0;
    for (const probe_record& x : desk.records) {
      if ((x.T > 0.6) != (phase == 1)) continue;
      n += 1, r0 += std::log10(x.warm.r0), u += double(x.unknowns), own += double(x.own);
      jw += double(x.warm.jacobi.iterations), jz += double(x.zero.jacobi.iterations);
      iw += double(x.warm.ilu0.iterations), iz += double(x.zero.ilu0.iterations);
    }
    if (n == 0) continue;
    std::printf(
        "%s: %g probes, unknowns %.0f, mean log10 |b - A x0|/|b| %.2f; iterations from x0 / from 0: Jacobi "
        "%.1f / %.1f, ILU(0) %.1f / %.1f; the run's own first solves %.1f\n",
        phase == 0 ? "T <= 0.6" : "T > 0.6", n, u / n, r0 / n, jw / n, jz / n, iw / n, iz / n, own / n);
  }
  return r.failure.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  if (!o.parse(argc, argv, "bench_ppe_difficulty", {"solver", "T", "every", "out", "across"})) return 2;
  const std::string solver = o.extra_values.count("solver") ? o.extra_values["solver"] : "jacobi";
  const std::string out = o.extra_values.count("out") ? o.extra_values["out"] : "out/ppe_difficulty";
  try {
    const double T = o.extra_values.count("T") ? bench::parse_number("--T", o.extra_values["T"], 0.0) : 3.8;
    const long every =
        o.extra_values.count("every") ? bench::parse_integer("--every", o.extra_values["every"], 1) : 10L;
    std::printf("bench_ppe_difficulty (%s): 2.5 mm obstacle dam break to T = %g, solver %s, probe every %ld "
                "steps\n",
                MPSKIT_BENCH_FLAGS, T, solver.c_str(), every);
    const int across =
        o.extra_values.count("across") ? bench::parse_integer("--across", o.extra_values["across"], 0) : 0;
    if (across > 1) fail("--across ", across, ": 0 or 1");
    if (solver == "jacobi") return run<jacobi_scene>(T, every, across == 1, out);
    if (solver == "ilu0") return run<ilu0_scene>(T, every, across == 1, out);
    std::fprintf(stderr, "bench_ppe_difficulty: --solver %s: jacobi or ilu0\n", solver.c_str());
    return 2;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "bench_ppe_difficulty: %s\n", e.what());
    return 2;
  }
}
