// BiCGSTAB with ILU(0) (ppe/ilu0.hpp, ppe::bicgstab_ilu0) against the LSMPS default BiCGSTAB-Jacobi on
// Tanaka's 2D dam break (examples/cases/tanaka_dam_break_run.hpp, lsmps_impact_params, the options of
// issue #9's tests):
//   dam4: L = 4 mm refined 2:1 toward the far corner (the dam_break_multires test's multi-resolution run), to
//   T = 1.5; dam2: L = 2 mm, single resolution (5000 particles), to T = 0.6.
// Settings: Jacobi; ILU(0) with the default lag (solver_params::ilut_reuse = 4, same unknowns only); ILU(0)
// factorised at every solve (ilut_reuse = 1). Runs alternate between the settings within each repetition, so
// the machine's drift hits all of them alike; printed per setting: the median wall time, the median over
// repetitions of the ratio to Jacobi measured in the same repetition, the PPE iterations (per repetition also
// the pressure solves and the ILU(0) factorisations among them), and the front at the end (the solvers reach
// the same tolerance, so the runs agree to the solver's rounding; a chaotic run may drift later). Run from
// the repository root, with the thread count to measure:
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_ilu0 --repetitions 3
//
// Options: --repetitions R (default 3), --cases dam4,dam2.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_ilu0_scene.hpp"
#include "reporter.hpp"

using namespace mpskit;
using mpskit::bench::median;

namespace {

struct multi_jacobi : lsmps_defaults<2> {
  using resolution = mpskit::resolution::split_merge<>;
};
using multi_ilu0 = cases::with_ilu0<multi_jacobi>;
using single_ilu0 = cases::tanaka_ilu0_scene;

struct sample {
  double seconds = 0.0, front = 0.0;
  long iterations = 0, steps = 0;
  long solves = 0, factorisations = 0;  ///< pressure solves; ILU(0) factorisations among them (0 for Jacobi)
};

sample to_sample(const cases::tanaka_dam_break_result& r) {
  return {r.wall_seconds, r.Z.empty() ? 0.0 : r.Z.back(), r.ppe_iterations, r.steps, r.ppe_solves,
          r.ppe_factorisations};
}

/// setting 0: Jacobi; 1: ILU(0), default lag; 2: ILU(0), fresh factors at every solve.
sample run(const std::string& name, int setting) {
  cases::tanaka_dam_break_config c;
  scheme::lsmps_params<2> p = scheme::lsmps_impact_params<2>();
  if (setting == 2) p.solver.ilut_reuse = 1;
  if (name == "dam2") {
    c.L = 0.002;
    return to_sample(setting == 0 ? cases::run_tanaka_dam_break(c, 0.6, p)
                                  : cases::run_tanaka_dam_break<single_ilu0>(c, 0.6, p));
  }
  c.L = 0.004;  // dam4: as tests/test_split_merge.cpp, dam_break_multires
  const vec<2> corner(c.vessel_right, 0.0);
  const double L = c.L, Lf = 0.5 * c.L;
  p.resolution.target_diameter = [=](const vec<2>& x) {
    return Lf + std::clamp(((x - corner).norm() - 0.05) / 0.1, 0.0, 1.0) * (1.05 * L - Lf);
  };
  p.resolution.wall_contact = 0.75;
  const auto none = [](const auto&) {};
  return to_sample(setting == 0 ? cases::run_tanaka_dam_break<multi_jacobi>(c, 1.5, p, false, none)
                                : cases::run_tanaka_dam_break<multi_ilu0>(c, 1.5, p, false, none));
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  if (!o.parse(argc, argv, "bench_ilu0", {"cases"})) return 2;
  const int reps = o.repetitions;
  const std::string which = o.extra_values.count("cases") ? o.extra_values["cases"] : "dam4,dam2";
  std::printf("bench_ilu0 (%s), %d repetitions\n", MPSKIT_BENCH_FLAGS, reps);
  const std::vector<std::string> label{"Jacobi", "ILU(0), lag 4", "ILU(0), fresh"};
  for (const std::string name : {"dam4", "dam2"}) {
    if (which.find(name) == std::string::npos) continue;
    std::vector<std::vector<double>> secs(label.size()), ratio(label.size());
    std::vector<sample> last(label.size());
    for (int r = 0; r < reps; ++r) {
      std::vector<double> this_rep;
      for (std::size_t k = 0; k < label.size(); ++k) {
        const sample s = run(name, static_cast<int>(k));
        secs[k].push_back(s.seconds);
        this_rep.push_back(s.seconds);
        last[k] = s;
        std::printf(
            "  %s %s repetition %d: %.2f s, %ld steps, %ld PPE iterations, %ld solves, %ld factorisations, "
            "front %.6f\n",
            name.c_str(), label[k].c_str(), r, s.seconds, s.steps, s.iterations, s.solves, s.factorisations,
            s.front);
        std::fflush(stdout);
      }
      for (std::size_t k = 0; k < label.size(); ++k) ratio[k].push_back(this_rep[k] / this_rep[0]);
    }
    std::printf(
        "%s: | solver | median wall (s) | median time / Jacobi | PPE iterations | front at the end |\n",
        name.c_str());
    for (std::size_t k = 0; k < label.size(); ++k)
      std::printf("%s: | %s | %.2f | %.3f | %ld | %.6f |\n", name.c_str(), label[k].c_str(), median(secs[k]),
                  median(ratio[k]), last[k].iterations, last[k].front);
  }
  return 0;
}
