// Flow between two fixed gears (Tanaka, Cardoso & Bahai 2018 §5.5; validation-cases.md A5; docs/gears.md),
// with particle splitting and merging (Tanaka §4.4). The domain is generated (examples/cases/gears.hpp: our
// reconstruction of the paper's Fig. 21), written to DIR/gears.polyline and read back through the polyline
// reader (geometry::read_polyline), which is what the run uses. Writes to DIR (default out/gears):
//   gears.polyline                 the domain (walls, then the two pressure faces; fluid on the left)
//   gears_walls.vtk                the same segments for ParaView (legacy VTK polydata)
//   gears.pvd + gears_*.vtu        ParaView series of the particles (every `--vtk-every` s)
// Usage: gears [--full] [--out DIR] [--t-end T] [--window S] [--vtk-every S] [--wall-limit S]
//   [--geometry-only]
//   default: L* from 0.2 mm (d < 7 mm) to 0.8 mm, to 0.05 s (≈ 2 min of one core)
//   --full:  the paper's 0.4 s with L* from 0.1 mm (d < 4 mm) to 0.8 mm (hours of one core; --wall-limit
//            stops it)
//   --window S: the volume balance's averaging over the last S seconds (default 0.01 s, 0.1 s with --full;
//            must be < --t-end; with a --t-end not longer than the default window the window becomes 0.2
//            t_end, and the example says so). Options given with --full override its values, in any order.
//   A value that is not wholly a number, or is <= 0 (< 0 for --filter and --two-point, where 0 switches off),
//   an unknown option and a missing value are refused with the option named and the usage line, exit status 2
//   (cases/gears_options.hpp, tested under label bad_input).
// Knobs for experiments (docs/gears.md): --lmin L --lmax L --rfine R --tip-round R --root-round R,
// --two-point B (copy row β), --filter E (one-sided-band filter ε), --courant C, --alpha-w A, --alpha-o A,
// --cprime D (eq. 62's c′ = 1 ± D), --shift-as-printed (eq. 99 on the fluid pairs too), --no-merge; solvers:
// UMFPACK when the build has SuiteSparse, else ILUT-BiCGSTAB (--ilut forces it), --jacobi (BiCGSTAB-Jacobi:
// did not converge at step 0).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include "cases/gears_options.hpp"
#include "mpskit/io/progress.hpp"
#include "mpskit/io/vtk.hpp"

namespace fs = std::filesystem;
using namespace mpskit;

namespace {

void write_walls_vtk(const fs::path& file, const geometry::polygon_mesh<2>& m) {
  std::ofstream o(file);
  o.precision(17);
  o << "# vtk DataFile Version 3.0\nmpskit gears domain (walls and faces)\nASCII\nDATASET POLYDATA\nPOINTS "
    << m.vertices.cols() << " double\n";
  for (index_t v = 0; v < m.vertices.cols(); ++v) o << m.vertices(0, v) << ' ' << m.vertices(1, v) << " 0\n";
  o << "LINES " << m.size() << ' ' << 3 * m.size() << '\n';
  for (index_t e = 0; e < m.size(); ++e) o << "2 " << m.elements(0, e) << ' ' << m.elements(1, e) << '\n';
}

int run(int argc, char** argv) {
  cases::gears_options opt;
  try {  // reading (cases/gears_options.hpp): an unknown option, a missing or bad value
    opt = cases::read_gears_options(argc, argv);
    opt.validate();
  } catch (const mpskit::error& e) {
    std::fprintf(
        stderr,
        "%s\nusage: %s [--full] [--out DIR] [--t-end T] [--window S] [--vtk-every S] [--wall-limit S] "
        "[--geometry-only] (more knobs: see the file's header)\n",
        e.what(), argv[0]);
    return 2;
  }
  if (opt.fit_default_window())
    std::printf("gears: --t-end %g is not longer than the default window: averaging over the last %g s\n",
                opt.c.t_end, opt.c.window);
  const cases::gears_config& c = opt.c;
  const std::string& out = opt.out;
  const double vtk_every = opt.vtk_every;
  const bool geometry_only = opt.geometry_only, jacobi = opt.jacobi;
  [[maybe_unused]] const bool ilut = opt.ilut;  // used with SuiteSparse only
  fs::create_directories(out);
  const cases::gears_geometry g = cases::make_gears_geometry(c.geometry);
  const fs::path poly = fs::path(out) / "gears.polyline";
  geometry::write_polyline(poly.string(), g.mesh);
  const geometry::read_result<2> rd = geometry::read_polyline(poly.string());  // the run uses what was read
  write_walls_vtk(fs::path(out) / "gears_walls.vtk", rd.mesh);
  std::printf(
      "mpskit: flow between two fixed gears (Tanaka 2018 sec. 5.5; our reconstruction, docs/gears.md)\n");
  std::printf(
      "  gears: 12 and 24 teeth, module 3 mm, involute 20 deg, centre distance %.1f mm; teeth thinned by "
      "%.3f mm at the pitch circle for a minimum gap of %.3f mm\n",
      c.geometry.centre_distance * 1e3, g.thinning * 1e3, g.gap * 1e3);
  std::printf(
      "  window: faces at x = +-%.2f mm, top wall at y = %.1f mm, %d cut-off tooth space(s) left out; fluid "
      "area %.1f mm^2\n",
      g.a * 1e3, g.y_top * 1e3, g.pockets, g.area * 1e6);
  std::printf("  %s: %lld vertices, %lld segments read back through read_polyline\n", poly.string().c_str(),
              static_cast<long long>(rd.mesh.vertices.cols()), static_cast<long long>(rd.mesh.size()));
  std::printf(
      "  L*(d) = %.3f mm for d < %.0f mm, x sqrt(2) every %.0f mm up to %.3f mm; single resolution at L_min "
      "would need area / L_min^2 = %.0f particles\n",
      c.L_min * 1e3, c.r_fine * 1e3, c.level_width * 1e3, c.L_max * 1e3, g.area / (c.L_min * c.L_min));
  std::printf(
      "  pressure: %.0f Pa on the right face, %.0f Pa on the left (flow right to left), rho %.0f, mu %g\n",
      c.p_right, c.p_left, c.rho, c.mu);
  if (geometry_only) return 0;

  io::vtk_series vtk(fs::path(out) / "gears");
  io::progress_sink progress(std::cerr, 5.0);
  const auto t0 = std::chrono::steady_clock::now();
  double next_vtk = 0.0;
  io::step_iterations step_its;
  const auto observer = [&](const auto& sim) {
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    progress.update({sim.time(), c.t_end, sim.counters().steps, sim.dt(),
                     step_its(sim.counters().ppe_iterations), sim.state().n_real(), wall});
    if (sim.time() + 1e-12 >= next_vtk) {
      vtk.write(sim.state(), sim.time(), sim.counters().steps);
      next_vtk += vtk_every;
    }
  };
  const char* solver = jacobi ? "BiCGSTAB-Jacobi" : "ILUT-BiCGSTAB";
#ifdef MPSKIT_HAS_SUITESPARSE
  if (!jacobi && !ilut) solver = "UMFPACK";
#endif
  const auto r = [&] {
    if (jacobi) return cases::run_gears<cases::gears_jacobi_scene>(c, rd.mesh, g.a, g.y_top, observer);
#ifdef MPSKIT_HAS_SUITESPARSE
    if (!ilut) return cases::run_gears<cases::gears_umfpack_scene>(c, rd.mesh, g.a, g.y_top, observer);
#endif
    return cases::run_gears(c, rd.mesh, g.a, g.y_top, observer);
  }();
  progress.finish();
  std::printf(
      "  run (%s): %s at t = %.4f s of %.4f s, %ld steps, %.1f s wall (PPE iterations per step %.1f, most "
      "in one solve %ld)\n",
      solver,
      r.failed    ? "FAILED"
      : r.stopped ? "stopped at the wall-clock limit"
                  : "reached the end",
      r.t_reached, c.t_end, r.steps, r.wall_seconds, r.ppe_iterations_mean, r.ppe_iterations_max);
  if (r.failed) std::printf("  failure: %s\n", r.failure.c_str());
  std::printf(
      "  fluid particles: start %lld, mean %.0f, end %lld; splits %ld, merges %ld; diameters at the end "
      "[%.3f, %.3f] mm\n",
      static_cast<long long>(r.particles), r.particles_mean, static_cast<long long>(r.particles_end),
      r.splits, r.merges, r.L_min * 1e3, r.L_max * 1e3);
  std::printf(
      "  faces: %ld created, %ld removed (+%ld behind a face); ledger error %.1e; guard activations %ld\n",
      r.inflow, r.outflow, r.outflow_behind, r.ledger_error, r.guarded);
  if (r.q_in != 0.0)
    std::printf(
        "  volume balance over the last %.3f s: |Q_in - Q_out - dV/dt| / Q_in = %.4f (Q_in %.3e, Q_out %.3e, "
        "dV/dt %.3e m^2/s)\n",
        c.window, r.balance, r.q_in, r.q_out, r.dvdt);
  else
    std::printf("  volume balance: not measured (the run did not reach the window)\n");
  if (r.steps > 0) {
    std::printf("  max |u| %.3f m/s at (%.2f, %.2f) mm, t = %.4f s (last window: %.3f m/s)\n", r.u_max,
                r.u_max_at[0] * 1e3, r.u_max_at[1] * 1e3, r.u_max_t, r.u_max_window);
    std::printf(
        "  fluid p in [%.0f, %.0f] Pa: min at (%.2f, %.2f) mm, t = %.4f s; max at (%.2f, %.2f) mm, t = %.4f "
        "s\n",
        r.p_min, r.p_max, r.p_min_at[0] * 1e3, r.p_min_at[1] * 1e3, r.p_min_t, r.p_max_at[0] * 1e3,
        r.p_max_at[1] * 1e3, r.p_max_t);
  }
  std::printf("  output: %s/gears.pvd (%ld files), gears.polyline, gears_walls.vtk\n", out.c_str(),
              static_cast<long>(vtk.files_written()));
  return r.failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "gears: %s\n", e.what());
    return 1;
  }
}
