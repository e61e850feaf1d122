// Speed against error on the inviscid Taylor–Green vortex (Tanaka 2018 §5.4; examples/cases/taylor_green.hpp)
// with the LSMPS scheme: for each operator order and resolution N×N, the energy drift, the mean-free
// pressure error and the velocity error against eqs. 102–104 at t_end, and the wall time, as CSV, Markdown
// and PNG (benchmarks/reporter.hpp). Run from the repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_report_taylor_green --levels 25,50,100 --repetitions 3
//
// Options: --levels N1,N2,... (particles per side), --orders 2[,3] (LSMPS-A order), --repetitions R,
// --t-end T (s, default 0.5), --out DIR (default benchmarks/results).
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cases/taylor_green.hpp"
#include "reporter.hpp"

using namespace mpskit;

namespace {

struct order3_scene : cases::taylor_green_scene {
  using op = mpskit::op::lsmps_a<2, 3, kernel>;
};

template <class Scene>
bench::configuration make(int order, int n, double t_end) {
  bench::configuration c;
  c.series = "LSMPS-A order " + std::to_string(order);
  c.name = c.series + " " + std::to_string(n) + "^2";
  c.l0 = 1.0 / n;
  c.run = [n, t_end]() {
    cases::taylor_green_config cfg;
    cfg.n = n;
    cfg.t_end = t_end;
    const auto r = cases::run_taylor_green<Scene>(cfg);
    bench::run_outcome o;
    o.particles = r.particles;
    o.steps = r.steps;
    o.wall_seconds = r.wall_seconds;
    o.ppe_iterations = r.ppe_iterations;
    o.errors = {{"energy_drift", std::abs(r.energy_drift)},
                {"pressure_mean", r.pressure_error_mean},
                {"pressure_max", r.pressure_error},
                {"velocity", r.velocity_error}};
    return o;
  };
  return c;
}

}  // namespace

int main(int argc, char** argv) try {
  std::vector<int> levels{25, 50}, orders{2, 3};
  int reps = 1;
  double t_end = 0.5;
  std::string out = "benchmarks/results";
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a], v = argv[a + 1];
    if (k == "--levels") levels = bench::parse_integers("--levels", v, 2);
    else if (k == "--orders") orders = bench::parse_integers("--orders", v, 1);
    else if (k == "--repetitions") reps = bench::parse_integer("--repetitions", v, 1);
    else if (k == "--t-end") t_end = bench::parse_number("--t-end", v, 1e-12);
    else if (k == "--out") out = v;
    else fail("report_taylor_green: unknown option '", k, "'");
  }
  std::cout << "report_taylor_green (" << MPSKIT_BENCH_FLAGS << "), t_end = " << t_end << " s\n";
  bench::reporter rep("Taylor-Green vortex", reps);
  for (int order : orders)
    for (int n : levels) {
      if (order == 2) rep.add(make<cases::taylor_green_scene>(2, n, t_end));
      else if (order == 3) rep.add(make<order3_scene>(3, n, t_end));
      else fail("report_taylor_green: order ", order, " (accepted: 2, 3)");
    }
  rep.run_all(std::cout);
  std::filesystem::create_directories(out);
  const std::filesystem::path csv = std::filesystem::path(out) / "taylor_green_speed_error.csv";
  const std::filesystem::path png = std::filesystem::path(out) / "taylor_green_speed_error.png";
  rep.write_csv(csv);
  std::cout << "\n" << rep.markdown_table() << "\nwrote " << csv.string() << "\n";
  if (rep.write_plot(png, "energy_drift", std::cout, true)) std::cout << "wrote " << png.string() << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << e.what() << "\n";
  return 1;
}
