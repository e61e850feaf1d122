// Speed against error on the Koshizuka & Oka dam break (examples/cases/dam_break.hpp): for each solver
// and spacing l0 = a/N, the surge-front error against the experiments and wall time, as CSV, Markdown
// and PNG (benchmarks/reporter.hpp). Run from the repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_report_dam_break --levels 15,20,30 --repetitions 3
//
// Options: --levels N1,N2,... (l0 = a/N), --solvers cg_ichol[,cholmod][,umfpack], --repetitions R,
// --T-end T (dimensionless, default 3), --out DIR (default benchmarks/results), --data DIR (default
// tests/data/dam_break_front of the source tree), --lsmps-levels N1,... (Tanaka's dam break with the LSMPS
// scheme, L = h0/N, h0 = 100 mm; default 20,25; an empty list "" skips it), --lsmps-orders 2[,3] (LSMPS-A
// order, default 2), --lsmps-T-end T (default: --T-end), --lsmps-walls parent_gradient[,neumann_points]
// [,two_point_wall_only][,two_point_wall_only_active_set] (the LSMPS wall rows: lsmps_params::copy_row, or
// copy_two_point = 1 with wall-only shifting, optionally with active_set_solves = 10; any name of
// cases::tanaka_wall_variants; default parent_gradient, the library's default), --lsmps-collision ALPHA1 (the
// opt-in collision stage, lsmps_params::collision.alpha1; default 0: off), --lsmps-collide-isolated (isolated
// particles collide too), --lsmps-shift-isolated (isolated particles in the shifting penalty,
// lsmps_params::shift_isolated_penalty): the last three as the main example
// (examples/multires_dam_break.cpp).
//
// The LSMPS case (cases/tanaka_dam_break_run.hpp, issue #7) has the same shape as Koshizuka & Oka's (vessel
// 4 h0 wide, column h0 × 2 h0; h0 = 100 mm instead of a = 146 mm), so both are plotted against the same data
// in the same (T, Z). A run that fails before T_end is reported with NaN front errors (not plotted), the
// metric "completed" = 0 (1 when it reached T_end), T_reached/100 and its samples in dam_break_fronts.csv.
// The LSMPS runs also report the probe at (195, 5) mm (issue #7): T when it gets wet, and over the 10 ms
// after that the pressure impulse, the 2 ms moving-average peak and the peak of every 100th step (Tanaka's
// sampling), each /100, and the closest fluid pair over the run (min_pair_r/L/100, cases::min_pair_ratio:
// clustering).
//
// Error metric (docs/validation.md): at every front sample T_k ≤ T_end (ΔT = 0.05), Z_ref(T_k) is the
// mean of the data series defined at T_k (Martin & Moyce 1952 two scales, Koshizuka & Oka 1996;
// linear interpolation); e_k = (Z(T_k) − Z_ref(T_k)) / Z_ref(T_k); reported: RMS, max |e_k| and the
// signed mean (positive: the simulated front runs ahead of the experiments).
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cases/dam_break.hpp"
#include "cases/run_measures.hpp"
#include "cases/tanaka_dam_break_run.hpp"
#include "reporter.hpp"
#ifdef MPSKIT_HAS_SUITESPARSE
#include "mpskit/ppe/suitesparse.hpp"
#endif

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "unknown flags"
#endif
#ifndef MPSKIT_DAM_BREAK_DATA_DIR
#define MPSKIT_DAM_BREAK_DATA_DIR "tests/data/dam_break_front"
#endif

using namespace mpskit;

namespace {

struct cg_scene : defaults<2> {};
#ifdef MPSKIT_HAS_SUITESPARSE
struct cholmod_scene : defaults<2> {
  using solver = ppe::cholmod;
};
struct umfpack_scene : defaults<2> {
  using solver = ppe::umfpack;
};
#endif

/// One front sample against the reference: T, Z, Z_ref, e.
struct front_sample {
  double T, Z, Zref, e;
};

/// The samples T ≤ T_max where some data series is defined.
std::vector<front_sample> front_samples(const std::vector<double>& Ts, const std::vector<double>& Zs,
                                        const std::vector<cases::front_series>& data, double T_max) {
  std::vector<front_sample> v;
  for (std::size_t k = 0; k < Ts.size(); ++k) {
    if (Ts[k] > T_max + 1e-9) break;
    double zsum = 0.0;
    int m = 0;
    for (const auto& s : data) {
      const double z = s.at(Ts[k]);
      if (!std::isnan(z)) {
        zsum += z;
        ++m;
      }
    }
    if (m == 0) continue;
    const double zref = zsum / m;
    v.push_back({Ts[k], Zs[k], zref, (Zs[k] - zref) / zref});
  }
  return v;
}

/// RMS, max |e| and mean e of the relative front error against the mean of the data defined at each sample.
std::vector<bench::metric> front_errors(const std::vector<front_sample>& v) {
  if (v.empty()) fail("report_dam_break: no front sample lies where the data is defined");
  double sum = 0.0, sum2 = 0.0, emax = 0.0;
  for (const front_sample& f : v) {
    sum += f.e;
    sum2 += f.e * f.e;
    emax = std::max(emax, std::abs(f.e));
  }
  const double n = double(v.size());
  return {{"front_rms", std::sqrt(sum2 / n)}, {"front_max", emax}, {"front_mean", sum / n}};
}

/// Front samples of each configuration's first run (written to dam_break_fronts.csv).
std::map<std::string, std::vector<front_sample>> g_fronts;

/// The reporter's outcome of a run result R (cases::dam_break_result or tanaka_dam_break_result): counts,
/// wall time, front errors over T ≤ min(3, T_end); the samples of the configuration's first run are kept.
template <class R>
bench::run_outcome outcome_of(const R& r, const std::vector<cases::front_series>& data, double T_end,
                              const std::string& name) {
  bench::run_outcome o;
  o.particles = r.particles;
  o.steps = r.steps;
  o.wall_seconds = r.wall_seconds;
  o.ppe_iterations = r.ppe_iterations;
  const std::vector<front_sample> v = front_samples(r.T, r.Z, data, std::min(3.0, T_end));
  o.errors = front_errors(v);
  if (!g_fronts.count(name)) g_fronts[name] = v;
  return o;
}

template <class Scene>
bench::configuration make(const std::string& solver, int N, double T_end,
                          const std::vector<cases::front_series>* data) {
  cases::dam_break_config cfg;
  cfg.l0 = cfg.a / N;
  cfg.T_end = T_end;
  bench::configuration c;
  c.name = solver + " a/" + std::to_string(N);
  c.series = solver;
  c.l0 = cfg.l0;
  const std::string c_name = c.name;
  c.run = [cfg, data, T_end, c_name]() {
    return outcome_of(cases::run_dam_break<Scene>(cfg), *data, T_end, c_name);
  };
  return c;
}

struct lsmps_order3 : lsmps_defaults<2> {
  using op = mpskit::op::lsmps_a<2, 3, kernel>;
};

/// The LSMPS runs' opt-in collision and shifting options (--lsmps-collision, ...); tag() names them in a
/// configuration ("" when all are off).
struct lsmps_extras {
  double alpha1 = 0.0;
  bool collide_isolated = false, shift_isolated = false;
  std::string tag() const {
    std::ostringstream t;
    if (alpha1 > 0.0) t << "-coll" << alpha1 << (collide_isolated ? "i" : "");
    if (shift_isolated) t << "-si";
    return t.str();
  }
};

/// Tanaka's dam break with the LSMPS scheme at L = h0/N with the wall variant `walls` and the options `x`.
/// Besides the front: the probe at (195, 5) mm sampled every step (cases::measure_impact; window 10 ms after
/// the probe gets wet, 2 ms moving average, every 100 steps as Tanaka sampled), NaN when the run did not
/// reach the end of the window.
template <class Scene>
bench::configuration make_lsmps(int order, int N, double T_end, const std::vector<cases::front_series>* data,
                                const cases::tanaka_wall_variant& walls, const lsmps_extras& x) {
  cases::tanaka_dam_break_config cfg;
  cfg.L = cfg.column_width / N;
  bench::configuration c;
  c.name = "lsmps-" + std::to_string(order) + walls.tag + x.tag() + " h0/" + std::to_string(N);
  c.series = "LSMPS-A order " + std::to_string(order) + walls.label + x.tag() + " (Tanaka's vessel)";
  c.l0 = cfg.L;
  const std::string c_name = c.name;
  scheme::lsmps_params<2> p;
  walls.apply(p);
  p.collision.alpha1 = x.alpha1;
  p.collision.isolated = x.collide_isolated;
  p.shift_isolated_penalty = x.shift_isolated;
  p.validate();  // before any run: a bad --lsmps-collision is refused here
  c.run = [cfg, data, T_end, c_name, p]() {
    const cases::tanaka_dam_break_result r = cases::run_tanaka_dam_break<Scene>(cfg, T_end, p, true);
    bench::run_outcome o = outcome_of(r, *data, T_end, c_name);
    bench::record_completion(o, r.failed, r.failed ? r.T_failed : T_end, r.failure);
    o.errors.push_back({"p_min/rho_g_H", r.p_min / r.rho_g_h});
    const cases::impact_measures m = cases::far_wall_impact(r);
    const double nan = std::nan(""), T_of = std::sqrt(2.0 * cfg.g / cfg.column_width);
    // Divided by 100 like T_reached: the Markdown table prints 100 × each metric.
    o.errors.push_back({"probe_T_arrival/100", m.t_arrival * T_of / 100.0});
    o.errors.push_back({"probe_impulse_10ms_Pa_s/100", (m.complete ? m.impulse : nan) / 100.0});
    o.errors.push_back({"probe_peak_2ms_Pa/100", (m.complete ? m.peak_filtered : nan) / 100.0});
    o.errors.push_back({"probe_peak_every100_Pa/100", (m.complete ? m.peak_sparse : nan) / 100.0});
    o.errors.push_back({"min_pair_r/L/100", r.min_pair_ratio / 100.0});
    return o;
  };
  return c;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) v.push_back(item);
  return v;
}

}  // namespace

int main(int argc, char** argv) try {
  std::vector<int> levels{15, 20, 30};
  std::vector<std::string> solvers{"cg_ichol"};
#ifdef MPSKIT_HAS_SUITESPARSE
  solvers.push_back("cholmod");
#endif
  std::vector<int> lsmps_levels{20, 25}, lsmps_orders{2};
  std::vector<const cases::tanaka_wall_variant*> lsmps_walls{
      &cases::tanaka_wall_variant_named("parent_gradient", "report_dam_break --lsmps-walls")};
  int reps = 3;
  double T_end = 3.0, lsmps_T_end = -1.0;
  lsmps_extras extras;
  std::string out = "benchmarks/results", data_dir = MPSKIT_DAM_BREAK_DATA_DIR;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    auto next = [&]() -> std::string {
      if (k + 1 >= argc) fail("report_dam_break: option ", a, " needs a value");
      return argv[++k];
    };
    // a list of resolutions N (spacing = column width / N)
    const auto parse_levels = [&](std::vector<int>& out, const char* what) {
      out.clear();
      for (const std::string& s : split(next())) {
        const int N = bench::parse_integer(a.c_str(), s, 4);
        if (N < 4 || N > 400) fail("report_dam_break: ", a, " entry ", N, " outside [4, 400] (", what, ")");
        out.push_back(N);
      }
    };
    if (a == "--levels") {
      parse_levels(levels, "l0 = a/N");
    } else if (a == "--solvers") {
      solvers = split(next());
    } else if (a == "--repetitions") {
      reps = bench::parse_integer("--repetitions", next(), 1);
    } else if (a == "--T-end") {
      T_end = bench::parse_number("--T-end", next(), 0.0);
      if (!(T_end > 0.0 && T_end <= 10.0)) fail("report_dam_break: --T-end ", T_end, " outside (0, 10]");
    } else if (a == "--lsmps-levels") {
      parse_levels(lsmps_levels, "L = h0/N");
    } else if (a == "--lsmps-orders") {
      lsmps_orders.clear();
      for (const std::string& s : split(next())) {
        const int q = bench::parse_integer("--lsmps-orders", s, 2);
        if (q != 2 && q != 3) fail("report_dam_break: --lsmps-orders entry ", q, " (accepted: 2, 3)");
        lsmps_orders.push_back(q);
      }
    } else if (a == "--lsmps-walls") {
      lsmps_walls.clear();
      for (const std::string& w : split(next()))
        lsmps_walls.push_back(&cases::tanaka_wall_variant_named(w, "report_dam_break --lsmps-walls"));
    } else if (a == "--lsmps-T-end") {
      lsmps_T_end = bench::parse_number("--lsmps-T-end", next(), 0.0);
      if (!(lsmps_T_end > 0.0 && lsmps_T_end <= 10.0))
        fail("report_dam_break: --lsmps-T-end ", lsmps_T_end, " outside (0, 10]");
    } else if (a == "--lsmps-collision") {
      extras.alpha1 = bench::parse_number("--lsmps-collision", next(), 0.0);
    } else if (a == "--lsmps-collide-isolated") {
      extras.collide_isolated = true;
    } else if (a == "--lsmps-shift-isolated") {
      extras.shift_isolated = true;
    } else if (a == "--out") {
      out = next();
    } else if (a == "--data") {
      data_dir = next();
    } else {
      fail("report_dam_break: unknown option '", a,
           "' (--levels, --solvers, --repetitions, --T-end, --lsmps-levels, --lsmps-orders, --lsmps-T-end, "
           "--lsmps-walls, --lsmps-collision, --lsmps-collide-isolated, "
           "--lsmps-shift-isolated, --out, --data)");
    }
  }
  const std::vector<cases::front_series> data = cases::read_front_data(data_dir);
  const char* threads = std::getenv("OMP_NUM_THREADS");
  std::cout << "dam break speed/error report; " << MPSKIT_BENCH_FLAGS << "; OMP_NUM_THREADS="
            << (threads ? threads : "(unset)") << "; repetitions " << reps << "\n";
  bench::reporter rep("Dam break (Koshizuka & Oka; LSMPS in Tanaka's vessel)", reps);
  for (const std::string& s : solvers)
    for (int N : levels) {
      if (s == "cg_ichol") {
        rep.add(make<cg_scene>(s, N, T_end, &data));
#ifdef MPSKIT_HAS_SUITESPARSE
      } else if (s == "cholmod") {
        rep.add(make<cholmod_scene>(s, N, T_end, &data));
      } else if (s == "umfpack") {
        rep.add(make<umfpack_scene>(s, N, T_end, &data));
#endif
      } else {
        fail("report_dam_break: solver '", s,
             "' is not available (cg_ichol; cholmod, umfpack with SuiteSparse)");
      }
    }
  if (lsmps_T_end < 0.0) lsmps_T_end = T_end;
  if (extras.collide_isolated && !(extras.alpha1 > 0.0))
    fail(
        "report_dam_break: --lsmps-collide-isolated needs the collision stage on (--lsmps-collision ALPHA1 > "
        "0)");
  for (const cases::tanaka_wall_variant* w : lsmps_walls)
    for (int q : lsmps_orders)
      for (int N : lsmps_levels) {
        if (q == 2) rep.add(make_lsmps<lsmps_defaults<2>>(2, N, lsmps_T_end, &data, *w, extras));
        else rep.add(make_lsmps<lsmps_order3>(3, N, lsmps_T_end, &data, *w, extras));
      }
  rep.run_all(std::cout);
  std::filesystem::create_directories(out);
  const std::filesystem::path csv = std::filesystem::path(out) / "dam_break_speed_error.csv";
  const std::filesystem::path png = std::filesystem::path(out) / "dam_break_speed_error.png";
  rep.write_csv(csv);
  {
    const std::filesystem::path fronts = std::filesystem::path(out) / "dam_break_fronts.csv";
    std::ofstream f(fronts);
    if (!f) fail("report_dam_break: cannot write '", fronts.string(), "'");
    f << std::setprecision(8) << "configuration,T,Z,Z_ref,e\n";
    for (const auto& r : rep.records())
      for (const front_sample& x : g_fronts[r.name])
        f << r.name << ',' << x.T << ',' << x.Z << ',' << x.Zref << ',' << x.e << '\n';
    std::cout << "wrote " << fronts.string() << "\n";
  }
  std::cout << "\n" << rep.markdown_table() << "\nwrote " << csv.string() << "\n";
  if (rep.write_plot(png, "front_rms")) std::cout << "wrote " << png.string() << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << e.what() << "\n";
  return 1;
}
