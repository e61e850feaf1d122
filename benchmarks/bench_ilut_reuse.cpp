// The lagged ILUT (ppe/eigen_iterative.hpp, solver_params::ilut_reuse; docs/lsmps_scheme.md deviation 7): wall
// time of the 3D pipe of issue #8 (examples/cases/pipe.hpp: R = 5 mm, 8 particles per radius, periodic along z,
// ILUT-BiCGSTAB, pinned system with its left-null-vector solve) and of the 3D duct through pressure faces refined
// near its walls by splitting (examples/cases/duct.hpp, issue #9), with the factors kept for 1 (factorised at
// every solve), 4 (the default) and 8 solves. Runs alternate between the settings within each repetition, so
// the machine's drift hits all of them alike; printed: per setting the median wall time and the median over
// repetitions of the ratio to reuse 1 measured in the same repetition, and the errors (identical when the
// lag changes nothing but the iterations). Run from the repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_ilut_reuse --repetitions 3
//
// Options: --repetitions R (default 3), --t-end T (s; default 0.02 for both cases), --cases pipe,duct.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "cases/duct.hpp"
#include "cases/pipe.hpp"
#include "reporter.hpp"

using namespace mpskit;
using mpskit::bench::median;

namespace {

struct sample {
  double seconds = 0.0, max_error = 0.0;
};

sample run_pipe(int reuse, double t_end) {
  cases::pipe_config c;
  c.t_end = t_end;
  c.probe_times = {};
  c.params.solver.ilut_reuse = reuse;
  const auto r = cases::run_pipe(c);
  return {r.wall_seconds, r.probes.at(0).max_error};
}

sample run_duct(int reuse, double t_end) {
  cases::duct_config c;
  c.t_end = t_end;
  cases::refine_duct_walls(c);
  c.params.solver.ilut_reuse = reuse;
  const auto r = cases::run_duct_impl<cases::duct_pressure_multires_scene>(c);
  return {r.wall_seconds, r.max_error};
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  if (!o.parse(argc, argv, "bench_ilut_reuse", {"cases"})) return 2;
  const int reps = o.repetitions;
  const double t_end = o.t_end;
  const std::string which = o.extra_values.count("cases") ? o.extra_values["cases"] : "pipe,duct";
  std::printf("bench_ilut_reuse (%s), %d repetitions, t_end %.3f s\n", MPSKIT_BENCH_FLAGS, reps, t_end);
  const std::vector<int> settings{1, 4, 8};
  for (const std::string name : {"pipe", "duct"}) {
    if (which.find(name) == std::string::npos) continue;
    std::vector<std::vector<double>> secs(settings.size()), ratio(settings.size());
    std::vector<double> err(settings.size(), 0.0);
    for (int r = 0; r < reps; ++r) {
      std::vector<double> this_rep;
      for (std::size_t k = 0; k < settings.size(); ++k) {
        const sample s = name == "pipe" ? run_pipe(settings[k], t_end) : run_duct(settings[k], t_end);
        secs[k].push_back(s.seconds);
        this_rep.push_back(s.seconds);
        err[k] = s.max_error;
        std::printf("  %s reuse %d repetition %d: %.2f s, max error %.5f\n", name.c_str(), settings[k], r, s.seconds,
                    s.max_error);
        std::fflush(stdout);
      }
      for (std::size_t k = 0; k < settings.size(); ++k) ratio[k].push_back(this_rep[k] / this_rep[0]);
    }
    std::printf("%s: | ilut_reuse | median wall (s) | median time / reuse 1 | max error |\n", name.c_str());
    for (std::size_t k = 0; k < settings.size(); ++k)
      std::printf("%s: | %d | %.2f | %.3f | %.5f |\n", name.c_str(), settings[k], median(secs[k]), median(ratio[k]), err[k]);
  }
  return 0;
}
