// Plane Poiseuille flow with Tanaka 2018's LSMPS scheme (§5.2, §4.5.2; issue #8): the channel periodic in x
// driven by the body force G/ρ, and the same channel driven by pressure inflow/outflow boundaries, against
// the start-up series (validation-cases.md D1).
// Usage: channel [--full] [--periodic-only] [L] [t_end]   |   channel --pipe [t_end]
//        |   channel --duct [t_end] [L]   |   channel --duct-multires [t_end]
//        |   channel --a2 [t_end] [--ratio R] [--pressure] [--no-single]
//        |   channel --multi [L] [t_end] [--refine R [--graded]] [--neumann-points] [--dt-ratio r]
//            [--progress S]
//   --duct:  the 3D square duct (W = 4 mm, 8 mm long, L = 0.5 mm) through pressure faces, and periodic with
//            G/rho, against the start-up series: channel --duct [t_end] [L]
//   --duct-multires [t_end]: that duct through pressure faces, split near its walls
//            (cases::refine_duct_walls; issue #9; default to 0.05 s, ≈ 4 min of one core)
//   --multi: the multi-diameter channel (30 mm -> 10 mm, 100 Pa -> 0 Pa, mu = 0.001 Pa s); default L = 1 mm
//            to 0.3 s (the CI case); the paper's is L = 0.25 mm to 1 s. --refine R: start from L and split to
//            L/R entering the narrow section (issue #9; CI: R = 2; the paper's multi-resolution is
//            0.75 -> 0.25 mm, R = 3)
//            --graded: with --refine, start from particles at the target diameter
//            (resolution::graded_lattice)
//            --neumann-points: the wall copies as Neumann points (lsmps_params::copy_row,
//            docs/lsmps_scheme.md)
//            --thin-walls: the thin-wall visibility test on (lsmps_params::thin_walls; off in this case since
//            2026-11-29, docs/channel.md; give it to resume a checkpoint written before)
//            --dt-ratio r: the Δt ladder Δt_max / r^k (time_step_params::ratio, in [1.001, 2]; default 2)
//            --progress S: a progress row on stderr every S wall seconds
//            --checkpoint FILE [--every S] [--stop-after S]: write the run (and its running measurements) to
//            FILE every S wall seconds and at its end; --stop-after S: stop after S wall seconds, checkpoint
//            written
//            --resume FILE: continue such a run (give the same L, t_end and options; docs/run.md)
//            --ilut-across: keep the ILUT factors across changes of the unknowns (solver_params::
//            ilut_reuse_across_changes; 0.79x the wall time at the paper's size, docs/lsmps_scheme.md
//            deviation 7)
//   --a2:    Tanaka A2 (§5.2): the channel refined at its walls, 0.5/R mm there to 0.5 mm in the centre
//            (R = 4 the paper's 0.125 -> 0.5 mm; cases::a2_target) from a graded start, then single
//            resolution at 0.5/R mm with the same Δt; particle counts, wall times, errors against the
//            start-up series. Periodic (5 mm) by default, to 0.1 s (≈ 7 + 12 min of one core); --pressure:
//            the paper's 100 mm between pressure faces (28 000 particles, ≈ 4 s per step: days to 0.5 s);
//            --no-single: the multi-resolution run only
//   --pipe:  the 3D pipe (R = 5 mm, 8 particles per radius, periodic along z) to 0.2 s against the Szymanski
//            series
//   default: 10 mm wide, 20 mm long (Δp = 20 Pa), L = 0.5 mm, to 0.5 s (the CI case);
//   --full:  the paper's 100 mm channel, Δp = 100 Pa (G = 1000 Pa/m), to 0.5 s, ILUT-BiCGSTAB (Tanaka's
//            single resolution is L = 0.125 mm: pass it as L; expect hours on one core).
// Every number must be wholly a finite number > 0 (--refine and --ratio >= 1); a number beyond the mode's
// positional ones, an option of another mode, a missing value and an unknown option are refused with the
// mode's usage line, exit status 2, before any output (cases/channel_options.hpp, tested under label
// bad_input).
#include <algorithm>
#include <cstdio>
#include <exception>

#include "cases/channel_options.hpp"

namespace {
// The paper's 100 mm channel (--full) with ILUT-preconditioned BiCGSTAB: the default Jacobi-BiCGSTAB broke
// down (NaN) at step 200 at L = 0.5 mm and did not converge within 2000 iterations at step 0 at L = 0.25 mm
// on this 200–400-particle-long Dirichlet-to-Dirichlet PPE; ILUT needs ≈ 26 iterations per step at 0.5 mm
// (measured).
struct long_channel_scene : mpskit::cases::poiseuille_pressure_scene {
  using solver = mpskit::ppe::bicgstab;
};
struct long_channel_multires_scene : long_channel_scene {
  using resolution = mpskit::resolution::split_merge<>;
};

// Tanaka A2 (§5.2): the channel refined at its walls, L_f = 0.5 mm / R there and 0.5 mm in the centre (R = 4:
// the paper's 0.125 -> 0.5 mm), from a graded start, against single resolution at L_f with the same Δt = 0.1
// L_f²/ν. Periodic (5 mm period, body force G/ρ) by default; --pressure: the paper's 100 mm between pressure
// faces.
int run_a2(const mpskit::cases::channel_options& opt) {
  const double t_end = opt.a2_t_end, ratio = opt.a2_ratio;
  const bool pressure = opt.a2_pressure, single = opt.a2_single;
  // H = 10 mm, G = 1000 Pa/m, mu = 0.1 Pa s, L = 0.5 mm (the coarse size)
  mpskit::cases::poiseuille_config c;
  const double Lc = c.L, Lf = Lc / ratio, nu = c.mu / c.rho;
  c.length = pressure ? 0.1 : 0.005;
  c.t_end = t_end;
  c.probe_times.clear();
  for (double tp : {0.05, 0.1, 0.2})
    if (tp < t_end) c.probe_times.push_back(tp);
  // Δt = 0.1 L²/ν at the smallest particle; with pressure faces at the smallest boundary piece (the faces
  // carry the target spacing, min(L_c, L*), cut into whole pieces: at most 4 % below L_f here).
  c.dt = 0.1 * (pressure ? 0.96 * Lf : Lf) * (pressure ? 0.96 * Lf : Lf) / nu;
  const auto target = mpskit::cases::a2_target(c.H, Lf, Lc);
  mpskit::cases::poiseuille_config m = c;
  m.params.resolution.target_diameter = target;
  m.graded_start = true;
  if (pressure) m.boundary_spacing = [=](const mpskit::vec<2>& x) { return std::min(Lc, target(x)); };
  mpskit::cases::poiseuille_config f = c;
  f.L = Lf;
  std::printf(
      "Tanaka A2: H = %.0f mm, %s, G = %.0f Pa/m, mu = %.2f Pa s; multi-resolution %.4g -> %.4g mm (graded "
      "start) against single resolution at %.4g mm; dt = %.3e s, to %.3f s\n",
      c.H * 1e3,
      pressure ? "100 mm between pressure faces (100 Pa -> 0 Pa)" : "periodic (5 mm), body force G/rho", c.G,
      c.mu, Lf * 1e3, Lc * 1e3, Lf * 1e3, c.dt, t_end);
  const auto report = [&](const char* name, const auto& r) {
    std::printf(
        "%s: %lld -> %lld particles, L in [%.4g, %.4g] mm, %ld steps, %.1f s wall, %.1f PPE iterations per "
        "step, splits %ld, merges %ld, guarded %ld\n",
        name, static_cast<long long>(r.particles), static_cast<long long>(r.particles_end), r.L_min * 1e3,
        r.L_max * 1e3, r.steps, r.wall_seconds,
        static_cast<double>(r.ppe_iterations) / static_cast<double>(std::max(1L, r.steps)), r.splits,
        r.merges, r.guarded);
    for (const auto& pr : r.probes)
      std::printf("  t = %.3f s: max |u - series| / u_max = %.4f\n", pr.t, pr.max_error);
    std::printf("  t = %.3f s: vs series %.4f, vs steady %.4f\n", r.end.t, r.end.max_error, r.steady_error);
  };
  const auto run_one = [&](const mpskit::cases::poiseuille_config& cc, bool multi) {
    if (pressure)
      return multi ? mpskit::cases::run_poiseuille_pressure<long_channel_multires_scene>(cc)
                   : mpskit::cases::run_poiseuille_pressure<long_channel_scene>(cc);
    mpskit::cases::poiseuille_pressure_result r;
    static_cast<mpskit::cases::poiseuille_result&>(r) =
        multi ? mpskit::cases::run_poiseuille_periodic<mpskit::cases::poiseuille_multires_scene>(cc)
              : mpskit::cases::run_poiseuille_periodic(cc);
    return r;
  };
  const auto rm = run_one(m, true);
  report("multi-resolution", rm);
  if (!single) return 0;
  const auto rs = run_one(f, false);
  report("single resolution", rs);
  std::printf(
      "particles at the start: %.1f %% fewer (%lld against %lld; the paper: 59.4 %%, 26 708 against 65 870 "
      "in its 100 mm channel); wall time %.2f of single resolution (the paper: 0.140)\n",
      100.0 * (1.0 - static_cast<double>(rm.particles) / static_cast<double>(rs.particles)),
      static_cast<long long>(rm.particles), static_cast<long long>(rs.particles),
      rm.wall_seconds / rs.wall_seconds);
  return 0;
}

int run(int argc, char** argv) {
  mpskit::cases::channel_options opt;
  try {  // reading (cases/channel_options.hpp): an unknown option, a missing, bad or unexpected value
    opt = mpskit::cases::read_channel_options(argc, argv);
    opt.validate();
  } catch (const mpskit::error& e) {
    std::fprintf(stderr, "%s\nusage: %s\n", e.what(),
                 mpskit::cases::channel_usage(mpskit::cases::read_channel_mode(argc, argv)));
    return 2;
  }
  using mode = mpskit::cases::channel_mode;
  if (opt.mode == mode::pipe) {
    const mpskit::cases::pipe_config pc = opt.pipe;
    const auto r = mpskit::cases::run_pipe(pc);
    std::printf("pipe R = %.1f mm, %d particles per radius (%lld particles, %ld steps, %.1f s wall):\n",
                pc.R * 1e3, pc.per_radius, static_cast<long long>(r.particles), r.steps, r.wall_seconds);
    for (const auto& pr : r.probes)
      std::printf("  t = %.3f s: max ring |u - series| / u_max = %.4f (RMS %.4f)\n", pr.t, pr.max_error,
                  pr.rms_error);
    return 0;
  }
  if (opt.mode == mode::duct) {
    for (bool pressure : {true, false}) {
      const mpskit::cases::duct_config dc = opt.duct;
      const auto r = mpskit::cases::run_duct(dc, pressure);
      std::printf(
          "3D duct %s, L = %.3f mm, t = %.3f s (%lld -> %lld particles, %ld steps, %.1f s wall): max cell |u "
          "- series| / u_c = %.4f (RMS %.4f), u_c = %.5f m/s; inflow %ld, outflow %ld\n",
          pressure ? "through pressure faces" : "periodic, body force", dc.L * 1e3, dc.t_end,
          static_cast<long long>(r.particles), static_cast<long long>(r.particles_end), r.steps,
          r.wall_seconds, r.max_error, r.rms_error, r.u_centre, r.inflow, r.outflow);
    }
    return 0;
  }
  if (opt.mode == mode::duct_multires) {
    mpskit::cases::duct_config dc = opt.duct;
    mpskit::cases::refine_duct_walls(dc);
    const auto r = mpskit::cases::run_duct_impl<mpskit::cases::duct_pressure_multires_scene>(dc);
    std::printf(
        "3D duct through pressure faces, split near the walls, t = %.3f s (%lld -> %lld particles, L in "
        "[%.3f, "
        "%.3f] mm, %ld splits, %ld merges, %ld steps, %.1f s wall): max cell |u - series| / u_c = %.4f (RMS "
        "%.4f); inflow %ld, outflow %ld, ledger %.1e, guard %ld\n",
        dc.t_end, static_cast<long long>(r.particles), static_cast<long long>(r.particles_end), r.L_min * 1e3,
        r.L_max * 1e3, r.splits, r.merges, r.steps, r.wall_seconds, r.max_error, r.rms_error, r.inflow,
        r.outflow, r.ledger_error, r.guarded);
    return 0;
  }
  if (opt.mode == mode::a2) return run_a2(opt);
  if (opt.mode == mode::multi) {
    mpskit::cases::multi_diameter_config mc = opt.multi;
    const double ratio = opt.refine;  // --refine R: split 1:R entering the narrow section (issue #9's case)
    if (ratio >= 1.0) mpskit::cases::refine_narrow_section(mc, mc.L / ratio);
    const auto r = ratio >= 1.0
                       ? mpskit::cases::run_multi_diameter<mpskit::cases::multi_diameter_multires_scene>(mc)
                       : mpskit::cases::run_multi_diameter(mc);
    std::printf(
        "multi-diameter channel, L = %.3f mm%s%s%s (%lld particles initially, %ld steps, %.1f s wall, %.1f "
        "PPE iterations per step), to %.2f s:\n",
        mc.L * 1e3,
        ratio >= 1.0 ? (mc.graded_start ? ", graded to L/ratio in the narrow section at the start"
                                        : ", split to L/ratio in the narrow section")
                     : "",
        mc.params.copy_row == mpskit::scheme::copy_row_kind::neumann_points ? ", Neumann-point walls" : "",
        mc.params.thin_walls ? ", thin-wall visibility test on" : "", static_cast<long long>(r.particles),
        r.steps, r.wall_seconds,
        static_cast<double>(r.ppe_iterations) / static_cast<double>(std::max(1L, r.steps)), mc.t_end);
    if (r.resumed_at >= 0.0)
      std::printf("  resumed from '%s' at t = %.6f s\n", mc.pieces.resume.c_str(), r.resumed_at);
    if (!r.finished) {
      std::printf(
          "  stopped after %g s of this process at t = %.6f s (of %.2f s); continue with --resume %s "
          "(and --checkpoint %s to go on writing it)\n",
          mc.pieces.stop_after, r.t_reached, mc.t_end, mc.pieces.checkpoint.c_str(),
          mc.pieces.checkpoint.c_str());
      std::printf(
          "  so far: inflow %ld, outflow %ld, p in [%.0f, %.0f] Pa, max |u| %.3f m/s, guarded %ld, particles "
          "%lld, splits %ld, merges %ld\n",
          r.inflow, r.outflow, r.p_min, r.p_max, r.u_max, r.guarded, static_cast<long long>(r.particles_end),
          r.splits, r.merges);
      return 0;
    }
    std::printf(
        "  volume balance over the last %.2f s: |Q_in - Q_out - dV/dt| / Q_in = %.4f (Q_in %.3e m^2/s)\n",
        mc.window, r.balance, r.q_in);
    std::printf(
        "  inflow %ld, outflow %ld (+%ld behind a face), p in [%.0f, %.0f] Pa, max |u| %.3f m/s (last %.2f "
        "s: %.3f), guarded %ld\n",
        r.inflow, r.outflow, r.outflow_behind, r.p_min, r.p_max, r.u_max, mc.window, r.u_max_window,
        r.guarded);
    std::printf("  lowest pressure at (%.1f, %.1f) mm, t = %.4f s; highest at (%.1f, %.1f) mm, t = %.4f s\n",
                r.p_min_at[0] * 1e3, r.p_min_at[1] * 1e3, r.p_min_t, r.p_max_at[0] * 1e3, r.p_max_at[1] * 1e3,
                r.p_max_t);
    std::printf("  particles %lld at the end, diameters [%.3f, %.3f] mm, splits %ld, merges %ld\n",
                static_cast<long long>(r.particles_end), r.L_min * 1e3, r.L_max * 1e3, r.splits, r.merges);
    return 0;
  }
  const mpskit::cases::poiseuille_config c = opt.poiseuille;
  const bool full = opt.full, periodic_only = opt.periodic_only;
  const mpskit::cases::poiseuille_exact ex{c.G, c.H, c.mu, c.rho};
  std::printf(
      "Poiseuille: H = %.1f mm, G = %.0f Pa/m, mu = %.2f Pa s, L = %.3f mm, dt = %.2e s, u_max = %.4f m/s\n",
      c.H * 1e3, c.G, c.mu, c.L * 1e3, c.dt, ex.u_max());
  {
    mpskit::cases::poiseuille_config cp = c;
    cp.length = 0.005;  // any period > 2 R_e L (1 + skin) gives the same profile
    const auto r = mpskit::cases::run_poiseuille_periodic(cp);
    std::printf("periodic in x, body force G/rho (%lld particles, %ld steps, %.1f s wall):\n",
                static_cast<long long>(r.particles), r.steps, r.wall_seconds);
    for (const auto& pr : r.probes)
      std::printf("  t = %.3f s: max |u - series| / u_max = %.4f\n", pr.t, pr.max_error);
    std::printf("  t = %.3f s: vs series %.4f, vs steady %.4f, centre %.5f m/s\n", r.end.t, r.end.max_error,
                r.steady_error, r.centre_velocity);
  }
  if (periodic_only) return 0;
  const auto r = full ? mpskit::cases::run_poiseuille_pressure<long_channel_scene>(c)
                      : mpskit::cases::run_poiseuille_pressure(c);
  std::printf(
      "pressure boundaries, %.0f mm long, dp = %.1f Pa (%lld particles initially, %ld steps, %.1f s wall):\n",
      c.length * 1e3, c.G * c.length, static_cast<long long>(r.particles), r.steps, r.wall_seconds);
  for (const auto& pr : r.probes)
    std::printf("  t = %.3f s: mid-length max |u - series| / u_max = %.4f\n", pr.t, pr.max_error);
  std::printf("  t = %.3f s: vs series %.4f, vs steady %.4f, centre %.5f m/s; RMS |p - linear| / dp = %.4f\n",
              r.end.t, r.end.max_error, r.steady_error, r.centre_velocity, r.pressure_error);
  std::printf(
      "  inflow %ld, outflow %ld (+%ld behind a face), volume in [%.4f, %.4f] of H l, ledger error %.1e\n",
      r.inflow, r.outflow, r.outflow_behind, r.volume_min, r.volume_max, r.ledger_error);
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {  // mpskit::error and the standard library's: print, do not abort
    std::fflush(stdout);
    std::fprintf(stderr, "channel: %s\n", e.what());
    return 1;
  }
}
