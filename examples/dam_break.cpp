// The classic MPS dam break (the main example until issue #9; now examples/multires_dam_break.cpp): 2D dam
// break (Koshizuka & Oka 1996 set-up: column a × 2a, a = 0.146 m, tank 4a) with the default classic scene
// (mpskit::defaults<2>). Writes to out/dam_break/:
//   dam_break.pvd + dam_break_*.vtu   ParaView series (every 0.25 in T), all particle fields
//   front.csv                          surge front Z(T) with the data band
//   loads.csv                          every step: integrals (volume, mass, energies) and wall loads
//   particles.png, front.png           pictures (gnuplot, when installed)
// and prints a one-screen summary. Usage: dam_break [--full] [--out DIR] [--data DIR]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include "cases/dam_break.hpp"
#include "mpskit/io/csv.hpp"
#include "mpskit/io/probes.hpp"
#include "mpskit/io/progress.hpp"
#include "mpskit/io/vtk.hpp"

namespace fs = std::filesystem;
using namespace mpskit;

int main(int argc, char** argv) {
  cases::dam_break_config cfg;
  std::string data = MPSKIT_DATA_DIR, out = "out/dam_break";
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--full")) cfg.l0 = cfg.a / 40;
    else if (!std::strcmp(argv[a], "--out") && a + 1 < argc) out = argv[++a];
    else if (!std::strcmp(argv[a], "--data") && a + 1 < argc) data = argv[++a];
    else { std::fprintf(stderr, "usage: %s [--full] [--out DIR] [--data DIR]\n", argv[0]); return 2; }
  }
  try {
    const std::vector<cases::front_series> ref = cases::read_front_data(data);
    fs::create_directories(out);
    io::vtk_series vtk(fs::path(out) / "dam_break");
    io::progress_sink progress(std::cerr, 1.0);
    io::run_counters counters;
    const double tscale = std::sqrt(2.0 * 9.81 / cfg.a);
    const auto t0 = std::chrono::steady_clock::now();
    double next_vtk = 0.0;
    io::step_iterations step_its;
    std::vector<io::csv_column> cols = io::flow_integrals::columns(2);
    for (const char* c : {"right_wall_x", "bottom_y", "left_wall_x"}) cols.push_back({c, "N/m"});
    io::csv_writer loads(fs::path(out) / "loads.csv", cols, io::csv_mode::truncate,
                         {"wall loads from the antisymmetric MPS pair form (docs/solver.md)"});
    const auto r = cases::run_dam_break<defaults<2>>(cfg, [&](const auto& sim) {
      const auto& c = sim.counters();
      const index_t step_it = step_its(c.ppe_iterations);  // every solve of the step
      counters.record_step(
          sim.state().n_real(), step_it, 0, 0,
          static_cast<index_t>(std::count_if(sim.state().flags().begin(), sim.state().flags().end(),
                                             [](flag::type f) { return (f & flag::isolated) != 0; })));
      {
        const auto& st = sim.state();
        std::vector<double> row =
            io::integrals(st, sim.params().rho, sim.params().g, cfg.l0 * cfg.l0).values(sim.time());
        row.push_back(sim.wall_force([&](index_t i) { return st.x()(0, i) > 4 * cfg.a; })[0]);
        row.push_back(sim.wall_force([&](index_t i) { return st.x()(1, i) < 0.0; })[1]);
        row.push_back(sim.wall_force([&](index_t i) { return st.x()(0, i) < 0.0; })[0]);
        loads.row(row);
      }
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      progress.update(
          {sim.time(), cfg.T_end / tscale, c.steps, sim.dt(), step_it, sim.state().n_real(), wall});
      if (sim.time() * tscale + 1e-9 >= next_vtk) {
        vtk.write(sim.state(), sim.time(), c.steps);
        next_vtk += 0.25;
      }
      if (sim.time() * tscale + 1e-9 >= cfg.T_end) {  // last step: particle snapshot for the picture
        std::ofstream snap(fs::path(out) / "particles.dat");
        const auto& st = sim.state();
        for (index_t i = 0; i < st.n_real(); ++i)
          snap << st.x()(0, i) << ' ' << st.x()(1, i) << ' ' << st.template get<field::pressure>()[i] << ' '
               << int(st.kinds()[static_cast<std::size_t>(i)]) << '\n';
      }
    });
    progress.finish();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    {
      io::csv_writer csv(fs::path(out) / "front.csv",
                         {{"T", "1"}, {"Z", "1"}, {"band_low", "1"}, {"band_high", "1"}});
      for (std::size_t k = 0; k < r.T.size(); ++k) {
        const auto [lo, hi] = cases::front_band(ref, r.T[k]);
        csv.row({r.T[k], r.Z[k], lo, hi});
      }
    }
    // Pictures through gnuplot (Debian's gnuplot-nox; scripts/deps.sh installs it).
    const std::string gp = (fs::path(out) / "plot.gp").string();
    {
      std::ofstream g(gp);
      g << "set terminal pngcairo size 1000,500\nset datafile separator whitespace\n"
        << "set output '" << (fs::path(out) / "particles.png").string() << "'\n"
        << "set size ratio -1\nset title 'dam break at T = " << cfg.T_end
        << ": particles coloured by pressure (Pa)'\n"
        << "set xlabel 'x (m)'\nset ylabel 'y (m)'\nset palette rgbformulae 33,13,10\n"
        << "plot '" << (fs::path(out) / "particles.dat").string()
        << "' using 1:2:3 with points pt 7 ps 0.5 palette notitle\n"
        << "set output '" << (fs::path(out) / "front.png").string()
        << "'\nset size noratio\nset datafile separator ','\n"
        << "set title 'surge front: mpskit against Martin and Moyce (1952), Koshizuka and Oka (1996)'\n"
        << "set xlabel 'T = t sqrt(2g/a)'\nset ylabel 'Z = z/a'\nset key left top\nset xrange [0:"
        << cfg.T_end + 0.5 << "]\nset yrange [0:5]\n"
        << "plot '" << (fs::path(out) / "front.csv").string()
        << "' using 1:2 every ::1 with lines lw 2 title 'mpskit (l0 = a/" << std::lround(cfg.a / cfg.l0)
        << ")', '" << data
        << "/martin_moyce_1952_a1.125in.csv' using 1:2 every ::1 with points pt 5 title 'Martin and Moyce, a "
           "= 1.125 in', '"
        << data
        << "/martin_moyce_1952_a2.25in.csv' using 1:2 every ::1 with points pt 7 title 'Martin and Moyce, a "
           "= 2.25 in', '"
        << data
        << "/koshizuka_oka_1996.csv' using 1:2 every ::1 with points pt 9 title 'Koshizuka and Oka (1996)'\n";
    }
    const bool pictures = std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str()) == 0;
    int outside = 0, compared = 0;
    double worst = 0.0;
    for (std::size_t k = 0; k < r.T.size(); ++k) {
      const auto [lo, hi] = cases::front_band(ref, r.T[k]);
      if (std::isnan(lo)) continue;
      ++compared;
      outside += r.Z[k] < lo || r.Z[k] > hi;
      const double mid = 0.5 * (lo / 0.9 + hi / 1.1);
      worst = std::max(worst, std::abs(r.Z[k] - mid) / mid);
    }
    std::printf("\nmpskit dam break (Koshizuka & Oka set-up, classic MPS scene)\n");
    std::printf("  column %.3f x %.3f m, tank %.3f m, l0 = %.4f m (a/%ld): %ld particles, %ld fluid\n", cfg.a,
                2 * cfg.a, 4 * cfg.a, cfg.l0, std::lround(cfg.a / cfg.l0), long(r.particles), long(r.fluid));
    std::printf(
        "  front Z(T) for T <= %.1f: %d of %d samples inside the data band (+-10%%); largest distance to the "
        "band's centre %.1f %%\n",
        cfg.T_end, compared - outside, compared, 100.0 * worst);
    std::printf("  Z(T=%.2f) = %.3f; fluid stayed in the tank: %s; particles conserved: %s\n", r.T.back(),
                r.Z.back(), r.inside_tank ? "yes" : "NO", r.fluid_end == r.fluid ? "yes" : "NO");
    io::print_summary(std::cout, counters.summary(wall));
    std::printf("  output: %s/dam_break.pvd (%ld files), front.csv, loads.csv%s\n", out.c_str(),
                long(vtk.files_written()),
                pictures ? ", particles.png, front.png" : " (no gnuplot: pictures skipped)");
    return outside == 0 ? 0 : 1;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
