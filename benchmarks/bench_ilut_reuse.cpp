// The lagged ILUT (ppe/eigen_iterative.hpp, solver_params::ilut_reuse and ilut_reuse_across_changes;
// docs/lsmps_scheme.md deviation 7): wall time of the 3D pipe of issue #8 (examples/cases/pipe.hpp: R = 5 mm,
// 8 particles per radius, periodic along z, ILUT-BiCGSTAB, pinned system with its left-null-vector solve), of
// the 3D duct through pressure faces refined near its walls by splitting (examples/cases/duct.hpp, issue #9)
// and of the paper's multi-diameter channel (examples/cases/multi_diameter_channel.hpp: 0.75 mm graded to
// 0.25 mm in the narrow section, pressure faces, splits; its unknowns change at nearly every step), with the
// factors kept for 1 (factorised at every solve), 4 (the default) and 8 solves, the last two also across
// changes of the unknowns. Runs alternate between the settings within each repetition, so the machine's drift
// hits all of them alike; printed: per setting the median wall time and the median over repetitions of the
// ratio to reuse 1 measured in the same repetition, and the errors (identical when the lag changes nothing
// but the iterations). Run from the repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_ilut_reuse --repetitions 3
//
// Options: --repetitions R (default 3), --t-end T (s; default 0.02 for the pipe and the duct; the channel
// runs to 5 T, its balance over the last 0.3 of that), --cases pipe,duct,channel.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "cases/duct.hpp"
#include "cases/multi_diameter_channel.hpp"
#include "cases/pipe.hpp"
#include "reporter.hpp"

using namespace mpskit;
using mpskit::bench::median;

namespace {

struct sample {
  double seconds = 0.0, max_error = 0.0;
};

/// One solver setting: factors kept for `reuse` solves, and across changes of the unknowns when `across`.
struct setting {
  int reuse = 1;
  bool across = false;
  void apply(ppe::solver_params& p) const {
    p.ilut_reuse = reuse;
    p.ilut_reuse_across_changes = across;
  }
};

sample run_pipe(const setting& st, double t_end) {
  cases::pipe_config c;
  c.t_end = t_end;
  c.probe_times = {};
  st.apply(c.params.solver);
  const auto r = cases::run_pipe(c);
  return {r.wall_seconds, r.probes.at(0).max_error};
}

sample run_duct(const setting& st, double t_end) {
  cases::duct_config c;
  c.t_end = t_end;
  cases::refine_duct_walls(c);
  st.apply(c.params.solver);
  const auto r = cases::run_duct_impl<cases::duct_pressure_multires_scene>(c);
  return {r.wall_seconds, r.max_error};
}

sample run_channel(const setting& st, double t_end) {  // "max error": the volume balance over the window
  cases::multi_diameter_config c;
  c.L = 0.00075;
  c.t_end = t_end;
  c.window = 0.3 * t_end;
  cases::refine_narrow_section(c, c.L / 3.0);
  c.graded_start = true;
  st.apply(c.params.solver);
  const auto r = cases::run_multi_diameter<cases::multi_diameter_multires_scene>(c);
  return {r.wall_seconds, r.balance};
}

}  // namespace

int main(int argc, char** argv) {
  bench::run_options o;
  if (!o.parse(argc, argv, "bench_ilut_reuse", {"cases"})) return 2;
  const int reps = o.repetitions;
  const double t_end = o.t_end;
  const std::string which = o.extra_values.count("cases") ? o.extra_values["cases"] : "pipe,duct,channel";
  std::printf("bench_ilut_reuse (%s), %d repetitions, t_end %.3f s\n", MPSKIT_BENCH_FLAGS, reps, t_end);
  const std::vector<setting> settings{{1, false}, {4, false}, {8, false}, {4, true}, {8, true}};
  const auto label = [](const setting& st) {
    return std::to_string(st.reuse) + (st.across ? " + across" : "");
  };
  for (const std::string name : {"pipe", "duct", "channel"}) {
    if (which.find(name) == std::string::npos) continue;
    std::vector<std::vector<double>> secs(settings.size()), ratio(settings.size());
    std::vector<double> err(settings.size(), 0.0);
    for (int r = 0; r < reps; ++r) {
      std::vector<double> this_rep;
      for (std::size_t k = 0; k < settings.size(); ++k) {
        const sample s = name == "pipe"   ? run_pipe(settings[k], t_end)
                         : name == "duct" ? run_duct(settings[k], t_end)
                                          : run_channel(settings[k], 5.0 * t_end);
        secs[k].push_back(s.seconds);
        this_rep.push_back(s.seconds);
        err[k] = s.max_error;
        std::printf("  %s reuse %s repetition %d: %.2f s, max error %.5f\n", name.c_str(),
                    label(settings[k]).c_str(), r, s.seconds, s.max_error);
        std::fflush(stdout);
      }
      for (std::size_t k = 0; k < settings.size(); ++k) ratio[k].push_back(this_rep[k] / this_rep[0]);
    }
    std::printf("%s: | ilut_reuse | median wall (s) | median time / reuse 1 | max error |\n", name.c_str());
    for (std::size_t k = 0; k < settings.size(); ++k)
      std::printf("%s: | %s | %.2f | %.3f | %.5f |\n", name.c_str(), label(settings[k]).c_str(),
                  median(secs[k]), median(ratio[k]), err[k]);
  }
  return 0;
}
