// Tanaka's dam break (Tanaka, Cardoso & Bahai 2018 §5.6.1; issue #7) with the LSMPS scheme and polygon walls
// (mpskit::lsmps_defaults<2>): vessel 400 mm wide, column 100 × 200 mm, the pressure probe at (195, 5) mm on
// the far wall. Writes to out/tanaka_dam_break/ (or --out DIR):
//   tanaka_dam_break.pvd + _*.vtu   ParaView series every 0.25 in T = t √(2g/h0), all particle fields
//   front.csv                        front h* = h/h0 against T with the data band of the classic dam break
//   probe.csv                        the probe's pressure after every step (NaN while dry)
//   particles.png, front.png, probe.png   pictures (gnuplot, when installed)
// and prints a summary: the front against the band, the lowest fluid pressure against −ρgH, the closest pair,
// wall-crossing guard activations and the first impact at the probe beside the paper's 4433 Pa.
//
// Usage: tanaka_dam_break [--L mm] [--T T_end] [--walls NAME] [--collision ALPHA1] [--no-collide-isolated]
//                         [--lid mm] [--no-shift-isolated] [--obstacle] [--full] [--fallback | --ilu0]
//                         [--trace U]
//                         [--slab N [--slab-walls]] [--checkpoint FILE [--every S] [--stop-after S]]
//                         [--resume FILE] [--out DIR] [--data DIR]
// The defaults (since 2026-12-03) are the main example's options, scheme::lsmps_impact_params<2>(): the wall
// variant two_point_wall_only_active_set_own_loop_copies_conditioned_limited, the collision stage at alpha1
// 0.5 with isolated particles colliding, isolated particles in the shifting penalty (all opt-in in the
// library), with which every spacing from 6 to 1.5 mm gets through the far-wall impact with no guard
// activation (docs/validation.md). Until then: --walls two_point_wall_only_active_set --collision 0
// --no-shift-isolated.
//   --L      particle diameter in mm (default 5)
//   --T      end time in T (default 3.2: the first impact at the probe and its 10 ms window)
//   --walls  a name of cases::tanaka_wall_variants: parent_gradient (the library's default rows; with
//            --collision 0 --no-shift-isolated the library's defaults) | neumann_points |
//            two_point_wall_only | two_point_wall_only_active_set | ..._own_loop | ..._own_loop_copies |
//            two_point_wall_only_active_set_own_loop_copies_conditioned (through the impact at all 31
//            spacings 3-6 mm, docs/lsmps_scheme.md "Ill-conditioned fits") | ..._conditioned_limited (2 mm
//            too; default) | neumann_points_wall_only_active_set
//   --collision  lsmps_params::collision.alpha1: the opt-in collision stage's contact distance in L_ij
//            (default 0.5; 0 turns it off, and with it the isolated particles' collisions;
//            docs/lsmps_scheme.md deviation 17)
//   --no-collide-isolated  lsmps_params::collision.isolated off (default on with the stage;
//            --collide-isolated, the former opt-in, is still accepted: on, and refused with --collision 0)
//   --no-shift-isolated  lsmps_params::shift_isolated_penalty off: isolated particles stay out of the others'
//            shifting penalty (eq. 96 as printed; docs/lsmps_scheme.md deviation 18; --shift-isolated
//            accepted)
//   --lid    a closed vessel of that height in mm (tanaka_dam_break_config::closed_top; 0 or default: open,
//            300 mm walls, 375 mm with --obstacle; over 300 mm the far-wall run-up throws particles out from
//            t ≈ 0.37 s, T ≈ 5.1, which are removed and counted: tanaka_dam_break_config::remove_outside)
//   --obstacle  §5.6.2's vessel (column 100 × 250 mm, 10 × 10 mm block at x = 0; probe 5 mm above the block)
//   --full   the paper's L = 1 mm (20 000 particles; the paper reports 19 969, docs/regularize.md). Measured
//            before 2026-12-03, with the defaults of that time (add --collision 0 --no-shift-isolated, or
//            --no-collide-isolated --no-shift-isolated with --collision, to repeat these): at 2 mm the
//            two-point configuration without the active set fails at T ≈ 1.4 (docs/resolution.md); with
//            two_point_wall_only_active_set_own_loop_copies_conditioned_limited 2 mm gets through the impact,
//            1.5 mm fails in it (T = 2.82) and 1 mm before it (T = 2.58, PPE not converging after 46 guard
//            activations; docs/lsmps_scheme.md "The 1.5 mm breakdown"); with --collision 0.5 as well 1.5 mm
//            reaches T = 3.2 (with 102 guard activations), and so does 1 mm (146 guard activations, the front
//            in the band at 28 of 65 samples, the probe noisy; 66 min on two threads; docs/lsmps_scheme.md).
//            With the defaults (isolated particles colliding and in the penalty too) 1.5 mm reaches T = 3.2
//            with no guard activation (25 min on one thread, the front in the band at 27 of 65 samples;
//            docs/validation.md); 1 mm (2026-12-05, two threads) failed at T = 1.498 (BiCGSTAB-Jacobi not
//            converging from the warm start; since the cold restart, solver_params::cold_restart, it gets
//            past that point, to T = 2.86 with dt down to 3.2e-6 s from T = 2.64 before its machine session
//            ended; not yet run to the end), and with --fallback reached T = 3.2 before the cold restart (67
//            min with another job beside it, 3 LU solves, no guard activation, closest pair 0.410 L, band 28
//            of 65; docs/lsmps_scheme.md).
//   --fallback  the scene with ppe::with_fallback<bicgstab_jacobi, sparse_lu> (docs/run.md): a step whose
//            BiCGSTAB-Jacobi solve fails (not converged within the cap, or broken down) is solved by
//            SparseLU, counted in the summary; a run whose iterative solves all succeed is the same as
//            without it. 2D only.
//   --ilu0   the scene with ppe::bicgstab_ilu0 (BiCGSTAB with ILU(0), cases/tanaka_ilu0_scene.hpp) in place
//            of BiCGSTAB-Jacobi: the solver docs/performance.md "ILU(0) for the LSMPS PPE" recommends from
//            about 5000 particles (2 mm and finer here). Both solve to the same tolerance, but the dam break
//            amplifies the different digits after the impact, so a run with it is not the Jacobi run
//            (docs/performance.md, same section). Its factors are lagged (solver_params::ilut_reuse), so a
//            resumed run agrees with the uninterrupted one to the solver's tolerance, not bitwise
//            (docs/run.md). Not with --fallback. 2D only.
//   --slab   N: the 3D slab instead (cases/tanaka_dam_break_slab.hpp: the vessel extruded over N layers,
//            periodic in y, or between two end walls with --slab-walls; ours) with
//            scheme::lsmps_impact_params<3>() or, with --walls parent_gradient, Tanaka's Table 2, and the
//            flags above; a ParaView series, front.csv and a summary (docs/lsmps_scheme.md "The impact
//            configuration")
//   --trace  U (m/s): in out/trace.txt, the fastest particle and its neighbourhood (fluid and wall copies
//            with their pressures, packing ratios and surface flags) at each of the first 20 steps in which
//            some fluid particle is faster than U (cases::trace_fast_particle): where a failing run starts to
//            fail (written out after each traced step, so a run killed before its end keeps what it traced).
//   --checkpoint FILE [--every S] [--stop-after S]: write the run to FILE (the particles, the scheme's state,
//            the runner's front and probe samples and extremes, this program's output state) every S wall
//            seconds and at its end; --stop-after S: stop after S wall seconds of this process, checkpoint
//            written (2D only; cases::tanaka_pieces, docs/run.md "Checkpoint and restart")
//   --resume FILE: continue such a run with the same case and scheme options, --trace and --out (refused
//            otherwise; --T may differ: a run can be extended, a file at or beyond it is refused); the
//            ParaView series, the pictures, front.csv and probe.csv continue as if uninterrupted (the run is
//            bitwise the uninterrupted one, label restart)
// Exit status 0 when the run reached T_end or stopped at --stop-after, 1 when the scheme failed (the summary
// says where).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <type_traits>
#include <vector>

#include "cases/cli.hpp"
#include "cases/dam_break.hpp"
#include "cases/tanaka_dam_break_options.hpp"
#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_dam_break_slab.hpp"
#include "cases/tanaka_fallback_scene.hpp"
#include "cases/tanaka_ilu0_scene.hpp"
#include "mpskit/io/csv.hpp"
#include "mpskit/io/progress.hpp"
#include "mpskit/io/vtk.hpp"
#include "mpskit/io/vtk_reader.hpp"

namespace fs = std::filesystem;
using namespace mpskit;

namespace {
/// A file's size; an mpskit::error naming it when it cannot be read (the trace file of a run in pieces).
std::uintmax_t file_bytes(const fs::path& f) {
  std::error_code ec;
  const std::uintmax_t n = fs::file_size(f, ec);
  if (ec) fail("tanaka_dam_break: cannot read the size of '", f.string(), "': ", ec.message());
  return n;
}

/// --slab N: the 3D slab (cases/tanaka_dam_break_slab.hpp), N layers deep, with the library's impact
/// configuration scheme::lsmps_impact_params<3>() or, with --walls parent_gradient, Tanaka's Table 2
/// (lsmps_params<3>{}); the collision and isolated-particle flags as in 2D (impact_scheme_options::
/// slab_params). Writes a ParaView series every 0.25 in T and the front against the data band (front.csv),
/// and prints a summary. Exit status 0 when the run reached T_end.
int run_slab(const cases::tanaka_dam_break_config& cfg, int layers, cases::slab_sides sides, double T_end,
             const scheme::lsmps_params<3>& p, const char* scheme_name,
             const std::vector<cases::front_series>& ref, const std::string& out) {
  // refuses bad input before any output
  const cases::tanaka_slab slab = cases::make_tanaka_slab(cfg, layers, sides);
  fs::create_directories(out);
  io::vtk_series vtk(fs::path(out) / "tanaka_dam_break_slab");
  io::progress_sink progress(std::cerr, 2.0);
  const double T_of_t = std::sqrt(2.0 * cfg.g / cfg.column_width);
  double next_vtk = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  io::step_iterations step_its;
  const auto observe = [&](const auto& sim) {
    const double T = sim.time() * T_of_t,
                 wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    progress.update({sim.time(), T_end / T_of_t, sim.counters().steps, sim.dt(),
                     step_its(sim.counters().ppe_iterations), sim.state().n_real(), wall});
    if (T + 1e-9 >= next_vtk || T >= T_end) {
      vtk.write(sim.state(), sim.time(), sim.counters().steps);
      // not for the last step's frame: an extended run keeps the grid
      if (T + 1e-9 >= next_vtk) next_vtk += 0.25;
    }
  };
  std::printf(
      "mpskit: Tanaka's dam break as a 3D slab (%d layers, B = %g mm, %s) with the LSMPS scheme, "
      "L = %g mm, %lld fluid particles, %s, collision alpha1 %g%s%s, to T = %g\n",
      layers, 1e3 * slab.B, sides == cases::slab_sides::periodic ? "periodic in y" : "end walls", 1e3 * cfg.L,
      static_cast<long long>(slab.size()), scheme_name, p.collision.alpha1,
      p.collision.isolated ? " (isolated particles too)" : "",
      p.shift_isolated_penalty ? ", isolated particles in the shifting penalty" : "", T_end);
  const cases::tanaka_slab_result r = cases::run_tanaka_slab(cfg, layers, T_end, p, sides, true, observe);
  progress.finish();
  int compared = 0, inside = 0;
  {
    io::csv_writer csv(
        fs::path(out) / "front.csv",
        {{"T", "1"}, {"h_star", "1"}, {"h_star_body", "1"}, {"band_low", "1"}, {"band_high", "1"}});
    for (std::size_t k = 0; k < r.T.size(); ++k) {
      const auto [lo, hi] = cases::front_band(ref, r.T[k]);
      csv.row({r.T[k], r.Z[k], r.Z_body[k], lo, hi});
      if (std::isnan(lo)) continue;
      ++compared;
      inside += r.Z[k] >= lo && r.Z[k] <= hi;
    }
  }
  std::printf(
      "\nmpskit: Tanaka's dam break, 3D slab, LSMPS-A order 2 (docs/lsmps_scheme.md \"The impact "
      "configuration\")\n");
  if (r.failed)
    std::printf("  FAILED at T = %.3f (t = %.4f s): %s\n", r.T_failed, r.T_failed / T_of_t,
                r.failure.c_str());
  else
    std::printf("  reached T = %g (t = %.4f s) in %ld steps, %.1f s\n", T_end, T_end / T_of_t, r.steps,
                r.wall_seconds);
  const double Z_max = r.Z_body.empty() ? std::nan("") : *std::max_element(r.Z_body.begin(), r.Z_body.end());
  std::printf(
      "  front h/h0: %d of %d samples inside the data band (Martin & Moyce 1952, Koshizuka & Oka 1996, +-10 "
      "%%); the largest connected body's at most %.3f (the far wall: 4)\n",
      inside, compared, Z_max);
  if (r.steps > 0)
    std::printf(
        "  lowest fluid pressure %.0f Pa = %.2f rho g H; largest speed %.2f sqrt(gH); closest fluid pair "
        "%.3f L\n",
        r.p_min, r.p_min / r.rho_g_h, r.u_max / std::sqrt(cfg.g * cfg.column_height), r.min_pair_ratio);
  else  // all three are measured after a step
    std::printf("  lowest pressure, largest speed and closest pair: not measured (no step completed)\n");
  std::printf(
      "  wall-crossing guard activations %ld; active-set rows %ld; colliding pairs %ld; particles removed "
      "%ld\n",
      r.guarded, r.active_set_rows, r.collisions, r.left_domain);
  std::printf("  output: %s/tanaka_dam_break_slab.pvd (%ld files), front.csv\n", out.c_str(),
              long(vtk.files_written()));
  return r.failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  cases::tanaka_dam_break_options opt;  // the defaults: scheme::lsmps_impact_params<2>()
  try {
    opt = cases::read_tanaka_dam_break_options(argc, argv, MPSKIT_DATA_DIR);
  } catch (const mpskit::error& e) {  // an unknown option, a missing value, a number that is not one
    std::fprintf(
        stderr,
        "%s\nusage: %s [--L mm] [--T T_end] [--walls NAME] [--collision ALPHA1] [--no-collide-isolated] "
        "[--lid mm] [--no-shift-isolated] [--obstacle] [--full] [--fallback | --ilu0] [--trace U] [--slab N "
        "[--slab-walls]] [--checkpoint FILE [--every S] [--stop-after S]] [--resume FILE] [--out DIR] "
        "[--data DIR]\n",
        e.what(), argv[0]);
    return 2;
  }
  try {
    opt.validate();  // refuses bad input before any output
    const cases::tanaka_wall_variant& walls = opt.lsmps.walls("tanaka_dam_break");
    const cases::tanaka_dam_break_config cfg = opt.config();
    if (opt.slab_asked)  // the 3D slab: its own path (the probe, the trace and the pictures are 2D)
      return run_slab(cfg, static_cast<int>(opt.slab),
                      opt.slab_walls ? cases::slab_sides::walls : cases::slab_sides::periodic, opt.T_end,
                      opt.lsmps.slab_params(), opt.lsmps.slab_scheme_name(), cases::read_front_data(opt.data),
                      opt.out);
    const cases::tanaka_dam_break db = cases::make_tanaka_dam_break(cfg);
    const vec<2> probe = opt.obstacle ? db.obstacle_probe() : db.probe();
    const std::vector<cases::front_series> ref = cases::read_front_data(opt.data);

    fs::create_directories(opt.out);
    io::vtk_series vtk(fs::path(opt.out) / "tanaka_dam_break");
    io::progress_sink progress(std::cerr, 2.0);
    io::run_counters counters;
    std::vector<double> obstacle_t,
        obstacle_p;  // the obstacle's probe (the runner samples (195, 5) mm itself)
    const auto t0 = std::chrono::steady_clock::now();
    double next_vtk = 0.0, T_snap = 0.0, wall_before = 0.0;  // wall_before: earlier pieces' (--resume)
    io::step_iterations step_its;  // saved in a checkpoint (a resumed run's steps count from it)
    std::ofstream snap;
    std::ofstream trace_out;  // appended to when resuming
    const fs::path trace_path = fs::path(opt.out) / "trace.txt";
    if (opt.trace) trace_out.open(trace_path, opt.pieces.resume.empty() ? std::ios::trunc : std::ios::app);
    int traced = 0;
    const double rho_g_h = cfg.rho * cfg.g * cfg.column_height;
    const auto observe = [&](const auto& sim) {
      const auto& c = sim.counters();
      const auto& st = sim.state();
      const index_t step_it = step_its(c.ppe_iterations);  // every solve of the step
      counters.record_step(
          st.n_real(), step_it, 0, 0,
          static_cast<index_t>(std::count_if(st.flags().begin(), st.flags().begin() + st.n_real(),
                                             [](flag::type f) { return (f & flag::isolated) != 0; })));
      if (opt.trace && traced < 20 &&
          cases::trace_fast_particle(trace_out, sim, opt.trace_speed, rho_g_h, db.t_star(sim.time()))) {
        ++traced;
        trace_out.flush();  // a run killed before its end keeps what it traced
      }
      if (opt.obstacle) {
        obstacle_t.push_back(sim.time());
        obstacle_p.push_back(cases::probe_pressure(sim, probe, cfg.L));
      }
      const double T = db.t_star(sim.time()),
                   wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      progress.update({sim.time(), opt.T_end / db.t_star(1.0), c.steps, sim.dt(), step_it, st.n_real(),
                       wall_before + wall});
      if (T + 1e-9 >= next_vtk || T >= opt.T_end) {  // every 0.25 in T and the last step
        vtk.write(st, sim.time(), c.steps);
        // not for the last step's frame: a resumed, extended run keeps the grid
        if (T + 1e-9 >= next_vtk) next_vtk += 0.25;
        snap.open(fs::path(opt.out) / "particles.dat",
                  std::ios::trunc);  // the latest written state, for the picture
        T_snap = T;
        for (index_t i = 0; i < st.n_real(); ++i)
          snap << st.x()(0, i) << ' ' << st.x()(1, i) << ' ' << st.template get<field::pressure>()[i] << '\n';
        snap.close();
      }
    };
    const scheme::lsmps_params<2> p = opt.lsmps.params("tanaka_dam_break");
    // Checkpoints carry this program's state beside the runner's: the options (a resume with others is
    // refused), the output series (its length and last time: another --out is refused), the summary's
    // counters, the obstacle's probe and the trace file's length (what a killed run traced after the
    // checkpoint is cut off and traced again). particles.dat may hold a later state than the checkpoint's
    // until the next frame rewrites it (at the latest the run's last step, from which the picture is drawn).
    char options_text[320];
    std::snprintf(
        options_text, sizeof options_text,
        "walls %s, collision %.17g, collide_isolated %d, shift_isolated %d, fallback %d, trace %.17g",
        walls.name.c_str(), opt.lsmps.collision, int(opt.lsmps.colliding_isolated()),
        int(opt.lsmps.shift_isolated), int(opt.fallback), opt.trace ? opt.trace_speed : -1.0);
    // --ilu0 appended only when given, so that the checkpoints of runs without it still load
    const std::string options = std::string(options_text) + (opt.ilu0 ? ", ilu0 1" : "");
    // The output's state (section "example.output"): the next frame's time, the picture's T, the running PPE
    // iteration total at the last step, the traces written, the ParaView files written and the last one's
    // time, the trace file's length (flushed per trace; -1 without --trace). The last three are read into
    // these places: the series' length and last time are checked against the .pvd file, and the trace file is
    // cut back to its length.
    double files_saved = 0.0, last_file_time = 0.0, trace_bytes = -1.0;
    cases::measure_list output;
    output(next_vtk)(T_snap)(step_its.last)(traced)
        .add([&] { return double(vtk.pvd().entries().size()); }, [&](double x) { files_saved = x; })
        .add([&] { return vtk.pvd().entries().empty() ? 0.0 : vtk.pvd().entries().back().time; },
             [&](double x) { last_file_time = x; })
        .add([&] { return opt.trace ? double(file_bytes(trace_path)) : -1.0; },
             [&](double x) { trace_bytes = x; });
    opt.pieces.save_extra = [&](io::checkpoint_sections& s) {
      s.add_bytes("example.options", options);
      s.add_int64s("example.counters", counters.values());
      output.save(s, "example.output");
      cases::add_columns(s, "example.obstacle_probe", {&obstacle_t, &obstacle_p});
    };
    opt.pieces.load_extra = [&](const io::checkpoint_sections& s,
                                const cases::tanaka_dam_break_result& so_far) {
      const std::string& file = opt.pieces.resume;
      if (s.get_bytes("example.options") != options)
        fail("tanaka_dam_break: '", file, "' was written with ", s.get_bytes("example.options"),
             "; this run has ", options, " (resume with the same options)");
      counters.from_values(s.get_int64s("example.counters"));
      output.load(s, "example.output", "tanaka_dam_break", file);
      cases::get_columns(s, "example.obstacle_probe", {&obstacle_t, &obstacle_p}, "tanaka_dam_break", file);
      const auto files = static_cast<std::size_t>(files_saved);
      wall_before = so_far.wall_seconds_before;
      const fs::path pvd = fs::path(opt.out) / "tanaka_dam_break.pvd";
      std::vector<io::pvd_entry> entries;
      if (files > 0) {
        std::error_code ec;
        if (!fs::exists(pvd, ec))
          fail("tanaka_dam_break: '", file, "' was written after ", files, " ParaView files, and '",
               pvd.string(), "' does not exist (resume with the --out of the run that wrote it)");
        entries = io::read_pvd(pvd);
        if (entries.size() < files || entries[files - 1].time != last_file_time)
          fail("tanaka_dam_break: '", file, "' was written after ", files,
               " ParaView files, the last at t = ", last_file_time, " s; '", pvd.string(), "' lists ",
               entries.size(),
               entries.size() < files
                   ? ""
                   : mpskit::detail::concat(", its file ", files, " at t = ", entries[files - 1].time, " s"),
               " (resume with the --out of the run that wrote it)");
        entries.resize(files);  // files the interrupted run wrote after the checkpoint are written again
      }
      vtk = io::vtk_series(fs::path(opt.out) / "tanaka_dam_break", {}, std::move(entries));
      if (opt.trace) {  // the trace file as it was at the checkpoint (not traced then: from the start)
        trace_out.close();
        const auto bytes = static_cast<std::uintmax_t>(std::max(0.0, trace_bytes));
        std::error_code ec;
        if (fs::exists(trace_path, ec) && file_bytes(trace_path) > bytes) {
          fs::resize_file(trace_path, bytes, ec);
          if (ec)
            fail("tanaka_dam_break: cannot cut '", trace_path.string(), "' back to ", bytes,
                 " bytes: ", ec.message());
        }
        trace_out.open(trace_path, std::ios::app);
      }
      std::printf("  resumed from '%s' at T = %.4f (step %ld, %.1f s of wall time before)\n", file.c_str(),
                  so_far.resumed_at, long(counters.summary(0.0).steps), so_far.wall_seconds_before);
    };
    std::printf(
        "mpskit: Tanaka's dam break%s with the LSMPS scheme (Tanaka 2018 sec. 5.6), L = %g mm, %lld fluid "
        "particles, walls '%s', collision alpha1 %g%s%s%s, to T = %g\n",
        opt.obstacle ? " with the 10 x 10 mm obstacle" : "", opt.L_mm, static_cast<long long>(db.size()),
        walls.name.c_str(), opt.lsmps.collision,
        opt.lsmps.colliding_isolated() ? " (isolated particles too)" : "",
        opt.lsmps.shift_isolated ? ", isolated particles in the shifting penalty" : "",
        opt.fallback ? ", SparseLU behind BiCGSTAB-Jacobi" : (opt.ilu0 ? ", BiCGSTAB-ILU(0)" : ""),
        opt.T_end);
    const auto run = [&](auto scene) {  // scene: std::type_identity<the scene>
      using Scene = typename decltype(scene)::type;
      return cases::run_tanaka_dam_break<Scene>(cfg, opt.T_end, p, true, observe, opt.pieces);
    };
    const cases::tanaka_dam_break_result r = opt.fallback
                                                 ? run(std::type_identity<cases::tanaka_fallback_scene>{})
                                             : opt.ilu0 ? run(std::type_identity<cases::tanaka_ilu0_scene>{})
                                                        : run(std::type_identity<lsmps_defaults<2>>{});
    progress.finish();
    const double wall = r.wall_seconds;  // the earlier pieces' included
    const std::vector<double>& probe_t = opt.obstacle ? obstacle_t : r.probe_t;
    const std::vector<double>& probe_p = opt.obstacle ? obstacle_p : r.probe_p;

    int compared = 0, inside = 0;
    {
      io::csv_writer csv(fs::path(opt.out) / "front.csv",
                         {{"T", "1"}, {"h_star", "1"}, {"band_low", "1"}, {"band_high", "1"}});
      for (std::size_t k = 0; k < r.T.size(); ++k) {
        const auto [lo, hi] =
            opt.obstacle ? std::pair(std::nan(""), std::nan("")) : cases::front_band(ref, r.T[k]);
        csv.row({r.T[k], r.Z[k], lo, hi});
        if (std::isnan(lo)) continue;
        ++compared;
        inside += r.Z[k] >= lo && r.Z[k] <= hi;
      }
    }
    {
      io::csv_writer csv(fs::path(opt.out) / "probe.csv", {{"t", "s"}, {"p", "Pa"}});
      for (std::size_t k = 0; k < probe_t.size(); ++k) csv.row({probe_t[k], probe_p[k]});
    }
    const cases::impact_measures m = cases::measure_impact(probe_t, probe_p, 0.01, 0.002);
    const std::string gp = (fs::path(opt.out) / "plot.gp").string();
    {
      const std::string o = opt.out;
      std::ofstream g(gp);
      g << "set terminal pngcairo size 1000,500\nset datafile separator whitespace\n"
        << "set output '" << o << "/particles.png'\nset size ratio -1\n"
        << "set title 'Tanaka dam break, L = " << opt.L_mm << " mm, T = " << T_snap
        << ": particles coloured by pressure (Pa)'\n"
        << "set xlabel 'x (m)'\nset ylabel 'y (m)'\nset palette rgbformulae 33,13,10\n"
        << "plot '" << o << "/particles.dat' using 1:2:3 with points pt 7 ps 0.5 palette notitle\n"
        << "set size noratio\nset datafile separator ','\nset key left top\n"
        << "set output '" << o << "/front.png'\nset title 'front h/h0 against T = t sqrt(2g/h0)'\n"
        << "set xlabel 'T'\nset ylabel 'h/h0'\n"
        << "plot '" << o
        << "/front.csv' using 1:2 every ::1 with lines lw 2 title 'mpskit LSMPS, L = " << opt.L_mm << " mm'"
        << (opt.obstacle
                ? ""
                : ", '' using 1:3 every ::1 with lines dt 2 lc rgb 'gray' title 'data band (+-10 %)', "
                  "'' using 1:4 every ::1 with lines dt 2 lc rgb 'gray' notitle")
        << "\n";
      if (std::isfinite(
              m.t_arrival))  // a probe dry throughout has nothing to plot (gnuplot would fail on it)
        g << "set output '" << o << "/probe.png'\nset title 'pressure at the probe (" << probe[0] * 1e3
          << ", " << probe[1] * 1e3 << ") mm'\nset xlabel 't (s)'\nset ylabel 'p (Pa)'\n"
          << "set xrange [" << m.t_arrival - 0.002 << ":*]\n"
          << "plot '" << o
          << "/probe.csv' using 1:2 every ::1 with lines title 'every step (LSMPS type B)'\n";
    }
    const bool pictures = std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str()) == 0;

    std::printf("\nmpskit: Tanaka's dam break%s, LSMPS-A order 2, walls '%s' (docs/lsmps_scheme.md)\n",
                opt.obstacle ? " with the obstacle" : "", walls.name.c_str());
    if (r.failed)
      std::printf("  FAILED at T = %.3f (t = %.4f s): %s\n", r.T_failed, r.T_failed / db.t_star(1.0),
                  r.failure.c_str());
    else if (r.stopped)
      std::printf(
          "  stopped after %g s of this process at T = %.4f (of %g), checkpoint written: continue with "
          "--resume %s (and --checkpoint %s to go on writing it; the numbers below are the run's so far)\n",
          opt.pieces.stop_after, r.T_reached, opt.T_end, opt.pieces.checkpoint.c_str(),
          opt.pieces.checkpoint.c_str());
    else
      std::printf("  reached T = %g (t = %.4f s)\n", opt.T_end, opt.T_end / db.t_star(1.0));
    if (!opt.obstacle)
      std::printf(
          "  front h/h0: %d of %d samples inside the data band (Martin & Moyce 1952, Koshizuka & Oka 1996, "
          "+-10 %%)\n",
          inside, compared);
    std::printf(
        "  lowest fluid pressure %.0f Pa = %.2f rho g H (issue #7: >= -1); copies (auxiliary unknowns) "
        "%.0f Pa\n",
        r.p_min, r.p_min / r.rho_g_h, r.p_min_copies);
    if (r.steps > 0)
      std::printf(
          "  closest fluid pair %.3f L (at T = %.2f; %.3f L without isolated particles); largest speed %.2f "
          "sqrt(gH) (at T = %.2f)\n",
          r.min_pair_ratio, r.T_min_pair, r.min_pair_ratio_non_isolated,
          r.u_max / std::sqrt(cfg.g * cfg.column_height), r.T_u_max);
    else  // both are measured after a step
      std::printf("  closest fluid pair and largest speed: not measured (no step completed)\n");
    std::printf(
        "  wall-crossing guard activations %ld; active-set rows %ld; particles removed over the side walls "
        "%ld\n",
        r.guarded, r.active_set_rows, r.left_domain);
    std::printf(
        "  PPE solves restarted from 0 after a Krylov breakdown %ld, after not converging from the warm "
        "start %ld (docs/run.md); shifted velocities clipped %ld; colliding pairs %ld\n",
        r.ppe_breakdown_restarts, r.ppe_cold_restarts, r.shift_velocity_clipped, r.collisions);
    if (r.ppe_solves > 0) {
      // The split into first solves and repeats only for a run with repeats (without one the repeats'
      // mean is NaN and the first solves' is the mean above).
      char split[96] = "";
      if (r.ppe_repeat_solves > 0)
        std::snprintf(split, sizeof split, " (the steps' first solves %.1f, the repeats %.1f)",
                      r.first_solve_iterations(), r.repeat_solve_iterations());
      std::printf(
          "  PPE solves %ld (%.2f per step: the active set's and the own-loop guard's repeats), %.1f "
          "iterations per solve%s, incomplete factorisations %ld\n",
          r.ppe_solves, double(r.ppe_solves) / double(std::max(1L, r.steps)),
          double(r.ppe_iterations) / double(r.ppe_solves), split, r.ppe_factorisations);
    }
    if (opt.fallback)
      std::printf("  PPE solves made by the SparseLU fallback (--fallback) %ld\n", r.ppe_fallbacks);
    if (std::isfinite(m.t_arrival)) {
      // NaN when no step number in the window is a multiple of 100 (coarse runs: 79 steps at 5 mm)
      char sparse[64] = "no 100th step in the window";
      if (std::isfinite(m.peak_sparse)) std::snprintf(sparse, sizeof sparse, "%.0f Pa", m.peak_sparse);
      // NaN when the series ends less than 1 ms after the arrival (a run that failed in the impact): no
      // centred 2 ms average lies inside it
      char filtered[64] = "none (the series ends within 1 ms of the arrival)";
      if (std::isfinite(m.peak_filtered))
        std::snprintf(filtered, sizeof filtered, "%.0f Pa", m.peak_filtered);
      std::printf(
          "  probe (%.0f, %.0f) mm wet at T = %.3f; over the next 10 ms%s: impulse %.2f Pa s, peak %.0f Pa, "
          "2 ms-filtered peak %s, every-100-steps peak %s (Tanaka: %.0f Pa at 1 mm, every 100 steps)\n",
          probe[0] * 1e3, probe[1] * 1e3, db.t_star(m.t_arrival), m.complete ? "" : " (window incomplete)",
          m.impulse, m.peak, filtered, sparse, cases::tanaka_dam_break::paper_peak_pressure);
    } else
      std::printf("  probe (%.0f, %.0f) mm: dry to the end\n", probe[0] * 1e3, probe[1] * 1e3);
    if (opt.trace)
      std::printf(
          "  trace: %d step(s) with a fluid particle faster than %g m/s in %s/trace.txt (pressures in "
          "rho g H)\n",
          traced, opt.trace_speed, opt.out.c_str());
    io::print_summary(std::cout, counters.summary(wall));
    std::printf("  output: %s/tanaka_dam_break.pvd (%ld files), front.csv, probe.csv%s\n", opt.out.c_str(),
                long(vtk.files_written()),
                pictures
                    ? (std::isfinite(m.t_arrival) ? ", particles.png, front.png, probe.png"
                                                  : ", particles.png, front.png (probe dry: no probe.png)")
                    : " (gnuplot missing or failed: pictures skipped)");
    return r.failed ? 1 : 0;
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
