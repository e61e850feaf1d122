// How hard the PPE is for each preconditioner over Tanaka's obstacle dam break (§5.6.2): why
// BiCGSTAB-ILU(0)'s first solves of a step keep their iteration count after the collapse (T > 0.6) while
// BiCGSTAB-Jacobi's fall (docs/performance.md "First solves and repeats"). Runs the 2.5 mm single-resolution
// obstacle case with lsmps_impact_params (the obstacle reporter's reference and `tanaka_dam_break --obstacle
// --L 2.5`), its own solver being --solver jacobi (default) or ilu0. The step's first PPE system (A, b and
// the warm start x0 the stepper hands the solver: the last pressures) is, every --every steps, solved again
// beside the run by BiCGSTAB-Jacobi and BiCGSTAB-ILU(0) (fresh factors, the run's tolerance), each from x0
// and from x = 0; the run itself is not changed (its steps are the reporter's: 5482 with Jacobi, 5318 with
// ILU(0) to T = 3.8). Writes, from the repository root,
//
//   OMP_NUM_THREADS=1 build/b/benchmarks/bench_ppe_difficulty --solver jacobi --T 3.8 --every 10 --out DIR
//
//   DIR/steps.csv   per step: T, the first solve's iterations, the repeated solves and their iterations
//   DIR/probes.csv  per probed step: T, unknowns, fluid particles, nonzeros, |b − A x0| / |b|, and the
//                   iterations of Jacobi and ILU(0) from x0 and from 0 (and the run's own first solve)
//
// and prints the probes' means before and after T = 0.6. One thread: the numbers are iteration counts, not
// times.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_ilu0_scene.hpp"
#include "reporter.hpp"

using namespace mpskit;

namespace {

/// One probed first solve.
struct probe_record {
  double T = 0.0, r0 = 0.0;
  long unknowns = 0, fluid = 0, nonzeros = 0, own = 0;
  long jacobi_warm = 0, jacobi_zero = 0, ilu0_warm = 0, ilu0_zero = 0;
};

/// Shared between the observer (arms a probe, says the time) and the solver wrapper (takes it at the next
/// solve, which is the next step's first).
struct probe_desk {
  bool armed = false;
  double T = 0.0;
  long fluid = 0;
  std::vector<probe_record> records;
};
probe_desk desk;

/// The scene's solver, which on an armed solve first solves the same system by both preconditioners.
template <class Primary>
class probing_solver : public Primary {
 public:
  Eigen::ComputationInfo compute(const ppe::matrix& A) {
    A_ = &A;
    return Primary::compute(A);
  }
  Eigen::ComputationInfo compute(const ppe::matrix& A, bool same_unknowns) {
    A_ = &A;
    return Primary::compute(A, same_unknowns);
  }
  Eigen::ComputationInfo compute(const ppe::matrix& A, const std::vector<index_t>& to_previous) {
    A_ = &A;
    return Primary::compute(A, to_previous);
  }
  ppe::solve_report solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    if (!desk.armed || b.norm() == 0.0) return Primary::solve(b, x);
    desk.armed = false;
    const ppe::matrix& A = *A_;
    probe_record r;
    r.T = desk.T;
    r.fluid = desk.fluid;
    r.unknowns = A.rows();
    r.nonzeros = A.nonZeros();
    r.r0 = (b - A * x).norm() / b.norm();
    ppe::solver_params sp = this->params();
    sp.ilut_reuse = 1;  // fresh factors: what the probe measures is the system, not the lag
    const auto iterations = [&](auto solver, const Eigen::VectorXd& x0) {
      solver.set_params(sp);
      if (solver.compute(A) != Eigen::Success) return -1L;
      Eigen::VectorXd y = x0;
      const ppe::solve_report rep = solver.solve(b, y);
      return rep.info == Eigen::Success ? rep.iterations : -rep.iterations;  // negative: not converged
    };
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(b.size());
    r.jacobi_warm = iterations(ppe::bicgstab_jacobi{}, x);
    r.jacobi_zero = iterations(ppe::bicgstab_jacobi{}, zero);
    r.ilu0_warm = iterations(ppe::bicgstab_ilu0{}, x);
    r.ilu0_zero = iterations(ppe::bicgstab_ilu0{}, zero);
    const ppe::solve_report own = Primary::solve(b, x);
    r.own = own.iterations;
    desk.records.push_back(r);
    return own;
  }

 private:
  const ppe::matrix* A_ = nullptr;
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
int run(double T_end, long every, const std::string& out) {
  const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(0.0025);
  const cases::tanaka_dam_break db = cases::make_tanaka_dam_break(c);
  std::vector<step_record> steps;
  long it_before = 0, rs_before = 0, ri_before = 0;
  const auto observe = [&](const auto& sim) {
    const scheme::lsmps_counters& k = sim.counters();
    const long it = k.ppe_iterations - it_before, rs = k.ppe_repeat_solves - rs_before,
               ri = k.ppe_repeat_iterations - ri_before;
    it_before = k.ppe_iterations, rs_before = k.ppe_repeat_solves, ri_before = k.ppe_repeat_iterations;
    steps.push_back({db.t_star(sim.time()), it - ri, rs, ri});
    if (k.steps % every == 0) {
      desk.armed = true;
      desk.T = db.t_star(sim.time());  // the probed solve is the next step's; T at its start
      desk.fluid = sim.state().n_real();
    }
  };
  const cases::tanaka_dam_break_result r = cases::run_tanaka_dam_break<Scene>(
      c, T_end, scheme::lsmps_impact_params<2>(), false, observe);
  std::filesystem::create_directories(out);
  std::ofstream s(out + "/steps.csv");
  s << "T,first_solve_iterations,repeat_solves,repeat_iterations\n";
  for (const step_record& x : steps)
    s << x.T << ',' << x.first << ',' << x.repeats << ',' << x.repeat_iterations << '\n';
  std::ofstream p(out + "/probes.csv");
  p << "T,unknowns,fluid,nonzeros,r0,own,jacobi_warm,jacobi_zero,ilu0_warm,ilu0_zero\n";
  for (const probe_record& x : desk.records)
    p << x.T << ',' << x.unknowns << ',' << x.fluid << ',' << x.nonzeros << ',' << x.r0 << ',' << x.own << ','
      << x.jacobi_warm << ',' << x.jacobi_zero << ',' << x.ilu0_warm << ',' << x.ilu0_zero << '\n';
  std::printf("reached T = %.4f in %ld steps (%s), %zu probes\n", r.T_reached, r.steps,
              r.failure.empty() ? "no failure" : r.failure.c_str(), desk.records.size());
  for (int phase = 0; phase < 2; ++phase) {
    double n = 0, r0 = 0, u = 0, jw = 0, jz = 0, iw = 0, iz = 0, own = 0;
    for (const probe_record& x : desk.records) {
      if ((x.T > 0.6) != (phase == 1)) continue;
      n += 1, r0 += std::log10(x.r0), u += double(x.unknowns), own += double(x.own);
      jw += double(x.jacobi_warm), jz += double(x.jacobi_zero), iw += double(x.ilu0_warm),
          iz += double(x.ilu0_zero);
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
  if (!o.parse(argc, argv, "bench_ppe_difficulty", {"solver", "T", "every", "out"})) return 2;
  const std::string solver = o.extra_values.count("solver") ? o.extra_values["solver"] : "jacobi";
  const std::string out = o.extra_values.count("out") ? o.extra_values["out"] : "out/ppe_difficulty";
  try {
    const double T = o.extra_values.count("T") ? bench::parse_number("--T", o.extra_values["T"], 0.0) : 3.8;
    const long every =
        o.extra_values.count("every") ? bench::parse_integer("--every", o.extra_values["every"], 1) : 10L;
    std::printf("bench_ppe_difficulty (%s): 2.5 mm obstacle dam break to T = %g, solver %s, probe every %ld "
                "steps\n",
                MPSKIT_BENCH_FLAGS, T, solver.c_str(), every);
    if (solver == "jacobi") return run<jacobi_scene>(T, every, out);
    if (solver == "ilu0") return run<ilu0_scene>(T, every, out);
    std::fprintf(stderr, "bench_ppe_difficulty: --solver %s: jacobi or ilu0\n", solver.c_str());
    return 2;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "bench_ppe_difficulty: %s\n", e.what());
    return 2;
  }
}
