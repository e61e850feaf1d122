// Speed against error on Tanaka's dam break with the 10 × 10 mm obstacle (§5.6.2; issue #9 "Speed against
// error", reduced): single resolution over spacings and the main example's multi-resolution run (coarse L, L/ratio
// around the block; examples/cases/tanaka_obstacle_multires.hpp), each with its front error against a finer
// single-resolution reference run once first, to T_end. Writes CSV, Markdown and PNG (benchmarks/reporter.hpp)
// and the speed-up of each multi-resolution run at equal front error (benchmarks/speed_up.hpp). Run from the
// repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/bench/benchmarks/bench_report_obstacle_multires --repetitions 3
//
// Options: --reference mm (default 2.5: the finest spacing whose single run gets over the block, docs/resolution.md),
// --single L1,L2,... (mm, default 5,4,3.33), --multi L/ratio,... (default 5/2), --T T_end (default 2.4),
// --repetitions R (default 3), --out DIR (default benchmarks/results), --walls NAME (a name of
// cases::tanaka_wall_variants; default cases::obstacle_walls, the main example's). Results: obstacle_multires_speed_error.*
// and obstacle_multires_speed_up.csv. Not the study (1 mm reference to t = 0.4 s through the far-wall
// impact, which no spacing gets through yet: issue #7).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cases/tanaka_obstacle_multires.hpp"
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
  const double v = bench::parse_number(what, s, 0.0);
  if (!(v > 0.0)) fail("report_obstacle_multires: ", what, " '", s, "': need a number > 0");
  return v;
}

bench::run_outcome outcome_of(const cases::tanaka_dam_break_result& r, const cases::tanaka_dam_break_result& ref,
                              const char* name) {
  if (r.failed) fail("report_obstacle_multires: '", name, "' failed at T = ", r.T_failed, ": ", r.failure);
  const cases::front_difference d = cases::compare_fronts(r, ref);
  bench::run_outcome o;
  o.particles = r.particles_end;
  o.steps = r.steps;
  o.wall_seconds = r.wall_seconds;
  o.ppe_iterations = r.ppe_iterations;
  o.errors = {{"front_rms", d.rms}, {"front_max", d.max}};
  return o;
}

}  // namespace

int main(int argc, char** argv) try {
  double ref_mm = 2.5, T_end = 2.4;
  std::vector<double> singles{5.0, 4.0, 10.0 / 3.0};
  std::vector<std::pair<double, double>> multis{{5.0, 2.0}};
  int reps = 3;
  std::string out = "benchmarks/results", walls = cases::obstacle_walls;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a], v = argv[a + 1];
    if (k == "--reference") ref_mm = number(v, "--reference");
    else if (k == "--T") T_end = number(v, "--T");
    else if (k == "--repetitions") reps = bench::parse_integer("--repetitions", v, 1);
    else if (k == "--out") out = v;
    else if (k == "--walls") walls = v;  // checked by obstacle_params below, before any run
    else if (k == "--single") {
      singles.clear();
      for (const std::string& s : split(v)) singles.push_back(number(s, "--single"));
    } else if (k == "--multi") {
      multis.clear();
      for (const std::string& s : split(v)) {
        const auto slash = s.find('/');
        if (slash == std::string::npos) fail("report_obstacle_multires: --multi '", s, "': need L/ratio, e.g. 5/2");
        multis.push_back({number(s.substr(0, slash), "--multi L"), number(s.substr(slash + 1), "--multi ratio")});
      }
    } else fail("report_obstacle_multires: unknown option '", k, "' (--reference, --single, --multi, --T, --repetitions, --out, --walls)");
  }
  if (argc % 2 == 0) fail("report_obstacle_multires: option '", argv[argc - 1], "' has no value");
  const scheme::lsmps_params<2> p = cases::obstacle_params(walls);
  std::cout << "report_obstacle_multires (" << MPSKIT_BENCH_FLAGS << "), to T = " << T_end << ", reference "
            << ref_mm << " mm, walls '" << walls << "'\n";
  const cases::tanaka_dam_break_result ref = cases::run_tanaka_dam_break(cases::tanaka_obstacle_config(1e-3 * ref_mm), T_end, p, true);
  if (ref.failed) fail("report_obstacle_multires: the reference (", ref_mm, " mm) failed at T = ", ref.T_failed, ": ", ref.failure);
  std::cout << "  reference " << ref_mm << " mm: " << ref.particles << " particles, " << ref.steps << " steps, "
            << ref.wall_seconds << " s\n";

  bench::reporter rep("Dam break with the obstacle, front against " + std::to_string(ref_mm).substr(0, 4) + " mm", reps);
  for (const double L : singles) {
    std::ostringstream name;
    name << "single " << L << " mm";
    rep.add({name.str(), "single", 1e-3 * L, [=, &ref, n = name.str()] {
               return outcome_of(cases::run_tanaka_dam_break(cases::tanaka_obstacle_config(1e-3 * L), T_end, p, true), ref, n.c_str());
             }});
  }
  for (const auto& [L, ratio] : multis) {
    std::ostringstream name;
    name << "multi " << L << "/" << L / ratio << " mm";
    rep.add({name.str(), "multi", 1e-3 * L, [=, &ref, n = name.str()] {
               const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(1e-3 * L);
               scheme::lsmps_params<2> pm = p;
               cases::refine_around_block(pm, c, ratio, 0.03, 0.06);
               return outcome_of(cases::run_tanaka_dam_break<cases::obstacle_multires_scene>(c, T_end, pm, true), ref, n.c_str());
             }});
  }
  rep.run_all(std::cout);
  std::filesystem::create_directories(out);
  const std::filesystem::path dir(out);
  rep.write_csv(dir / "obstacle_multires_speed_error.csv");
  std::cout << "\n" << rep.markdown_table() << "\n";
  // Issue #9's speed-up: the single-resolution time for each multi-resolution run's RMS front error, on the
  // single-resolution curve measured in this run (log-log interpolation, a bound outside the measured range).
  std::vector<bench::cost_point> curve;
  for (const bench::run_record& r : rep.records())
    if (r.series == "single") curve.push_back({r.wall_median, bench::reporter::value(r, "front_rms")});
  std::ofstream f(dir / "obstacle_multires_speed_up.csv");
  f << "# reference: single resolution " << ref_mm << " mm to T = " << T_end << ", " << ref.wall_seconds << " s\n";
  f << "multires,multires_wall_median_s,multires_front_rms,single_runs,kind,single_seconds,speed_up,dominated\n";
  for (const bench::run_record& m : rep.records()) {
    if (m.series != "multi" || curve.empty()) continue;
    const double e = bench::reporter::value(m, "front_rms");
    const bench::speed_up_result s = bench::speed_up(curve, {m.wall_median, e});
    std::cout << m.name << ": single resolution needs " << s.bound_prefix() << s.single_seconds
              << " s for its front error; speed-up " << s.kind_name() << " " << s.speed_up << s.dominated_note() << "\n";
    f << m.name << "," << m.wall_median << "," << e << "," << curve.size() << "," << s.kind_name() << "," << s.single_seconds
      << "," << s.speed_up << "," << s.dominated << "\n";
  }
  if (rep.write_plot(dir / "obstacle_multires_speed_error.png", "front_rms", std::cout, true))
    std::cout << "wrote " << (dir / "obstacle_multires_speed_error.png").string() << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << e.what() << "\n";
  return 1;
}
