#pragma once
// Speed-against-error reporter: runs one case over a list of configurations (name, spacing l0, a run
// function that picks the scene/solver), repeats each run, and records particles, steps, wall time
// (median over repetitions), particle-steps per second, mean PPE iterations per step and the case's
// error metrics against a reference. Writes a CSV, a Markdown table and a PNG of error against wall
// time through gnuplot (Debian package gnuplot-nox, scripts/deps.sh).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cases/cli.hpp"
#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"

namespace mpskit::bench {

/// A named error metric of one run (dimensionless unless the name says otherwise).
struct metric {
  std::string name;    ///< column name, e.g. "front_rms"
  double value = 0.0;  ///< value
};

/// What one run of a configuration measured.
struct run_outcome {
  index_t particles = 0;          ///< particles of every kind
  long steps = 0;                 ///< steps taken
  double wall_seconds = 0.0;      ///< wall time of the time loop (set-up excluded)
  long ppe_iterations = 0;        ///< PPE iterations summed over steps
  std::vector<metric> errors;     ///< error metrics against the reference
  std::string failure;            ///< why the run stopped before its end; empty when it completed
};

/// Records how far a run got: T_reached (its end, or where it failed) and, when it `failed`, why (the
/// outcome's `failure` becomes "at T = <T_reached>: <why>"). A failed run's error metrics become NaN (errors
/// over the samples before a failure are not comparable with complete runs: NaN leaves them out of plots and
/// speed-ups); two metrics are appended: `completed` (1 or 0) and `T_reached/100` (the dimensionless time
/// reached, over 100 so the Markdown table's 100 × prints it).
inline void record_completion(run_outcome& o, bool failed, double T_reached, const std::string& why = "") {
  if (failed) {
    std::ostringstream f;
    f << "at T = " << T_reached << ": " << why;
    o.failure = f.str();
    for (metric& m : o.errors) m.value = std::nan("");
  }
  o.errors.push_back({"completed", failed ? 0.0 : 1.0});
  o.errors.push_back({"T_reached/100", T_reached / 100.0});
}

/// A configuration: a name, a series it belongs to (one plotted line, e.g. the solver), its spacing,
/// and the run itself.
struct configuration {
  std::string name;                   ///< row name, e.g. "cg_ichol a/20"
  std::string series;                 ///< plot series (configurations of one series are joined)
  double l0 = 0.0;                    ///< particle spacing (m)
  std::function<run_outcome()> run;   ///< runs the case once
};

/// One row of the report.
struct run_record {
  std::string name, series;
  double l0 = 0.0;
  index_t particles = 0;
  long steps = 0;
  std::vector<double> wall_seconds;    ///< every repetition
  double wall_median = 0.0;            ///< median of wall_seconds
  double particle_steps_per_second = 0.0;  ///< particles × steps / median wall time
  double ppe_iterations_mean = 0.0;    ///< PPE iterations per step
  std::vector<metric> errors;          ///< from the first repetition (runs are deterministic)
  std::string failure;                 ///< the run's failure (empty: completed); a failed run is not repeated
};

/// Median of a non-empty list.
inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Seconds of the steady clock since t0.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Command-line numbers (parse_number, parse_numbers, whole_number, parse_integer, parse_integers): shared
// with the examples, examples/cases/cli.hpp.
using cases::parse_integer;
using cases::parse_integers;
using cases::parse_number;
using cases::parse_numbers;
using cases::whole_number;

/// Options of the own-main timing benchmarks: --repetitions R (≥ 1) and --t-end T (s, > 0), plus any `extra`
/// options taking one value (their values land in `extra_values`, by name). Returns false after printing the
/// reason to stderr (`program` names it) on an unknown or incomplete option or a bad value.
struct run_options {
  int repetitions = 3;
  double t_end = 0.02;
  std::map<std::string, std::string> extra_values;
  bool parse(int argc, char** argv, const char* program, const std::vector<std::string>& extra = {}) {
    for (int a = 1; a < argc; ++a) {
      const std::string arg = argv[a];
      if (a + 1 >= argc) {
        std::fprintf(stderr, "%s: unknown or incomplete option '%s'\n", program, arg.c_str());
        return false;
      }
      try {
        if (arg == "--repetitions") {
          repetitions = parse_integer("--repetitions", argv[++a], 1);
          continue;
        }
        if (arg == "--t-end") {
          t_end = parse_number("--t-end", argv[++a], 0.0);
          continue;
        }
      } catch (const mpskit::error& e) {
        std::fprintf(stderr, "%s: %s\n", program, e.what());
        return false;
      }
      if (arg.rfind("--", 0) == 0 && std::find(extra.begin(), extra.end(), arg.substr(2)) != extra.end()) {
        extra_values[arg.substr(2)] = argv[++a];
      } else {
        std::fprintf(stderr, "%s: unknown or incomplete option '%s'\n", program, arg.c_str());
        return false;
      }
    }
    if (repetitions < 1 || !(t_end > 0.0)) {
      std::fprintf(stderr, "%s: --repetitions must be >= 1 and --t-end > 0\n", program);
      return false;
    }
    return true;
  }
};

/// Runs configurations, keeps records, writes CSV / Markdown / PNG.
class reporter {
 public:
  /// `case_name` titles the outputs; `repetitions` ≥ 1 runs per configuration (median wall time).
  explicit reporter(std::string case_name, int repetitions = 3)
      : case_(std::move(case_name)), reps_(repetitions) {
    if (repetitions < 1) fail("reporter: repetitions = ", repetitions, " must be >= 1");
  }
  /// Adds a configuration.
  void add(configuration c) {
    if (!c.run) fail("reporter: configuration '", c.name, "' has no run function");
    configs_.push_back(std::move(c));
  }
  /// Runs every configuration `repetitions` times, logging each run to `log`.
  const std::vector<run_record>& run_all(std::ostream& log = std::cout) {
    records_.clear();
    for (const configuration& c : configs_) {
      run_record r;
      r.name = c.name;
      r.series = c.series;
      r.l0 = c.l0;
      for (int k = 0; k < reps_; ++k) {
        const run_outcome o = c.run();
        if (k == 0) {
          r.particles = o.particles;
          r.steps = o.steps;
          r.errors = o.errors;
          r.ppe_iterations_mean = o.steps > 0 ? double(o.ppe_iterations) / double(o.steps) : 0.0;
        } else if (o.steps != r.steps) {
          fail("reporter: '", c.name, "' took ", o.steps, " steps in repetition ", k, ", ", r.steps,
               " in the first (runs must be deterministic)");
        }
        r.wall_seconds.push_back(o.wall_seconds);
        log << "  " << c.name << " run " << k + 1 << "/" << reps_ << ": " << o.wall_seconds << " s, "
            << o.steps << " steps" << std::endl;
        if (!o.failure.empty()) {
          // Runs are deterministic: a repetition would fail the same way, so the study goes on with the next
          // configuration; the record keeps the failure and the caller's metrics (NaN where not comparable).
          r.failure = o.failure;
          log << "  " << c.name << ": failed " << o.failure << " (not repeated)" << std::endl;
          break;
        }
      }
      r.wall_median = median(r.wall_seconds);
      r.particle_steps_per_second = double(r.particles) * double(r.steps) / r.wall_median;
      records_.push_back(std::move(r));
    }
    return records_;
  }
  /// The records of the last run_all.
  const std::vector<run_record>& records() const { return records_; }

  /// Writes one CSV row per configuration (header: name, series, l0 [m], particles, steps,
  /// wall_median [s], wall_min [s], wall_max [s], particle_steps_per_s, ppe_iterations_mean, errors...).
  void write_csv(const std::filesystem::path& path) const {
    std::ofstream f(path);
    if (!f) fail("reporter: cannot write '", path.string(), "'");
    f << std::setprecision(10);
    f << "name,series,l0 [m],particles,steps,wall_median [s],wall_min [s],wall_max [s],particle_steps_per_s,"
         "ppe_iterations_mean";
    for (const std::string& m : metric_names()) f << ',' << m;
    f << '\n';
    for (const run_record& r : records_) {
      f << r.name << ',' << r.series << ',' << r.l0 << ',' << r.particles << ',' << r.steps << ','
        << r.wall_median << ',' << *std::min_element(r.wall_seconds.begin(), r.wall_seconds.end()) << ','
        << *std::max_element(r.wall_seconds.begin(), r.wall_seconds.end()) << ','
        << r.particle_steps_per_second << ',' << r.ppe_iterations_mean;
      for (const std::string& m : metric_names()) f << ',' << value(r, m);
      f << '\n';
    }
    if (!f) fail("reporter: writing '", path.string(), "' failed");
  }

  /// A Markdown table of the records (errors in %).
  std::string markdown_table() const {
    std::ostringstream o;
    o << "| configuration | l0 (m) | particles | steps | wall median (s) | particle-steps/s | PPE iter./step "
         "|";
    for (const std::string& m : metric_names()) o << ' ' << m << " (%) |";
    o << "\n|---|---|---|---|---|---|---|";
    for (std::size_t k = 0; k < metric_names().size(); ++k) o << "---|";
    o << '\n';
    for (const run_record& r : records_) {
      o << "| " << r.name << (r.failure.empty() ? "" : " (failed)") << " | " << std::setprecision(4) << r.l0
        << " | " << r.particles << " | " << r.steps << " | " << std::fixed << std::setprecision(2)
        << r.wall_median << " | " << std::setprecision(0) << r.particle_steps_per_second << " | "
        << std::setprecision(1) << r.ppe_iterations_mean << " |";
      for (const std::string& m : metric_names())
        o << ' ' << std::setprecision(2) << 100.0 * value(r, m) << " |";
      o << std::defaultfloat << '\n';
    }
    return o.str();
  }

  /// Plots `metric_name` against median wall time (log scale), one line per series, each point labelled
  /// with its configuration name minus the series prefix; writes `<png>.dat` and `<png>.gp` beside the
  /// PNG and runs gnuplot. `log_y` puts the metric on a log scale too. Returns false (with a message on
  /// `log`) when no run has a value to plot (finite, and > 0 with log_y: e.g. a study of the reference alone,
  /// whose error against itself is 0), or when gnuplot is missing or fails.
  bool write_plot(const std::filesystem::path& png, const std::string& metric_name,
                  std::ostream& log = std::cout, bool log_y = false) const {
    if (std::none_of(records_.begin(), records_.end(), [&](const run_record& r) {
          const double v = value(r, metric_name);
          return std::isfinite(v) && std::isfinite(r.wall_median) && r.wall_median > 0.0 &&
                 (!log_y || v > 0.0);
        })) {
      log << "reporter: no run has a " << (log_y ? "positive " : "") << "finite " << metric_name
          << " to plot: no picture '" << png.string() << "'\n";
      return false;
    }
    std::map<std::string, std::vector<const run_record*>> by_series;
    std::vector<std::string> order;
    for (const run_record& r : records_) {
      if (!by_series.count(r.series)) order.push_back(r.series);
      by_series[r.series].push_back(&r);
    }
    const std::filesystem::path dat = png.string() + ".dat", gp = png.string() + ".gp";
    {
      std::ofstream d(dat);
      if (!d) fail("reporter: cannot write '", dat.string(), "'");
      d << std::setprecision(10);
      for (const std::string& s : order) {
        d << "# series " << s << ": wall_median [s], " << metric_name << ", label\n";
        for (const run_record* r : by_series[s]) {
          std::string label = r->name;
          if (label.rfind(s + " ", 0) == 0) label = label.substr(s.size() + 1);
          d << r->wall_median << ' ' << value(*r, metric_name) << " \"" << label << "\"\n";
        }
        d << "\n\n";
      }
    }
    {
      std::ofstream g(gp);
      if (!g) fail("reporter: cannot write '", gp.string(), "'");
      g << "set terminal pngcairo size 900,600 font 'sans,11' noenhanced\n"
        << "set output '" << png.string() << "'\n"
        << "set title '" << gp_quoted(case_) << ": " << metric_name
        << " against wall time (median of runs)'\n"
        << "set xlabel 'wall time (s)'\nset ylabel '" << metric_name << "'\n"
        << (log_y ? "set logscale xy\n" : "set logscale x\n")
        << "set grid\nset key top left\nset offsets graph 0.05, graph 0.05, graph 0.15, graph 0.15\n"
        << "plot ";
      for (std::size_t k = 0; k < order.size(); ++k) {
        const char* off = k % 2 ? "offset 0,-1.2" : "offset 0,1.2";
        g << (k ? ", \\\n     " : "") << "'" << dat.string() << "' index " << k
          << " using 1:2 with linespoints pt 7 title '" << gp_quoted(order[k]) << "', '' index " << k
          << " using 1:2:3 with labels " << off << " notitle";
      }
      g << "\n";
    }
    const std::string cmd = "gnuplot '" + gp.string() + "'";
    if (std::system(cmd.c_str()) != 0) {
      log << "reporter: '" << cmd << "' failed (its message is above; is gnuplot installed? apt-get install "
             "gnuplot-nox)\n";
      return false;
    }
    return true;
  }

  /// The error metric `name` of a record (NaN when it has none).
  static double value(const run_record& r, const std::string& name) {
    for (const metric& m : r.errors)
      if (m.name == name) return m.value;
    return std::nan("");
  }

 private:
  /// Text inside a gnuplot single-quoted string: a quote is written twice (a series named "Tanaka's ..."
  /// broke the script).
  static std::string gp_quoted(const std::string& t) {
    std::string q;
    for (const char ch : t) {
      q += ch;
      if (ch == '\'') q += '\'';
    }
    return q;
  }
  std::vector<std::string> metric_names() const {
    std::vector<std::string> n;
    for (const run_record& r : records_)
      for (const metric& m : r.errors)
        if (std::find(n.begin(), n.end(), m.name) == n.end()) n.push_back(m.name);
    return n;
  }

  std::string case_;
  int reps_;
  std::vector<configuration> configs_;
  std::vector<run_record> records_;
};

}  // namespace mpskit::bench
