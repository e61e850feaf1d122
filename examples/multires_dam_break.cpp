// The main example (README quick start; issue #9 item 4): Tanaka's dam break with the 10 × 10 mm obstacle
// (Tanaka, Cardoso & Bahai 2018 §5.6.2, validation-cases.md A7: vessel 400 mm, column 100 × 250 mm, the block
// on the floor at x = 0) refined around the block by particle splitting and merging (resolution::split_merge,
// §4.4, eqs. 65–74), against single resolution at the coarse and at the fine spacing. Three runs, one after
// the other, all with the LSMPS scheme and polygon walls (mpskit::lsmps_defaults<2>), to T = 3.8, through the
// surge's impact on the far wall, with the options that get all three through it (cases::tanaka_impact_walls:
// two-point copy rows, wall-only shifting, the active set, the own-loop guard, conditioned and limited copy
// rows; the collision stage with alpha1 0.5, isolated particles colliding and in the shifting penalty:
// docs/lsmps_scheme.md deviations 13 and 15-18 and "Ill-conditioned fits"; all opt-in options of the library,
// chosen here by the example; with the library's default wall rows the obstacle case fails at t ≈ 0.11 s even
// at single resolution, and with the earlier default `neumann_points_wall_only_active_set` the runs do not
// get through the far-wall impact at every spacing):
//   multi   L coarse, target diameter L/ratio within r0 of the block's centre (0, 5) mm, a linear ramp to
//           1.05 L at r1 (our target function: the paper's Fig. 27b is not in the text)
//   coarse  single resolution at L
//   fine    single resolution at L/ratio: the reference of the front error
// Writes to out/multires_dam_break/ (or --out DIR):
//   multires_dam_break.pvd + _*.vtu   ParaView series of the multi-resolution run every 0.25 in
//                                     T = t √(2g/h0) (the field `volume` is the particle's area:
//                                     diameter = √volume)
//   front.csv     front h/h0 of the three runs every 0.05 in T (NaN after a run's end)
//   runs.csv      per run: reached T, particles (start, mean over steps, end), events, steps, wall time,
//                 front error, guard activations, closest pair, largest speed (NaN for a run that made no
//                 step), the far-wall probe's first wet T, impulse over 10 ms and 2 ms-filtered peak, the
//                 impulse's error against fine, the error of the front over the largest connected body
//                 (io::largest_body: spray left out)
//   probe.csv     the far-wall probe's pressure (195, 5) mm after every step of each run (NaN while dry)
//   particles.png (the multi-resolution run's last written state coloured by diameter), front.png, probe.png
//                 (the far-wall probe around the fine run's first impact, else the multi run's)
// and prints a one-screen summary: particle saving, wall time, front error (before the fine run's far-wall
// impact; also over the largest connected body) and impulse error against single resolution.
//
// Usage: multires_dam_break [--L mm] [--ratio r] [--T T_end] [--r0 mm] [--r1 mm] [--walls NAME]
//                           [--collision ALPHA1] [--no-collide-isolated] [--no-shift-isolated] [--release]
//                           [--warm] [--contact-fallback] [--no-single] [--full] [--out DIR]
//   --L      coarse diameter in mm (default 5; the block is then two particles wide)
//   --ratio  coarse / fine diameter (default 2: 2.5 mm at the block; the fine single run costs 4 minutes to
//            T = 3.8, at 2 mm about 9; with the earlier default walls neumann_points_wall_only_active_set the
//            2 mm single run fails in the block impact, T ≈ 1.5)
//   --T      end time in T (default 3.8: the far-wall probe gets wet at T ≈ 3.45 and its 10 ms impact window
//            ends by T ≈ 3.6; 5.6 is the paper's t = 0.4 s, about 14 minutes for the three runs)
//   --r0, --r1  the refined zone's radius and the ramp's outer radius in mm (default 30, 60)
//   --walls  the wall options of all three runs, a name of cases::tanaka_wall_variants (default
//            cases::tanaka_impact_walls; docs/resolution.md "The main example")
//   --collision  lsmps_params::collision.alpha1 of all three runs: the opt-in collision stage (default 0.5;
//            0 turns it off; docs/lsmps_scheme.md deviation 17); without isolated particles colliding and in
//            the shifting penalty the 2.5 mm run fails at the block (T = 1.99; docs/validation.md "Dam break
//            with the obstacle")
//   --no-collide-isolated  lsmps_params::collision.isolated off: isolated particles do not collide (default
//            on with the collision stage; --collide-isolated, the former opt-in, is still accepted: on, and
//            refused with --collision 0)
//   --no-shift-isolated  lsmps_params::shift_isolated_penalty off: isolated particles stay out of the others'
//            shifting penalty (eq. 96 as printed; docs/lsmps_scheme.md deviation 18; --shift-isolated
//            accepted)
//   --release  lsmps_params::active_set_release on (opt-in): the active set also releases particles its rows
//            say are compressed, the complementarity p >= 0, w >= 0 (docs/lsmps_scheme.md deviation 13;
//            refused with wall options that have no active set)
//   --warm   lsmps_params::active_set_warm_start on (opt-in; needs --release): each step's active set starts
//            from the set the previous solve ended with (docs/lsmps_scheme.md deviation 13)
//   --contact-fallback  split_merge_params::wall_contact_fallback on (opt-in): a particle near a wall that no
//            direction lets keep a child within wall_contact L' splits toward the wall if its nearer child is
//            then copied (docs/resolution.md "Hard cases" 2b); without it a coarse particle can stay coarse
//            in the fine zone
//   The earlier default (to T = 2.4, before the impact): --walls neumann_points_wall_only_active_set
//            --collision 0 --no-shift-isolated --T 2.4
//   --no-single the multi-resolution run alone
//   --full   the paper's sizes: L = 5 mm, ratio 5 (1 mm at the block), the single-resolution reference at
//            1 mm (24 969 particles in the paper; the 1 mm single run takes more than two hours on one core);
//            the multi-resolution run alone (--full --no-single) blows up at T = 3.106 (measured 2026-12-05;
//            docs/resolution.md "The main example at the paper's ratio")
// Exit status 0 when the multi-resolution run reached T_end, 1 otherwise (the summary says where each
// failed).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include "cases/cli.hpp"
#include "cases/multires_dam_break_options.hpp"
#include "cases/tanaka_obstacle_multires.hpp"
#include "mpskit/io/csv.hpp"
#include "mpskit/io/progress.hpp"
#include "mpskit/io/vtk.hpp"

namespace fs = std::filesystem;
using namespace mpskit;

namespace {

struct run_record {
  std::string name;
  double L = 0.0;                 ///< the run's coarse diameter (m)
  cases::tanaka_dam_break_result r;
  double mean_particles = 0.0;    ///< fluid particles averaged over the steps
  cases::front_difference front;  ///< against the fine run, before its far-wall impact
  cases::front_difference body_front;  ///< the same for the front over the largest connected body (no spray)
  cases::impact_measures impact;   ///< the first impact at the far-wall probe (195, 5) mm
  double impulse_error = std::nan("");  ///< |impulse / fine's − 1| (NaN unless both windows are complete)
  double T_reached() const { return r.failed ? r.T_failed : r.T.empty() ? 0.0 : r.T.back(); }
  /// The closest pair (r_ij/L_ij) and the largest speed (in sqrt_gH) after any step; NaN when no step was
  /// made or no pair came within 1.5 L_ij (min_pair_ratio's 1e300).
  double pair() const { return r.steps > 0 && r.min_pair_ratio < 1e299 ? r.min_pair_ratio : std::nan(""); }
  double speed(double sqrt_gH) const { return r.steps > 0 ? r.u_max / sqrt_gH : std::nan(""); }
};

/// A diameter in mm as %g prints it ("2.5").
std::string fmt_mm(double L) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", L * 1e3);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  cases::multires_dam_break_options opt;  // the defaults: scheme::lsmps_impact_params<2>()
  try {
    opt = cases::read_multires_dam_break_options(argc, argv);
  } catch (const mpskit::error& e) {  // an unknown option, a missing value, a number that is not one
    std::fprintf(
        stderr,
        "%s\nusage: %s [--L mm] [--ratio r] [--T T_end] [--r0 mm] [--r1 mm] [--walls NAME] [--collision "
        "ALPHA1] [--no-collide-isolated] [--no-shift-isolated] [--release] [--warm] [--contact-fallback] "
        "[--no-single] [--full] [--out DIR]\n",
        e.what(), argv[0]);
    return 2;
  }
  try {
    opt.validate();  // refuses bad input before any output
    const cases::tanaka_dam_break_config cfg_coarse = opt.coarse_config(), cfg_fine = opt.fine_config();
    const cases::tanaka_dam_break db = cases::make_tanaka_dam_break(cfg_coarse);
    const double sqrt_gH = std::sqrt(cfg_coarse.g * cfg_coarse.column_height);  // issue #9's speed scale

    fs::create_directories(opt.out);
    io::vtk_series vtk(fs::path(opt.out) / "multires_dam_break");
    std::printf(
        "mpskit: Tanaka's dam break with the 10 x 10 mm obstacle (Tanaka 2018 sec. 5.6.2), LSMPS scheme, "
        "walls '%s', "
        "collision alpha1 %g%s%s%s, to T = %g (t = %.4f s)\n  multi-resolution: %g mm, %g mm within %g mm of "
        "the block's centre, ramp to %g mm%s; "
        "single resolution at %g and %g mm%s\n",
        opt.lsmps.walls_name.c_str(), opt.lsmps.collision,
        opt.lsmps.colliding_isolated() ? " (isolated particles too)" : "",
        opt.lsmps.shift_isolated ? ", isolated particles in the shifting penalty" : "",
        opt.release ? (opt.warm ? ", active set with releases, warm-started" : ", active set with releases")
                    : "",
        opt.T_end, opt.T_end / db.t_star(1.0), opt.L_mm, opt.L_mm / opt.ratio, opt.r0_mm, opt.r1_mm,
        opt.contact_fallback ? ", wall-contact fallback" : "", opt.L_mm, opt.L_mm / opt.ratio,
        opt.single ? "" : " skipped (--no-single)");

    std::vector<run_record> runs;
    const auto run = [&]<class Scene>(const char* name, const cases::tanaka_dam_break_config& cfg,
                                      scheme::lsmps_params<2> p, bool write_vtk) {
      run_record rec;
      rec.name = name;
      rec.L = cfg.L;
      io::progress_sink progress(std::cerr, 2.0);
      double n_sum = 0.0, next_vtk = 0.0;
      long steps = 0;
      std::ofstream snap;
      const auto t0 = std::chrono::steady_clock::now();
      io::step_iterations step_its;
      const auto observe = [&](const auto& sim) {
        const auto& st = sim.state();
        n_sum += static_cast<double>(st.n_real());
        ++steps;
        const double T = db.t_star(sim.time());
        progress.update({sim.time(), opt.T_end / db.t_star(1.0), sim.counters().steps, sim.dt(),
                         step_its(sim.counters().ppe_iterations), st.n_real(),
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()});
        if (write_vtk && (T + 1e-9 >= next_vtk || T >= opt.T_end)) {
          vtk.write(st, sim.time(), sim.counters().steps);
          next_vtk += 0.25;
          snap.open(fs::path(opt.out) / "particles.dat",
                    std::ios::trunc);  // the latest written state, for the picture
          const auto& V = st.template get<field::volume>();
          for (index_t i = 0; i < st.n_real(); ++i)
            snap << st.x()(0, i) << ' ' << st.x()(1, i) << ' ' << 1e3 * std::sqrt(V[i]) << '\n';
          snap.close();
        }
      };
      std::fprintf(stderr, "  run '%s' ...\n", name);
      rec.r = cases::run_tanaka_dam_break<Scene>(cfg, opt.T_end, p, true, observe);
      progress.finish();
      rec.mean_particles =
          steps > 0 ? n_sum / static_cast<double>(steps) : static_cast<double>(rec.r.particles);
      runs.push_back(std::move(rec));
    };

    const scheme::lsmps_params<2> p = opt.params();
    scheme::lsmps_params<2> pm = p;
    cases::refine_around_block(pm, cfg_coarse, opt.ratio, 1e-3 * opt.r0_mm, 1e-3 * opt.r1_mm);
    pm.resolution.wall_contact_fallback =
        opt.contact_fallback;  // (refine_around_block sets wall_contact = 0.75)
    run.operator()<cases::obstacle_multires_scene>("multi", cfg_coarse, pm, true);
    if (opt.single) {
      run.operator()<lsmps_defaults<2>>("coarse", cfg_coarse, p, false);
      run.operator()<lsmps_defaults<2>>("fine", cfg_fine, p, false);
    }
    run_record& multi = runs[0];
    const cases::tanaka_dam_break_result* ref = opt.single ? &runs[2].r : nullptr;
    for (run_record& rr : runs) rr.impact = cases::far_wall_impact(rr.r);
    // Fronts compared up to the fine run's first wet sample at the far-wall probe (after it every front is
    // the vessel's width), as the speed-against-error reporter (benchmarks/report_obstacle_multires.cpp).
    const double T_impact = opt.single ? db.t_star(runs[2].impact.t_arrival) : std::nan("");
    if (ref)
      for (run_record& rr : runs) {
        const double T_limit = std::isfinite(T_impact) ? T_impact : std::numeric_limits<double>::infinity();
        rr.front = cases::compare_fronts(rr.r, *ref, T_limit);
        rr.body_front = cases::compare_fronts(rr.r, *ref, T_limit, &cases::tanaka_dam_break_result::Z_body);
        if (rr.impact.complete && runs[2].impact.complete)
          rr.impulse_error = std::abs(rr.impact.impulse / runs[2].impact.impulse - 1.0);
      }

    {
      std::vector<io::csv_column> cols{{"T", "1"}};
      for (const run_record& rr : runs) cols.push_back({"h_star_" + rr.name, "1"});
      io::csv_writer csv(fs::path(opt.out) / "front.csv", cols);
      const auto& T0 = multi.r.T;
      std::size_t longest = 0;
      for (const run_record& rr : runs) longest = std::max(longest, rr.r.T.size());
      for (std::size_t k = 0; k < longest; ++k) {
        // T: the multi-resolution run's sample (the others' differ by up to a step; past its end, the nominal
        // 0.05 k)
        std::vector<double> row{k < T0.size() ? T0[k] : 0.05 * static_cast<double>(k)};
        for (const run_record& rr : runs) row.push_back(k < rr.r.Z.size() ? rr.r.Z[k] : std::nan(""));
        csv.row(row);
      }
    }
    {
      std::string order = "rows (column run): ";
      for (std::size_t k = 0; k < runs.size(); ++k)
        order += (k ? ", " : "") + std::to_string(k) + " = " + runs[k].name;
      io::csv_writer csv(fs::path(opt.out) / "runs.csv",
                         {{"run", "1"},
                          {"L", "mm"},
                          {"L_min", "mm"},
                          {"T_reached", "1"},
                          {"failed", "1"},
                          {"particles_start", "1"},
                          {"particles_mean", "1"},
                          {"particles_end", "1"},
                          {"splits", "1"},
                          {"merges", "1"},
                          {"steps", "1"},
                          {"wall", "s"},
                          {"front_rms", "1"},
                          {"front_max", "1"},
                          {"T_compared", "1"},
                          {"guard", "1"},
                          {"closest_pair", "L"},
                          {"max_u", "sqrt(gH)"},
                          {"T_wet", "1"},
                          {"impulse", "Pa s"},
                          {"peak_2ms", "Pa"},
                          {"impulse_error", "1"},
                          {"body_front_rms", "1"},
                          {"body_front_max", "1"}},
                         io::csv_mode::truncate,
                         {order,
                          "front_rms, front_max: |h/h0 / (h/h0 of fine) - 1| over the common samples before "
                          "the fine run's T_wet",
                          "body_front_rms, body_front_max: the same for the front over the largest connected "
                          "body (io::largest_body: spray left out)",
                          "T_wet: the far-wall probe (195, 5) mm's first wet sample; impulse, peak_2ms over "
                          "the 10 ms from it (NaN if incomplete)"});
      for (std::size_t k = 0; k < runs.size(); ++k) {
        const run_record& rr = runs[k];
        csv.row({double(k),
                 rr.L * 1e3,
                 rr.r.L_min * 1e3,
                 rr.T_reached(),
                 rr.r.failed ? 1.0 : 0.0,
                 double(rr.r.particles),
                 rr.mean_particles,
                 double(rr.r.particles_end),
                 double(rr.r.splits),
                 double(rr.r.merges),
                 double(rr.r.steps),
                 rr.r.wall_seconds,
                 rr.front.rms,
                 rr.front.max,
                 rr.front.T_last,
                 double(rr.r.guarded),
                 rr.pair(),
                 rr.speed(sqrt_gH),
                 db.t_star(rr.impact.t_arrival),
                 rr.impact.complete ? rr.impact.impulse : std::nan(""),
                 rr.impact.complete ? rr.impact.peak_filtered : std::nan(""),
                 rr.impulse_error,
                 rr.body_front.rms,
                 rr.body_front.max});
      }
    }
    {
      std::vector<io::csv_column> cols;
      for (const run_record& rr : runs)
        cols.insert(cols.end(), {{"t_" + rr.name, "s"}, {"p_" + rr.name, "Pa"}});
      io::csv_writer csv(fs::path(opt.out) / "probe.csv", cols);
      std::size_t longest = 0;
      for (const run_record& rr : runs) longest = std::max(longest, rr.r.probe_t.size());
      for (std::size_t k = 0; k < longest; ++k) {
        std::vector<double> row;
        for (const run_record& rr : runs)
          for (const auto* v : {&rr.r.probe_t, &rr.r.probe_p})
            row.push_back(k < v->size() ? (*v)[k] : std::nan(""));
        csv.row(row);
      }
    }
    // The probe picture's window: around the fine run's first impact (the reference), else the multi run's,
    // else the coarse run's (the first of them that got wet).
    double t_wet = std::nan("");
    for (const std::size_t k : {std::size_t{2}, std::size_t{0}, std::size_t{1}})
      if (k < runs.size() && !std::isfinite(t_wet)) t_wet = runs[k].impact.t_arrival;
    const bool any_wet = std::isfinite(t_wet);
    const std::string gp = (fs::path(opt.out) / "plot.gp").string();
    {
      const std::string o = opt.out;
      std::ofstream g(gp);
      g << "set terminal pngcairo size 1000,560\nset datafile separator whitespace\n"
        << "set output '" << o << "/particles.png'\nset size ratio -1\n"
        << "set title 'multi-resolution dam break with the obstacle: particles coloured by diameter (mm)'\n"
        << "set xlabel 'x (m)'\nset ylabel 'y (m)'\nset palette rgbformulae 33,13,10\n"
        << "plot '" << o << "/particles.dat' using 1:2:3 with points pt 7 ps 0.4 palette notitle\n"
        << "set size noratio\nset datafile separator ','\nset key left top\n"
        << "set output '" << o << "/front.png'\nset title 'front h/h0 against T = t sqrt(2g/h0)'\n"
        << "set xlabel 'T'\nset ylabel 'h/h0'\nplot ";
      for (std::size_t k = 0; k < runs.size(); ++k)
        g << (k ? ", " : "") << "'" << o << "/front.csv' using 1:" << k + 2
          << " every ::1 with lines lw 2 title '" << runs[k].name << ", " << fmt_mm(runs[k].L) << " mm"
          << (k == 0 ? " / " + fmt_mm(cfg_fine.L) + " mm" : std::string()) << "'";
      g << "\n";
      // The far-wall probe around the impact (from 10 ms before t_wet to 20 ms after it).
      // Every step's sample, one-step spikes clipped at twice the largest 2 ms-filtered peak (they reach
      // MPa).
      double peak = 0.0;
      for (const run_record& rr : runs)
        if (std::isfinite(rr.impact.peak_filtered)) peak = std::max(peak, rr.impact.peak_filtered);
      if (any_wet) {
        g << "set output '" << o
          << "/probe.png'\nset title 'pressure at the far-wall probe (195, 5) mm, every step"
          << (peak > 0.0 ? " (clipped at twice the largest 2 ms-filtered peak)" : "")
          << "'\nset xlabel 't (s)'\n"
          << "set ylabel 'p (Pa)'\nset xrange [" << t_wet - 0.01 << ":" << t_wet + 0.02 << "]\n";
        if (peak > 0.0) g << "set yrange [" << -0.5 * peak << ":" << 2.0 * peak << "]\n";
        g << "plot ";
        for (std::size_t k = 0; k < runs.size(); ++k)
          g << (k ? ", " : "") << "'" << o << "/probe.csv' using " << 2 * k + 1 << ":" << 2 * k + 2
            << " every ::1 with lines title '" << runs[k].name << "'";
        g << "\n";
      }
    }
    const bool pictures = std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str()) == 0;

    std::printf("\nmpskit: multi-resolution dam break with the obstacle, to T = %g (docs/resolution.md)\n",
                opt.T_end);
    std::printf("  %-7s %5s %9s %8s %8s %8s %7s %7s %8s %7s %7s %7s  %s\n", "run", "L mm", "reached T",
                "part. 0", "mean", "end", "splits", "merges", "wall s", "guard", "pair L", "|u|max",
                "front vs fine (RMS / max, to T)");
    for (const run_record& rr : runs) {
      std::printf("  %-7s %5.2f %9.3f %8ld %8.0f %8ld %7ld %7ld %8.1f %7ld %7.3f %7.2f  ", rr.name.c_str(),
                  rr.L * 1e3, rr.T_reached(), static_cast<long>(rr.r.particles), rr.mean_particles,
                  static_cast<long>(rr.r.particles_end), rr.r.splits, rr.r.merges, rr.r.wall_seconds,
                  rr.r.guarded, rr.pair(), rr.speed(sqrt_gH));
      if (rr.front.samples > 0)
        std::printf("%.2f %% / %.2f %% (%d samples to %.2f)\n", 100 * rr.front.rms, 100 * rr.front.max,
                    rr.front.samples, rr.front.T_last);
      else std::printf("-\n");
    }
    std::printf(
        "  (pair L: the closest pair r_ij/L_ij after any step; |u|max: the largest speed in sqrt(g H), H = "
        "%.0f mm; issue #9's hard-case bounds are >= 0.3 and <= 5)\n",
        cfg_coarse.column_height * 1e3);
    if (opt.single && runs[0].body_front.samples > 0 && runs[1].body_front.samples > 0)
      std::printf(
          "  front over the largest connected body (spray left out) vs fine, RMS / max: multi %.2f %% / %.2f "
          "%%, coarse %.2f %% / %.2f %%\n",
          100 * runs[0].body_front.rms, 100 * runs[0].body_front.max, 100 * runs[1].body_front.rms,
          100 * runs[1].body_front.max);
    std::printf(
        "  far-wall probe (195, 5) mm, first impact: the 10 ms from its first wet sample (the paper's probe "
        "is 5 mm above the block and has no far-wall figure)\n  %-7s %7s %13s %13s  %s\n",
        "run", "wet T", "impulse Pa s", "2 ms peak Pa", "impulse vs fine");
    for (const run_record& rr : runs) {
      if (!std::isfinite(rr.impact.t_arrival)) {
        std::printf("  %-7s dry to the end\n", rr.name.c_str());
        continue;
      }
      std::printf("  %-7s %7.3f %13.2f %13.0f  ", rr.name.c_str(), db.t_star(rr.impact.t_arrival),
                  rr.impact.impulse, rr.impact.peak_filtered);
      if (!rr.impact.complete) std::printf("(window incomplete)\n");
      else if (std::isfinite(rr.impulse_error)) std::printf("%.1f %%\n", 100.0 * rr.impulse_error);
      else std::printf("-\n");
    }
    for (const run_record& rr : runs)
      if (rr.r.failed)
        std::printf("  '%s' FAILED at T = %.3f: %s\n", rr.name.c_str(), rr.r.T_failed, rr.r.failure.c_str());
    if (opt.single) {
      const run_record& fine = runs[2];
      std::printf("  particle saving against the fine single run: %.1f %% (mean %.0f against %ld)\n",
                  100.0 * (1.0 - multi.mean_particles / static_cast<double>(fine.r.particles)),
                  multi.mean_particles, static_cast<long>(fine.r.particles));
      if (!fine.r.failed && !multi.r.failed)
        std::printf(
            "  wall time: multi %.1f s, fine single %.1f s (%.2fx), coarse single %.1f s; the reference is "
            "the fine run itself, so this is the cost of its accuracy, not a speed-up at equal error "
            "(benchmarks/speed_up.hpp)\n",
            multi.r.wall_seconds, fine.r.wall_seconds, fine.r.wall_seconds / multi.r.wall_seconds,
            runs[1].r.wall_seconds);
      else
        std::printf(
            "  wall time: multi %.1f s, coarse single %.1f s, fine single %.1f s%s: no speed figure from "
            "runs that did not all reach T = %g\n",
            multi.r.wall_seconds, runs[1].r.wall_seconds, fine.r.wall_seconds,
            fine.r.failed ? " (to its failure)" : "", opt.T_end);
    }
    std::printf(
        "  multi: volume change %.1e (splits and merges conserve it), smallest diameter %.2f mm, closest "
        "pair %.3f L\n",
        multi.r.volume_change, multi.r.L_min * 1e3, multi.r.min_pair_ratio);
    std::printf("  output: %s/multires_dam_break.pvd (%ld files), front.csv, runs.csv%s\n", opt.out.c_str(),
                long(vtk.files_written()),
                !pictures ? ", probe.csv (no gnuplot: pictures skipped)"
                : any_wet ? ", probe.csv, particles.png, front.png, probe.png"
                          : ", probe.csv, particles.png, front.png (probe dry: no probe.png)");
    return multi.r.failed ? 1 : 0;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
