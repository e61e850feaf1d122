// Speed against error on Tanaka's dam break with the 10 × 10 mm obstacle (§5.6.2; issue #9 "Speed against
// error"): single resolution over spacings and the main example's multi-resolution run (coarse L, L/ratio
// around the block; examples/cases/tanaka_obstacle_multires.hpp), each against a finer single-resolution
// reference run once first, to T_end. Metrics (issue #9): the RMS front error at the reference's samples
// before the far-wall impact (the reference's first wet sample at the probe (195, 5) mm; the whole run if it
// never gets there), for the front over every non-isolated particle (front_rms) and over the largest
// connected body (body_front_rms, io::largest_body: spray clusters ahead of the surge left out; since
// 2026-12-04, the plotted one), and the error of the pressure impulse of that first impact at the probe
// (10 ms window from its first wet sample, as the example tanaka_dam_break). (The paper's probe 5 mm above
// the block is not used: it gets wet under the thin jet over the block, p ≈ 0, so its impulse is near 0,
// −0.22 Pa s at 4 mm, and relative errors mean nothing.) Writes CSV, Markdown and PNG
// (benchmarks/reporter.hpp) and the speed-up of each multi-resolution run at equal error for both metrics
// (benchmarks/speed_up.hpp). Run from the repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/bench/benchmarks/bench_report_obstacle_multires --repetitions 3
//
// Options: --reference mm (default 2.5: the finest spacing whose single run gets over the block,
// docs/resolution.md), --single L1,L2,... (mm, default 5,4,3.33), --multi L/ratio,... (default 5/2), --T
// T_end (default 2.4), --repetitions R (default 3), --out DIR (default benchmarks/results), --walls NAME (a
// name of cases::tanaka_wall_variants; default cases::obstacle_walls, the main example's until 2026-12-03;
// cases::tanaka_impact_walls is its default now), --collision ALPHA1 (the opt-in collision stage,
// lsmps_params::collision; default 0, off), --collide-isolated 0|1 (collision.isolated; needs --collision),
// --shift-isolated 0|1 (lsmps_params::shift_isolated_penalty, deviation 18), --series DIR (keep every run's
// front, far-wall probe and counters in DIR/<run>.txt and reuse them: a run whose file exists is loaded, not
// computed, if the file's configuration key (L, T_end, walls, options, the case's vessel settings, threads,
// compiler flags) is this one's, else refused; the key does not cover the library's code, so a directory
// belongs to one build: empty it after changing the code; the reference is the single run of its spacing, so
// a reference computed once serves later studies, and `--single "" --multi "" --series DIR` runs the
// reference alone; a loaded run's wall time is the one measured when it was computed, so use --repetitions
// 1). Results: obstacle_multires_speed_error.* and obstacle_multires_speed_up.csv. The impulse needs a T_end
// past the reference's impact and its 10 ms window (T ≳ 3.2); with the default 2.4 only the front is
// compared. The study asks for a 1 mm reference to t = 0.4 s (T = 5.6); what was run is in
// docs/validation.md "Dam break with the obstacle". A configuration that fails is recorded (not repeated; NaN
// metrics, `completed` 0, T reached) and the study goes on; a failed reference stops it. --solver jacobi|ilu0
// (default jacobi, the LSMPS default BiCGSTAB-Jacobi; ilu0: ppe::bicgstab_ilu0, docs/performance.md "ILU(0)
// for the LSMPS PPE") is the PPE solver of every run of the invocation, the reference's too; with ilu0 the
// --series key gains "; solver ilu0" (a Jacobi key is the one from before the option, so older series
// directories stay valid). --across-changes 0|1 (default 0; needs --solver ilu0):
// ppe::solver_params::ilut_reuse_across_changes, the factors kept when the unknowns change (up to ilut_reuse
// solves), key "; across changes".
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cases/tanaka_obstacle_multires.hpp"
#include "cases/tanaka_ilu0_scene.hpp"
#include "reporter.hpp"
#include "speed_up.hpp"

using namespace mpskit;

namespace {

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream in(s);
  for (std::string t; std::getline(in, t, ',');)
    if (!t.empty()) v.push_back(t);
  return v;
}

// A number > 0 (bench::parse_number: the whole text, finite).
double number(const std::string& s, const char* what) {
  const std::string option = std::string("report_obstacle_multires: ") + what;
  const double v = bench::parse_number(option.c_str(), s, 0.0);
  if (!(v > 0.0)) fail(option, " '", s, "': must be a finite number > 0");
  return v;
}

/// Issue #9's metrics against the reference: the RMS (and largest) front error at the reference's samples up
/// to T_impact (the reference's first wet sample at the far-wall probe; the whole run when it never gets
/// there), and the relative error of the pressure impulse of the first impact at that probe (NaN when the
/// reference has no complete impact window). Prints the run's impulse and guard activations (not error
/// metrics) to `log`. A run that fails before T_end keeps its wall time and NaN metrics
/// (bench::record_completion).
bench::run_outcome outcome_of(const cases::tanaka_dam_break_result& r,
                              const cases::tanaka_dam_break_result& ref, double T_impact, double T_end,
                              const char* name, std::ostream& log) {
  const cases::front_difference d = cases::compare_fronts(r, ref, T_impact);
  const cases::front_difference b =
      cases::compare_fronts(r, ref, T_impact, &cases::tanaka_dam_break_result::Z_body);
  const cases::impact_measures m = cases::far_wall_impact(r), mr = cases::far_wall_impact(ref);
  const double impulse_error =
      mr.complete && m.complete ? std::abs(m.impulse / mr.impulse - 1.0) : std::nan("");
  log << "    " << name << ": far-wall impulse " << m.impulse << " Pa s"
      << (m.complete ? "" : " (window incomplete)") << ", 2 ms peak " << m.peak_filtered
      << " Pa, guard activations " << r.guarded << ", closest pair " << r.min_pair_ratio
      << " L, largest speed " << r.u_max << " m/s";
  // Where the PPE's time goes (docs/performance.md "Through the far-wall impact"): solves per step (the
  // active set and the own-loop guard repeat them), iterations per solve (all; the steps' first solves and
  // the repeats when there were repeats: a run loaded from a file written before they were counted has
  // none), and incomplete factorisations (ILU(0)) per step.
  if (r.ppe_solves > 0 && r.steps > 0) {
    log << ", PPE solves per step " << double(r.ppe_solves) / double(r.steps) << ", iterations per solve "
        << double(r.ppe_iterations) / double(r.ppe_solves);
    if (r.ppe_repeat_solves > 0)
      log << " (first solves " << r.first_solve_iterations() << ", repeats " << r.repeat_solve_iterations()
          << ")";
    log << ", factorisations per step " << double(r.ppe_factorisations) / double(r.steps);
  }
  log << "\n";
  bench::run_outcome out;
  out.particles = r.particles_end;
  out.steps = r.steps;
  out.wall_seconds = r.wall_seconds;
  out.ppe_iterations = r.ppe_iterations;
  out.errors = {{"front_rms", d.rms},           {"front_max", d.max}, {"body_front_rms", b.rms},
                {"body_front_max", b.max},      {"impulse_error", impulse_error}};
  // A failed run stays in the study (its metrics NaN, its time and how far it got recorded), so one fragile
  // configuration does not cost the others' results.
  bench::record_completion(out, r.failed, r.failed ? r.T_failed : T_end, r.failure);
  return out;
}

/// A run kept on disk (`--series DIR`): the series and counters the study reads from a
/// tanaka_dam_break_result, so that an expensive run (the 1 mm reference: hours of one core) is computed once
/// and reused by later studies with the same configuration. One text file per run: a `key` line (the run's
/// configuration; a file whose key differs is refused, not overwritten), the counters, the failure text, the
/// front samples (T, Z), the far-wall probe (t, p; NaN while dry) and the body front (T, Z_body; files
/// without it are refused), numbers at 17 digits, so a loaded run gives the metrics of the computed one
/// bitwise.
class run_cache {
 public:
  explicit run_cache(std::string dir) : dir_(std::move(dir)) {}

  /// The run under `file` (a name without spaces) with configuration `key`: loaded when DIR/file.txt exists
  /// (its key must equal `key`), else computed by `compute` and saved. Without a directory: computed, not
  /// saved.
  template <class F>
  cases::tanaka_dam_break_result get(const std::string& file, const std::string& key, F&& compute,
                                     std::ostream& log) const {
    if (dir_.empty()) return compute();
    const std::filesystem::path path = std::filesystem::path(dir_) / (file + ".txt");
    if (std::filesystem::exists(path)) {
      cases::tanaka_dam_break_result r = load(path, key);
      log << "  " << file << ": loaded from " << path.string() << " (computed earlier: " << r.wall_seconds
          << " s)\n";
      return r;
    }
    cases::tanaka_dam_break_result r = compute();
    std::filesystem::create_directories(dir_);
    save(path, key, r);
    return r;
  }

 private:
  static std::string one_line(std::string s) {
    std::replace(s.begin(), s.end(), '\n', ' ');
    return s;
  }

  // Written beside the target and renamed onto it, so that a killed run or a second study sharing the
  // directory never sees half a file.
  static void save(const std::filesystem::path& path, const std::string& key,
                   const cases::tanaka_dam_break_result& r) {
    if (r.Z.size() != r.T.size() || r.Z_body.size() != r.T.size())
      fail("report_obstacle_multires: ", path.string(), ": the run's front series have ", r.T.size(),
           " times, ", r.Z.size(), " and ", r.Z_body.size(), " fronts");
    const std::filesystem::path tmp = path.string() + ".partial";
    {
      std::ofstream f(tmp);
      f.precision(17);
      f << "key " << key << "\ncounters " << r.particles << ' ' << r.particles_end << ' ' << r.steps << ' '
        << r.wall_seconds << ' ' << r.ppe_iterations << ' ' << r.guarded << ' ' << r.min_pair_ratio << ' '
        << r.u_max << ' ' << r.failed << ' ' << r.T_failed << ' ' << r.ppe_solves << ' '
        << r.ppe_factorisations << ' ' << r.ppe_repeat_solves << ' ' << r.ppe_repeat_iterations
        << "\nfailure " << one_line(r.failure) << "\nfront " << r.T.size() << "\n";
      for (std::size_t k = 0; k < r.T.size(); ++k) f << r.T[k] << ' ' << r.Z[k] << '\n';
      f << "probe " << r.probe_t.size() << "\n";
      for (std::size_t k = 0; k < r.probe_t.size(); ++k) f << r.probe_t[k] << ' ' << r.probe_p[k] << '\n';
      f << "front_body " << r.T.size() << "\n";
      for (std::size_t k = 0; k < r.T.size(); ++k) f << r.T[k] << ' ' << r.Z_body[k] << '\n';
      f.close();
      if (!f) fail("report_obstacle_multires: cannot write ", tmp.string());
    }
    std::filesystem::rename(tmp, path);
  }

  // Numbers through strtod (istream's >> rejects "nan"); every field must be present and whole.
  static cases::tanaka_dam_break_result load(const std::filesystem::path& path, const std::string& key) {
    std::ifstream f(path);
    const auto bad = [&](const char* what) {
      fail("report_obstacle_multires: ", path.string(), ": ", what,
           " (not a file written by --series; remove it)");
    };
    std::string line;
    if (!std::getline(f, line) || line.rfind("key ", 0) != 0) bad("no key line");
    if (line.substr(4) != key)
      fail("report_obstacle_multires: ", path.string(),
           " holds another configuration:\n  file: ", line.substr(4), "\n  this: ", key,
           "\n(use another --series directory or remove the file)");
    std::vector<double> v;
    // n numbers, or as many as one of `older` (files written before the last fields were added).
    const auto numbers = [&](const std::string& text, std::size_t n,
                             std::initializer_list<std::size_t> older = {}) {
      v.clear();
      const char* s = text.c_str();
      for (std::size_t k = 0; k < n; ++k) {
        if (std::find(older.begin(), older.end(), k) != older.end()) {
          const char* t = s;
          while (*t == ' ') ++t;
          if (*t == '\0') break;
        }
        char* end = nullptr;
        const double x = std::strtod(s, &end);
        if (end == s) bad("a number is missing");
        v.push_back(x);
        s = end;
      }
      while (*s == ' ') ++s;
      if (*s != '\0') bad("trailing text");
    };
    const auto section = [&](const char* name) {
      const std::string head = std::string(name) + " ";
      if (!std::getline(f, line) || line.rfind(head, 0) != 0) bad(name);
      return line.substr(head.size());
    };
    cases::tanaka_dam_break_result r;
    // 10: written before 2026-12-07 (no PPE solves and factorisations); 12: before the repeated solves
    numbers(section("counters"), 14, {10, 12});
    r.particles = static_cast<index_t>(v[0]);
    r.particles_end = static_cast<index_t>(v[1]);
    r.steps = static_cast<long>(v[2]);
    r.wall_seconds = v[3];
    r.ppe_iterations = static_cast<long>(v[4]);
    r.guarded = static_cast<long>(v[5]);
    r.min_pair_ratio = v[6];
    r.u_max = v[7];
    r.failed = v[8] != 0.0;
    r.T_failed = v[9];
    if (v.size() >= 12) {
      r.ppe_solves = static_cast<long>(v[10]);
      r.ppe_factorisations = static_cast<long>(v[11]);
    }
    if (v.size() == 14) {
      r.ppe_repeat_solves = static_cast<long>(v[12]);
      r.ppe_repeat_iterations = static_cast<long>(v[13]);
    }
    r.failure = section("failure");
    const auto pairs = [&](const char* name, std::vector<double>& a, std::vector<double>& b) {
      numbers(section(name), 1);
      if (!(v[0] >= 0.0 && v[0] <= 1e8 && v[0] == std::floor(v[0]))) bad("a series length is not a count");
      const std::size_t n = static_cast<std::size_t>(v[0]);
      for (std::size_t k = 0; k < n; ++k) {
        if (!std::getline(f, line)) bad("a series is short");
        numbers(line, 2);
        a.push_back(v[0]);
        b.push_back(v[1]);
      }
    };
    pairs("front", r.T, r.Z);
    pairs("probe", r.probe_t, r.probe_p);
    if (f.peek() == std::char_traits<char>::eof())
      bad("no front_body section (a file from before 2026-12-04, when the body front was added)");
    std::vector<double> T_body;
    pairs("front_body", T_body, r.Z_body);
    if (T_body != r.T) bad("the front_body times differ from the front's");
    return r;
  }

  std::string dir_;
};

/// The speed-up of every multi-resolution record at equal `metric` on the single-resolution records' curve.
void speed_ups(const bench::reporter& rep, const char* metric, std::ostream& log, std::ostream& csv) {
  std::vector<bench::cost_point> curve;
  const auto usable = [](double e) { return std::isfinite(e) && e > 0.0; };  // NaN: no complete impact window
  for (const bench::run_record& r : rep.records()) {
    if (r.series != "single") continue;
    if (usable(bench::reporter::value(r, metric)))
      curve.push_back({r.wall_median, bench::reporter::value(r, metric)});
    else if (!r.failure.empty())
      log << metric << ": " << r.name << " failed (" << r.failure
          << "): not on the single-resolution curve\n";
  }
  if (curve.empty()) log << metric << ": no single-resolution run with a usable value: no speed-up\n";
  for (const bench::run_record& m : rep.records()) {
    if (m.series != "multi" || curve.empty()) continue;
    const double e = bench::reporter::value(m, metric);
    if (!usable(e)) {
      log << m.name << ", " << metric << " " << e << (m.failure.empty() ? "" : " (failed " + m.failure + ")")
          << ": no speed-up\n";
      continue;
    }
    const bench::speed_up_result s = bench::speed_up(curve, {m.wall_median, e});
    log << m.name << ", " << metric << " " << e << ": single resolution needs " << s.bound_prefix()
        << s.single_seconds << " s for it; speed-up " << s.kind_name() << " " << s.speed_up
        << s.dominated_note() << "\n";
    csv << m.name << "," << metric << "," << m.wall_median << "," << e << "," << curve.size() << ","
        << s.kind_name() << "," << s.single_seconds << "," << s.speed_up << "," << s.dominated << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) try {
  double ref_mm = 2.5, T_end = 2.4, collision = 0.0;
  bool collide_isolated = false, shift_isolated = false, ilu0 = false, across_changes = false;
  const auto flag01 = [](const char* what, const std::string& v) {
    const int f = bench::parse_integer(what, v, 0);
    if (f > 1) fail("report_obstacle_multires: ", what, " ", f, ": must be 0 or 1");
    return f == 1;
  };
  std::vector<double> singles{5.0, 4.0, 10.0 / 3.0};
  std::vector<std::pair<double, double>> multis{{5.0, 2.0}};
  int reps = 3;
  std::string out = "benchmarks/results", walls = cases::obstacle_walls, series;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a], v = argv[a + 1];
    if (k == "--reference") ref_mm = number(v, "--reference");
    else if (k == "--T") T_end = number(v, "--T");
    else if (k == "--repetitions") reps = bench::parse_integer("--repetitions", v, 1);
    else if (k == "--out") out = v;
    else if (k == "--series") series = v;
    else if (k == "--walls") walls = v;  // checked by obstacle_params below, before any run
    // validated by the scheme
    else if (k == "--collision") collision = bench::parse_number("--collision", v, 0.0);
    else if (k == "--collide-isolated") collide_isolated = flag01("--collide-isolated", v);
    else if (k == "--shift-isolated") shift_isolated = flag01("--shift-isolated", v);
    else if (k == "--solver") {
      if (v != "jacobi" && v != "ilu0") fail("report_obstacle_multires: --solver '", v, "': jacobi or ilu0");
      ilu0 = v == "ilu0";
    } else if (k == "--across-changes") {
      across_changes = flag01("--across-changes", v);
    } else if (k == "--single") {
      singles.clear();
      for (const std::string& s : split(v)) singles.push_back(number(s, "--single"));
    } else if (k == "--multi") {
      multis.clear();
      for (const std::string& s : split(v)) {
        const auto slash = s.find('/');
        if (slash == std::string::npos)
          fail("report_obstacle_multires: --multi '", s, "': need L/ratio, e.g. 5/2");
        multis.push_back(
            {number(s.substr(0, slash), "--multi L"), number(s.substr(slash + 1), "--multi ratio")});
      }
    } else fail("report_obstacle_multires: unknown option '", k,
                "' (--reference, --single, --multi, --T, --repetitions, --out, --walls, --collision, "
                "--collide-isolated, --shift-isolated, --series, --solver, --across-changes)");
  }
  if (argc % 2 == 0) fail("report_obstacle_multires: option '", argv[argc - 1], "' has no value");
  scheme::lsmps_params<2> p = cases::obstacle_params(walls);
  p.collision.alpha1 = collision;
  p.collision.isolated = collide_isolated;
  p.shift_isolated_penalty = shift_isolated;
  p.collision.validate();
  if (across_changes && !ilu0) fail("report_obstacle_multires: --across-changes 1 needs --solver ilu0");
  p.solver.ilut_reuse_across_changes = across_changes;
  if (collide_isolated && collision == 0.0)
    fail(
        "report_obstacle_multires: --collide-isolated 1 needs the collision stage on (--collision ALPHA1 > "
        "0)");
  std::cout << "report_obstacle_multires (" << MPSKIT_BENCH_FLAGS << "), to T = " << T_end << ", reference "
            << ref_mm << " mm, walls '" << walls << "', collision alpha1 " << collision
            << (collide_isolated ? " (isolated particles too)" : "")
            << (shift_isolated ? ", isolated particles in the shifting penalty" : "") << ", PPE solver "
            << (ilu0 ? "BiCGSTAB-ILU(0)" : "BiCGSTAB-Jacobi")
            << (across_changes ? " (factors kept across changes of the unknowns)" : "") << "\n";
  // A run's configuration, the key of its --series file: the options that change its result or its wall time,
  // and the case's vessel settings. Not the library's code: a series directory belongs to one build of it.
  if (singles.empty() && multis.empty() && series.empty())
    fail("report_obstacle_multires: --single \"\" --multi \"\" runs the reference alone, to keep it: give "
         "--series DIR");
  const auto key = [&](const std::string& run, double L_mm) {
    const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(1e-3 * L_mm);
    std::ostringstream k;
    k.precision(17);
    k << run << "; L " << L_mm << " mm; T " << T_end << "; walls " << walls << "; collision " << collision
      << " isolated " << collide_isolated << "; shift_isolated " << shift_isolated << "; vessel "
      << c.vessel_height << " m" << (c.closed_top ? " closed" : " open")
      << (c.remove_outside ? ", remove_outside" : "") << "; threads " << max_threads() << "; build "
      << MPSKIT_BENCH_FLAGS << (ilu0 ? "; solver ilu0" : "") << (across_changes ? "; across changes" : "");
    return k.str();
  };
  const auto file = [](const std::string& run) {  // "multi 5/2.5 mm" -> "multi_5_over_2.5_mm"
    std::string f;
    for (const char ch : run)
      if (ch == '/') f += "_over_";
      else if (ch != ' ') f += ch;
      else if (!f.empty() && f.back() != '_') f += '_';
    return f;
  };
  const run_cache cache(series);
  const auto single_run = [&](double L_mm) {
    std::ostringstream name;
    name << "single " << L_mm << " mm";
    return cache.get(file(name.str()), key(name.str(), L_mm), [&] {
      const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(1e-3 * L_mm);
      return ilu0 ? cases::run_tanaka_dam_break<cases::tanaka_ilu0_scene>(c, T_end, p, true)
                  : cases::run_tanaka_dam_break(c, T_end, p, true);
    }, std::cout);
  };
  const cases::tanaka_dam_break_config ref_c = cases::tanaka_obstacle_config(1e-3 * ref_mm);
  const cases::tanaka_dam_break_result ref = single_run(ref_mm);
  if (ref.failed)
    fail("report_obstacle_multires: the reference (", ref_mm, " mm) failed at T = ", ref.T_failed, ": ",
         ref.failure);
  const cases::impact_measures mref = cases::far_wall_impact(ref);
  const double T_impact = std::isfinite(mref.t_arrival)
                              ? cases::make_tanaka_dam_break(ref_c).t_star(mref.t_arrival)
                              : std::numeric_limits<double>::infinity();
  std::cout << "  reference " << ref_mm << " mm: " << ref.particles << " particles, " << ref.steps
            << " steps, " << ref.wall_seconds << " s, guard activations " << ref.guarded
            << "; far-wall probe (195, 5) mm wet at T = " << T_impact
            << " (fronts compared before it), impulse over 10 ms " << mref.impulse << " Pa s"
            << (mref.complete ? "" : " (window incomplete: no impulse error)") << ", 2 ms peak "
            << mref.peak_filtered << " Pa, closest pair " << ref.min_pair_ratio << " L, largest speed "
            << ref.u_max << " m/s\n";

  bench::reporter rep("Dam break with the obstacle, front against " + std::to_string(ref_mm).substr(0, 4) +
                          " mm" + (ilu0 ? ", BiCGSTAB-ILU(0)" : ""),
                      reps);
  for (const double L : singles) {
    std::ostringstream name;
    name << "single " << L << " mm";
    rep.add({name.str(), "single", 1e-3 * L, [=, &ref, &single_run, n = name.str()] {
               return outcome_of(single_run(L), ref, T_impact, T_end, n.c_str(), std::cout);
             }});
  }
  for (const auto& [L, ratio] : multis) {
    std::ostringstream name;
    name << "multi " << L << "/" << L / ratio << " mm";
    std::ostringstream what;  // the key: ratio and the refined region too
    what.precision(17);
    what << name.str() << " (ratio " << ratio << ", r0 0.03 m, r1 0.06 m)";
    rep.add({name.str(), "multi", 1e-3 * L, [=, &ref, &cache, &key, &file, n = name.str(), w = what.str()] {
               return outcome_of(cache.get(file(n), key(w, L), [&] {
                 const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(1e-3 * L);
                 scheme::lsmps_params<2> pm = p;
                 cases::refine_around_block(pm, c, ratio, 0.03, 0.06);
                 return ilu0
                            ? cases::run_tanaka_dam_break<cases::with_ilu0<cases::obstacle_multires_scene>>(
                                  c, T_end, pm, true)
                            : cases::run_tanaka_dam_break<cases::obstacle_multires_scene>(c, T_end, pm, true);
               }, std::cout), ref, T_impact, T_end, n.c_str(), std::cout);
             }});
  }
  if (singles.empty() && multis.empty()) return 0;  // the reference alone (e.g. to fill --series)
  rep.run_all(std::cout);
  std::filesystem::create_directories(out);
  const std::filesystem::path dir(out);
  rep.write_csv(dir / "obstacle_multires_speed_error.csv");
  std::cout << "\n" << rep.markdown_table() << "\n";
  // Issue #9's speed-up: the single-resolution time for each multi-resolution run's error, on the
  // single-resolution curve measured in this run (log-log interpolation on its lower envelope, a bound
  // outside the measured range), for the front error and (when the reference has a complete impact window)
  // for the far-wall impulse error.
  std::ofstream f(dir / "obstacle_multires_speed_up.csv");
  f << "# reference: single resolution " << ref_mm << " mm to T = " << T_end << ", " << ref.wall_seconds
    << " s; walls " << walls << ", collision alpha1 " << collision
    << (collide_isolated ? " (isolated too)" : "")
    << (shift_isolated ? ", isolated in the shifting penalty" : "") << "; PPE solver "
    << (ilu0 ? "ilu0" : "jacobi") << (across_changes ? " (across changes)" : "")
    << "; front before T = " << T_impact << "; far-wall impulse " << mref.impulse << " Pa s\n";
  f << "multires,metric,multires_wall_median_s,multires_error,single_runs,kind,single_seconds,speed_up,"
       "dominated\n";
  speed_ups(rep, "front_rms", std::cout, f);
  speed_ups(rep, "body_front_rms", std::cout, f);
  if (mref.complete) speed_ups(rep, "impulse_error", std::cout, f);
  if (rep.write_plot(dir / "obstacle_multires_speed_error.png", "body_front_rms", std::cout, true))
    std::cout << "wrote " << (dir / "obstacle_multires_speed_error.png").string() << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << e.what() << "\n";
  return 1;
}
