// Speed against error on plane Poiseuille flow (Tanaka 2018 §5.2 / §4.5.2; examples/cases/poiseuille.hpp)
// with the LSMPS scheme: the channel periodic in x driven by G/ρ, and the 20 mm channel driven by pressure
// inflow/outflow boundaries, over spacings L; errors at t_end against the start-up series and the steady
// profile (max over rows / u_max), and the wall time, as CSV, Markdown and PNG (benchmarks/reporter.hpp).
// Δt = 0.1 L²/ν (the viscous limit; the Courant limit at L = 1 mm), so the cost grows as L⁻⁴ in 2D. Run from
// the repository root with one thread:
//
//   OMP_NUM_THREADS=1 build/benchmarks/bench_report_poiseuille --levels 1,0.5,0.25 --repetitions 3
//
// Options: --levels L1,L2,... (mm), --repetitions R, --t-end T (s, default 0.5), --out DIR (default
// benchmarks/results), --cases periodic,pressure, --multires on (adds the 2:1 multi-resolution runs of
// docs/resolution.md; results to poiseuille_multires_speed_error.*).
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cases/poiseuille.hpp"
#include "mpskit/resolution/split_merge.hpp"
#include "reporter.hpp"
#include "speed_up.hpp"

using namespace mpskit;

namespace {

cases::poiseuille_config config(double L_mm, double t_end) {
  cases::poiseuille_config c;
  c.L = L_mm * 1e-3;
  // 0.1 L²/ν (viscous limit), or the Courant limit 0.1 L/|u| with |u| up to 1.2 u_max where that is smaller
  // (L ≥ 0.75 mm)
  c.dt = std::min(2.5e-4 * (c.L / 0.5e-3) * (c.L / 0.5e-3), 0.1 * c.L / (1.2 * 0.125));
  c.t_end = t_end;
  c.probe_times = {};
  return c;
}

/// The reporter's outcome of a finished run (pressure: with the pressure-profile error). Particles: the count
/// at the end (in/outflow and splits change it; the first committed table listed the initial counts).
template <class Result>
bench::run_outcome outcome_of(const Result& r, bool pressure) {
  bench::run_outcome o;
  o.particles = r.particles_end;
  o.steps = r.steps;
  o.wall_seconds = r.wall_seconds;
  o.ppe_iterations = r.ppe_iterations;
  o.errors = {{"series", r.end.max_error}, {"steady", r.steady_error}};
  if constexpr (requires { r.pressure_error; })
    if (pressure) o.errors.push_back({"pressure", r.pressure_error});
  return o;
}

struct periodic_multires_scene : cases::poiseuille_scene {
  using resolution = mpskit::resolution::split_merge<>;
};
struct pressure_multires_scene : cases::poiseuille_pressure_scene {
  using resolution = mpskit::resolution::split_merge<>;
};

/// Multi-resolution 2:1 (docs/resolution.md, label poiseuille_multires): from the 0.5 mm lattice,
/// L* = 0.25 mm within 1.5 mm of a wall, a ramp to 0.525 mm at 3.5 mm; Δt = 0.1 (0.24 mm)²/ν (pressure faces:
/// the smallest boundary piece is 0.248 mm) or 0.1 (0.25 mm)²/ν (periodic).
bench::configuration make_multires(bool pressure, double t_end) {
  bench::configuration b;
  b.series = pressure ? "pressure boundaries 20 mm 2:1" : "periodic body force 2:1";
  b.name = b.series + " 0.25-0.5mm";
  b.l0 = 0.25e-3;
  b.run = [pressure, t_end]() {
    cases::poiseuille_config c;
    c.t_end = t_end;
    c.probe_times = {};
    const double Lf = 0.25e-3, H = c.H, Lc = c.L;
    const auto target = [=](const vec<2>& x) {
      const double d = std::min(x[1], H - x[1]);
      return Lf + std::clamp((d - 1.5e-3) / 2e-3, 0.0, 1.0) * (1.05 * Lc - Lf);
    };
    c.params.resolution.target_diameter = target;
    bench::run_outcome o;
    if (pressure) {
      c.length = 0.02;
      c.dt = 0.1 * 0.24e-3 * 0.24e-3 / (c.mu / c.rho);
      c.boundary_spacing = [=](const vec<2>& x) { return std::min(Lc, target(x)); };
      o = outcome_of(cases::run_poiseuille_pressure<pressure_multires_scene>(c), true);
    } else {
      c.length = 0.005;
      c.dt = 0.1 * Lf * Lf / (c.mu / c.rho);
      o = outcome_of(cases::run_poiseuille_periodic<periodic_multires_scene>(c), false);
    }
    return o;
  };
  return b;
}

bench::configuration make(bool pressure, double L_mm, double t_end) {
  bench::configuration b;
  b.series = pressure ? "pressure boundaries 20 mm" : "periodic body force";
  std::ostringstream name;
  name << b.series << " L=" << L_mm << "mm";
  b.name = name.str();
  b.l0 = L_mm * 1e-3;
  b.run = [pressure, L_mm, t_end]() {
    auto c = config(L_mm, t_end);
    bench::run_outcome o;
    if (pressure) {
      c.length = 0.02;
      o = outcome_of(cases::run_poiseuille_pressure(c), true);
    } else {
      c.length = std::max(0.005, 10.0 * c.L);  // a period > 2 R_e L (1 + skin)
      o = outcome_of(cases::run_poiseuille_periodic(c), false);
    }
    return o;
  };
  return b;
}

}  // namespace

int main(int argc, char** argv) try {
  std::vector<double> levels{1.0, 0.5};
  int reps = 1;
  double t_end = 0.5;
  bool periodic = true, pressure = true, multires = false;
  std::string out = "benchmarks/results";
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a], v = argv[a + 1];
    if (k == "--levels") levels = bench::parse_numbers("--levels", v, 1e-9);
    else if (k == "--repetitions") reps = bench::parse_integer("--repetitions", v, 1);
    else if (k == "--t-end") t_end = bench::parse_number("--t-end", v, 1e-12);
    else if (k == "--out") out = v;
    else if (k == "--multires") multires = v == "1" || v == "on";
    else if (k == "--cases") {
      periodic = v.find("periodic") != std::string::npos;
      pressure = v.find("pressure") != std::string::npos;
    } else fail("report_poiseuille: unknown option '", k, "'");
  }
  std::cout << "report_poiseuille (" << MPSKIT_BENCH_FLAGS << "), t_end = " << t_end << " s\n";
  bench::reporter rep("Poiseuille", reps);
  for (double L : levels) {
    if (periodic) rep.add(make(false, L, t_end));
    if (pressure) rep.add(make(true, L, t_end));
  }
  if (multires) {
    if (periodic) rep.add(make_multires(false, t_end));
    if (pressure) rep.add(make_multires(true, t_end));
  }
  rep.run_all(std::cout);
  std::filesystem::create_directories(out);
  const std::string stem = multires ? "poiseuille_multires_speed_error" : "poiseuille_speed_error";
  const std::filesystem::path csv = std::filesystem::path(out) / (stem + ".csv");
  const std::filesystem::path png = std::filesystem::path(out) / (stem + ".png");
  rep.write_csv(csv);
  std::cout << "\n" << rep.markdown_table() << "\nwrote " << csv.string() << "\n";
  if (multires) {
    // Issue #9's speed-up: the single-resolution time for each multi-resolution run's error against the
    // series, on the single-resolution curve of the same case measured in this run (bench::speed_up: log-log
    // interpolation, a bound outside the measured range).
    const std::filesystem::path su = std::filesystem::path(out) / (stem + "_speed_up.csv");
    std::ofstream f(su);
    f << "multires,multires_wall_median_s,multires_error_series,single_runs,kind,single_seconds,speed_up,"
         "dominated\n";
    for (const bench::run_record& m : rep.records()) {
      const auto at = m.series.rfind(" 2:1");
      if (at == std::string::npos) continue;
      const std::string base = m.series.substr(0, at);
      std::vector<bench::cost_point> curve;
      for (const bench::run_record& r : rep.records())
        if (r.series == base) curve.push_back({r.wall_median, bench::reporter::value(r, "series")});
      if (curve.empty()) continue;
      const bench::speed_up_result s =
          bench::speed_up(curve, {m.wall_median, bench::reporter::value(m, "series")});
      std::cout << m.name << ": single resolution needs " << s.bound_prefix() << s.single_seconds
                << " s for its error; speed-up " << s.kind_name() << " " << s.speed_up << s.dominated_note()
                << "\n";
      f << m.name << "," << m.wall_median << "," << bench::reporter::value(m, "series") << "," << curve.size()
        << "," << s.kind_name() << "," << s.single_seconds << "," << s.speed_up << "," << s.dominated << "\n";
    }
    std::cout << "wrote " << su.string() << "\n";
  }
  if (rep.write_plot(png, "series", std::cout, true)) std::cout << "wrote " << png.string() << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << e.what() << "\n";
  return 1;
}
