#pragma once
// Runs Tanaka's dam break (cases/tanaka_dam_break.hpp, §5.6.1) with the LSMPS scheme: front samples every
// 0.05 in T = t √(2g/h0), the pressure at the probe (195, 5) mm every step, the lowest fluid (and copy)
// pressure, the closest fluid pair (every step), counters and wall time. Shared by the test label
// dam_break_lsmps and the speed-against-error reporter (benchmarks/report_dam_break.cpp). Long runs go in
// pieces through a checkpoint (tanaka_pieces; label restart).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "cases/run_measures.hpp"
#include "cases/run_pieces.hpp"
#include "cases/tanaka_dam_break.hpp"
#include "mpskit/io/lsmps_checkpoint.hpp"
#include "mpskit/io/probes.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// Counters both dam-break runners report (the 2D run and the 3D slab, cases/tanaka_dam_break_slab.hpp).
struct tanaka_run_counts {
  long steps = 0, guarded = 0;
  long active_set_rows = 0, active_set_unfinished = 0;  ///< lsmps_params::active_set_solves (counters)
  long collisions = 0;   ///< colliding pairs of the collision stage (lsmps_params::collision)
  long left_domain = 0;  ///< particles removed over the side walls (tanaka_dam_break_config::remove_outside)
  long active_set_solves = 0;  ///< PPE solves repeated by the active set (lsmps_counters::active_set_solves)
  /// The solve ledger: pressure solves and the ILUT / ILU(0) factorisations among them
  /// (lsmps_counters::ppe_solves, ppe_factorisations; 0 factorisations for BiCGSTAB-Jacobi), and
  /// lagged-factor solves repeated with fresh factors (lsmps_counters::ppe_lagged_retries,
  /// solver_params::ilut_reuse).
  long ppe_solves = 0, ppe_factorisations = 0, ppe_lagged_retries = 0;
  /// The solves after each step's first (the active set's and the own-loop guard's repeats) and their
  /// iterations (lsmps_counters::ppe_repeat_solves, ppe_repeat_iterations).
  long ppe_repeat_solves = 0, ppe_repeat_iterations = 0;
  /// Copies them from the scheme's counters (scheme::lsmps_counters).
  template <class Counters>
  void read_counts(const Counters& k) {
    steps = k.steps;
    guarded = k.guarded;
    active_set_rows = k.active_set_rows;
    active_set_unfinished = k.active_set_unfinished;
    collisions = k.collisions;
    left_domain = k.left_domain;
    active_set_solves = k.active_set_solves;
    ppe_solves = k.ppe_solves;
    ppe_factorisations = k.ppe_factorisations;
    ppe_lagged_retries = k.ppe_lagged_retries;
    ppe_repeat_solves = k.ppe_repeat_solves;
    ppe_repeat_iterations = k.ppe_repeat_iterations;
  }
};

/// What one run measured.
struct tanaka_dam_break_result : tanaka_run_counts {
  std::vector<double> T,
      Z;  ///< front samples h* (Z) at T = t* every 0.05 (the first at or after each multiple)
  /// The same front over the largest connected body only (io::largest_body, link 1.5): spray clusters left
  /// out.
  std::vector<double> Z_body;
  std::vector<double> probe_t,
      probe_p;                  ///< time (s) and pressure (Pa) at the probe after every step; NaN: dry
  double p_min = 0.0;           ///< lowest fluid pressure over all steps (Pa)
  double p_min_copies = 0.0;    ///< lowest imaginary-copy pressure (auxiliary unknowns of the wall rows, Pa)
  double rho_g_h = 0.0;         ///< ρ g H of the column (Pa)
  index_t particles = 0;        ///< fluid particles at the start
  index_t particles_end = 0;    ///< fluid particles at the end (differs with splitting and merging)
  double L_min = 0.0;           ///< smallest particle diameter at the end (m; sqrt of the 2D volume)
  long splits = 0, merges = 0;  ///< resolution events (Scene::resolution = split_merge)
  /// (ΣV at the end + ΣV removed over the side walls) / ΣV at the start − 1: the volume balance (splits and
  /// merges conserve ΣV, the removal's volume is counted).
  double volume_change = 0.0;
  /// Smallest r_ij / L_ij of fluid pairs after any step (min_pair_ratio: clustering) and T when it occurred.
  double min_pair_ratio = 1e300, T_min_pair = std::numeric_limits<double>::quiet_NaN();
  /// the same over pairs without an isolated particle (spray left out)
  double min_pair_ratio_non_isolated = 1e300;
  /// Largest |u| of a real particle after any step (m/s) and T when it occurred (issue #9's explosion
  /// measure).
  double u_max = 0.0, T_u_max = std::numeric_limits<double>::quiet_NaN();
  long filtered = 0, ppe_iterations = 0;
  long filter_amplifying = 0,
       filter_tapered = 0;  ///< band fits left alone / tapered (boundary_filter_params)
  /// own-loop guard (lsmps_params::own_loop): particle-steps checked, made p = 0, with copies' two-point term
  /// dropped; repeated solves
  long own_loop_checked = 0, own_loop_dirichlet = 0, own_loop_one_point = 0, own_loop_solves = 0;
  long ppe_fallbacks = 0;  ///< solves made by the fallback solver (Scene::solver = ppe::with_fallback)
  long ppe_breakdown_restarts = 0;  ///< solves restarted from 0 after a Krylov breakdown (solver_params)
  long ppe_cold_restarts = 0;  ///< warm-started solves repeated from 0 after not converging (solver_params)
  /// particle-steps whose eq. 91 velocity was clipped (shift_velocity_limit)
  long shift_velocity_clipped = 0;
  double left_domain_volume = 0.0;                             ///< their ΣV (m²)
  double wall_seconds = 0.0;                                   ///< wall time of the time loop (s)
  bool failed = false;                                         ///< the scheme threw (only with catch_failure)
  double T_failed = std::numeric_limits<double>::quiet_NaN();  ///< T at the failure
  std::string failure;                                         ///< the error's text
  /// Runs in pieces (tanaka_pieces): stopped at stop_after before T_end, checkpoint written (the numbers so
  /// far).
  bool stopped = false;
  double T_reached = 0.0;            ///< T at the end of this piece
  double resumed_at = -1.0;          ///< T the run was resumed from (< 0: not resumed)
  double wall_seconds_before = 0.0;  ///< wall time of the earlier pieces (s; included in wall_seconds)
  /// Iterations per solve of the steps' first pressure solves (NaN without a solve).
  double first_solve_iterations() const {
    const long first = ppe_solves - ppe_repeat_solves;
    return first > 0 ? double(ppe_iterations - ppe_repeat_iterations) / double(first)
                     : std::numeric_limits<double>::quiet_NaN();
  }
  /// Iterations per solve of the repeated ones, the active set's and the own-loop guard's (NaN without one).
  double repeat_solve_iterations() const {
    return ppe_repeat_solves > 0 ? double(ppe_repeat_iterations) / double(ppe_repeat_solves)
                                 : std::numeric_limits<double>::quiet_NaN();
  }
};

/// Long runs in pieces (cases/run_pieces.hpp). The checkpoint holds the particles, the scheme's state and the
/// runner's running measurements (front and probe samples, extremes, the wall time so far); it is written
/// once before the first step (a bad path or a reserved section name is refused at once, not after hours),
/// then as run_pieces says. A resumed file must have this case configuration (every field of
/// tanaka_dam_break_config, compared bitwise; refused otherwise); T_end may differ (a run can be extended; a
/// file at or beyond T_end is refused: nothing to run); the scheme options are the caller's to keep the same.
/// A run that fails writes no checkpoint (the last one written stays); a checkpoint that cannot be written
/// throws, with catch_failure too (it is not the scheme's failure). Resumed with the same options, the run is
/// bitwise the uninterrupted one (label restart) when the solver keeps no factorisation across steps
/// (io/lsmps_checkpoint.hpp; BiCGSTAB-Jacobi, the default).
struct tanaka_pieces : run_pieces {
  /// The caller's own sections (e.g. an example's output state), added to every checkpoint written; names
  /// must not start with "lsmps." or "tanaka_dam_break.".
  std::function<void(io::checkpoint_sections&)> save_extra;
  /// Called once after a resume, before the first step, with every section of the file and the result so far.
  std::function<void(const io::checkpoint_sections&, const tanaka_dam_break_result&)> load_extra;
};

namespace detail {
/// tanaka_dam_break_config's fields in a checkpoint (section "tanaka_dam_break.config"), with their names for
/// the refusal of another configuration.
inline std::vector<double> tanaka_config_values(const tanaka_dam_break_config& c) {
  return {c.L,
          c.vessel_left,
          c.vessel_right,
          c.vessel_height,
          c.closed_top ? 1.0 : 0.0,
          c.remove_outside ? 1.0 : 0.0,
          c.column_width,
          c.column_height,
          c.rho,
          c.mu,
          c.g,
          c.obstacle_width,
          c.obstacle_height,
          c.obstacle_centre,
          c.max_speed_factor};
}
inline constexpr std::array<const char*, 15> tanaka_config_names{"L",
                                                                 "vessel_left",
                                                                 "vessel_right",
                                                                 "vessel_height",
                                                                 "closed_top",
                                                                 "remove_outside",
                                                                 "column_width",
                                                                 "column_height",
                                                                 "rho",
                                                                 "mu",
                                                                 "g",
                                                                 "obstacle_width",
                                                                 "obstacle_height",
                                                                 "obstacle_centre",
                                                                 "max_speed_factor"};
}  // namespace detail

/// Pressure at q from the real, non-isolated fluid particles within re = R_e L (L the case's spacing; R_e of
/// the operator, 3.1): LSMPS type B of first order (io::lsmps_b1_interpolation, exact for linear fields). NaN
/// (dry) unless the fit is regular and some candidate j lies within 1.5 L_j of q, so that the value is an
/// interpolation inside the particle cloud and not an extrapolation from a passing splash.
template <class Sim>
double probe_pressure(const Sim& sim, const vec<2>& q, double L) {
  const auto& st = sim.state();
  const auto& fl = st.flags();
  thread_local std::vector<index_t> cand;
  thread_local std::vector<double> w;
  const auto counted = [&](index_t j) { return (fl[static_cast<std::size_t>(j)] & flag::isolated) == 0; };
  const bool ok = io::point_weights(st, q, sim.params().op.re_ratio * L, counted,
                                    io::lsmps_b1_interpolation<2>{}, cand, w);
  const auto& V = st.template get<field::volume>();
  const bool near = std::any_of(cand.begin(), cand.end(), [&](index_t j) {
    return (st.x().col(j) - q).norm() <= 1.5 * std::sqrt(V[j]);  // 2D: L = √V
  });
  if (!ok || !near) return std::numeric_limits<double>::quiet_NaN();
  const auto& P = st.template get<field::pressure>();
  double v = 0.0;
  for (std::size_t k = 0; k < cand.size(); ++k) v += w[k] * P[cand[k]];
  return v;
}

/// The wall options the dam-break runs compare (docs/lsmps_scheme.md): parent_gradient (the library's
/// defaults), neumann_points (copy_row = neumann_points, deviation 11), two_point_wall_only
/// (copy_two_point = 1 and shift.projection = wall_only), two_point_wall_only_active_set (the same with
/// active_set_solves = 10, deviation 13), two_point_wall_only_active_set_own_loop (the same with the own-loop
/// guard, deviation 15), two_point_wall_only_active_set_own_loop_wall (the same with
/// own_loop.wall_candidate_packing = 0.9), two_point_wall_only_active_set_own_loop_copies (the own-loop
/// variant with active_set_copies), two_point_wall_only_active_set_own_loop_copies_conditioned (the same with
/// op.max_condition = 1e4: a fit whose moment matrix has cond1 above 1e4 falls back to a lower order;
/// docs/lsmps_scheme.md "Ill-conditioned fits"),
/// two_point_wall_only_active_set_own_loop_copies_conditioned_limited (the same with shift_velocity_limit:
/// docs/lsmps_scheme.md "The shifted velocity's limiter") and neumann_points_wall_only_active_set
/// (Neumann-point rows, wall-only shifting and the set: the configuration of the main example,
/// examples/multires_dam_break.cpp, until 2026-12-03; it now uses the conditioned, limited variant above with
/// the collision stage). Used by the reporter (benchmarks/report_dam_break.cpp) and the example
/// tanaka_dam_break.
struct tanaka_wall_variant {
  std::string name;   ///< as given on a command line
  std::string tag;    ///< suffix of a configuration name
  std::string label;  ///< suffix of a plot series
  void (*apply)(scheme::lsmps_params<2>&);
};
/// copy_two_point = 1 and wall-only shifting (the two variants that build on it).
inline void two_point_wall_only(scheme::lsmps_params<2>& p) {
  p.copy_two_point = 1.0;
  p.shift.projection = regularize::penalty_projection::wall_only;
}
/// The same with active_set_solves = 10 and the own-loop guard (the two own-loop variants).
inline void two_point_own_loop(scheme::lsmps_params<2>& p) {
  two_point_wall_only(p);
  p.active_set_solves = 10;
  p.own_loop.enabled = true;
}
inline const std::vector<tanaka_wall_variant>& tanaka_wall_variants() {
  static const std::vector<tanaka_wall_variant> v{
      {"parent_gradient", "", "", [](scheme::lsmps_params<2>&) {}},
      {"neumann_points", "-np", ", Neumann-point walls",
       [](scheme::lsmps_params<2>& p) { p.copy_row = scheme::copy_row_kind::neumann_points; }},
      {"two_point_wall_only", "-tp", ", two-point copy rows + wall-only shifting", &two_point_wall_only},
      {"two_point_wall_only_active_set", "-tpa", ", two-point rows + wall-only shifting + active set",
       [](scheme::lsmps_params<2>& p) {
         two_point_wall_only(p);
         p.active_set_solves = 10;
       }},
      {"two_point_wall_only_active_set_own_loop", "-tpo",
       ", two-point rows + wall-only shifting + active set + own-loop guard", &two_point_own_loop},
      {"two_point_wall_only_active_set_own_loop_wall", "-tpow",
       ", two-point rows + wall-only shifting + active set + own-loop guard, wall candidates c < 0.9",
       [](scheme::lsmps_params<2>& p) {
         two_point_own_loop(p);
         p.own_loop.wall_candidate_packing = 0.9;
       }},
      {"two_point_wall_only_active_set_own_loop_copies", "-tpoc",
       ", two-point rows + wall-only shifting + active set with copies + own-loop guard",
       [](scheme::lsmps_params<2>& p) {
         two_point_own_loop(p);
         p.active_set_copies = true;
       }},
      {"two_point_wall_only_active_set_own_loop_copies_conditioned", "-tpocm",
       ", two-point rows + wall-only shifting + active set with copies + own-loop guard, cond1(M) <= 1e4",
       [](scheme::lsmps_params<2>& p) {
         two_point_own_loop(p);
         p.active_set_copies = true;
         p.op.max_condition = 1e4;
       }},
      {"two_point_wall_only_active_set_own_loop_copies_conditioned_limited", "-tpocml",
       ", two-point rows + wall-only shifting + active set with copies + own-loop guard, cond1(M) <= 1e4, "
       "shifted velocity limited",
       [](scheme::lsmps_params<2>& p) {  // the library's impact configuration without its collision settings
         const regularize::sized_collision_params collision = p.collision;
         const bool shift_isolated = p.shift_isolated_penalty;
         p = scheme::lsmps_impact_params<2>(p);
         p.collision = collision;
         p.shift_isolated_penalty = shift_isolated;
       }},
      {"neumann_points_wall_only_active_set", "-npa",
       ", Neumann-point walls + wall-only shifting + active set", [](scheme::lsmps_params<2>& p) {
         p.copy_row = scheme::copy_row_kind::neumann_points;
         p.shift.projection = regularize::penalty_projection::wall_only;
         p.active_set_solves = 10;
       }}};
  return v;
}
/// The variant named `name`; an unknown name is refused with the accepted list (`who` names the caller).
inline const tanaka_wall_variant& tanaka_wall_variant_named(const std::string& name, const char* who) {
  std::string accepted;
  for (const tanaka_wall_variant& w : tanaka_wall_variants()) {
    if (w.name == name) return w;
    accepted += (accepted.empty() ? "" : ", ") + w.name;
  }
  fail(who, ": wall variant '", name, "' (accepted: ", accepted, ")");
}

/// The first impact at the far-wall probe (195, 5) mm, sampled by the runner every step: a 10 ms window from
/// its first wet sample, a 2 ms filter (as the example tanaka_dam_break; measure_impact).
inline impact_measures far_wall_impact(const tanaka_dam_break_result& r) {
  return measure_impact(r.probe_t, r.probe_p, 0.01, 0.002);
}

/// The wall options that, with the collision stage and both isolated-particle options (the library's
/// scheme::lsmps_impact_params, tested to agree with this variant in label dam_break_lsmps), carry Tanaka's
/// dam break at every spacing measured (6-1.5 mm) and the obstacle case through the far-wall impact with no
/// guard activation (docs/validation.md): two-point copy rows, wall-only shifting, the active set, the
/// own-loop guard with the copies, conditioned fits and the limited shifted velocity (docs/lsmps_scheme.md).
inline constexpr const char* tanaka_impact_walls =
    "two_point_wall_only_active_set_own_loop_copies_conditioned_limited";

/// Does nothing (the default observer of run_tanaka_dam_break).
struct no_tanaka_observer {
  template <class Sim>
  void operator()(const Sim&) const {}
};

/// The column at rest: positions, zero velocity, volume L² (2D).
inline scheme::lsmps_state<2> tanaka_initial_state(const tanaka_dam_break_config& c,
                                                   const tanaka_dam_break& db) {
  scheme::lsmps_state<2> s0(db.size());
  s0.x() = db.x;
  s0.u().setZero();
  s0.template get<field::volume>().setConstant(c.L * c.L);
  return s0;
}
/// The case's part of the scheme options: ρ, ν, g (along −the last axis), Δt_max = α_C L / √(2 g H) (α_C =
/// p.time.courant, Tanaka's 0.1 by default), the blow-up bound max_speed = max_speed_factor √(g H) and the
/// removal box over the vessel's width [x_left, x_right] (c.remove_outside; the 2D vessel's [vessel_left,
/// vessel_right], the 3D slab's [0, W], cases/tanaka_dam_break_slab.hpp).
template <int D>
void set_tanaka_case_params(const tanaka_dam_break_config& c, scheme::lsmps_params<D>& p, double x_left,
                            double x_right) {
  p.rho = c.rho;  // (until 2026-12-04 not set: a config with rho != 1000 ran at lsmps_params' 1000)
  p.nu = c.mu / c.rho;
  p.g.setZero();
  p.g[D - 1] = -c.g;
  p.time.dt_max = p.time.courant * c.L / std::sqrt(2.0 * c.g * c.column_height);
  p.time.max_speed = c.max_speed_factor * std::sqrt(c.g * c.column_height);
  if (c.remove_outside) {
    p.remove_outside.lo[0] = x_left;
    p.remove_outside.hi[0] = x_right;
  }
}
/// The 2D case's: the removal box over [vessel_left, vessel_right].
inline void set_tanaka_case_params(const tanaka_dam_break_config& c, scheme::lsmps_params<2>& p) {
  set_tanaka_case_params<2>(c, p, c.vessel_left, c.vessel_right);
}

/// Runs to T = T_end. `p` carries the scheme options (copy rows, shifting, ...); the case sets the rest
/// (set_tanaka_case_params). With
/// catch_failure an mpskit::error ends the run and is recorded (the reporter's failed configurations);
/// otherwise it propagates. `observe(sim)` is called after every step
/// (output, progress). `pieces`: checkpoints, stopping and resuming (tanaka_pieces; refused before any step
/// when malformed, or when the file to resume is another configuration's).
template <class Scene = lsmps_defaults<2>, class Observer = no_tanaka_observer>
tanaka_dam_break_result run_tanaka_dam_break(const tanaka_dam_break_config& c, double T_end,
                                             scheme::lsmps_params<2> p = {}, bool catch_failure = false,
                                             Observer&& observe = {}, const tanaka_pieces& pieces = {}) {
  pieces.validate("run_tanaka_dam_break");
  const auto db = make_tanaka_dam_break(c);
  set_tanaka_case_params(c, p);
  simulation<Scene> sim(p, tanaka_initial_state(c, db), &db.walls);
  tanaka_dam_break_result r;
  r.rho_g_h = c.rho * c.g * c.column_height;
  r.particles = db.size();
  double next = 0.0;
  const auto volume = [&]() {
    return sim.state().template get<field::volume>().head(sim.state().n_real()).sum();
  };
  double V0 = volume();
  piece_clock clock(pieces);
  const auto wall = [&] { return clock.wall(); };
  // The running measurements (section "tanaka_dam_break.measures"; the samples' vectors whole in ".front" and
  // ".probe": at 1 mm ≈ 20 000 steps).
  measure_list measures;
  measures(V0)(next)(r.p_min)(r.p_min_copies)(r.u_max)(r.T_u_max)(r.min_pair_ratio)(r.T_min_pair)(
      r.min_pair_ratio_non_isolated)(r.particles)
      .add([&] { return r.wall_seconds_before + wall(); }, [&](double w) { r.wall_seconds_before = w; });
  if (!pieces.resume.empty()) {
    const std::string& file = pieces.resume;
    io::checkpoint_sections sec;
    io::load_simulation(file, sim, &sec);
    const std::vector<double> cv = sec.get_doubles("tanaka_dam_break.config"),
                              want = detail::tanaka_config_values(c);
    if (cv.size() != want.size())
      fail("run_tanaka_dam_break: '", file, "': section 'tanaka_dam_break.config' holds ", cv.size(),
           " values, expected ", want.size());
    for (std::size_t k = 0; k < want.size(); ++k)
      if (std::bit_cast<std::uint64_t>(cv[k]) != std::bit_cast<std::uint64_t>(want[k]))
        fail("run_tanaka_dam_break: '", file, "' was written with ", detail::tanaka_config_names[k], " = ",
             cv[k], "; this run has ", want[k], " (resume with the file's configuration)");
    measures.load(sec, "tanaka_dam_break.measures", "run_tanaka_dam_break", file);
    get_columns(sec, "tanaka_dam_break.front", {&r.T, &r.Z, &r.Z_body}, "run_tanaka_dam_break", file);
    get_columns(sec, "tanaka_dam_break.probe", {&r.probe_t, &r.probe_p}, "run_tanaka_dam_break", file);
    r.resumed_at = db.t_star(sim.time());
    if (!(r.resumed_at < T_end))
      fail("run_tanaka_dam_break: '", file, "' is at T = ", r.resumed_at,
           ", not before this run's T_end = ", T_end, " (nothing to run)");
    if (pieces.load_extra) pieces.load_extra(sec, r);
  }
  bool saving = false;  // a checkpoint that cannot be written is not the scheme's failure: thrown with
                        // catch_failure too
  const auto save = [&] {
    saving = true;
    io::checkpoint_sections sec;
    if (pieces.save_extra) pieces.save_extra(sec);
    for (const std::string& n : sec.names())
      if (n.rfind("tanaka_dam_break.", 0) == 0)
        fail("run_tanaka_dam_break: the caller's section name '", n, "' is reserved");
    sec.add_doubles("tanaka_dam_break.config", detail::tanaka_config_values(c));
    measures.save(sec, "tanaka_dam_break.measures");
    add_columns(sec, "tanaka_dam_break.front", {&r.T, &r.Z, &r.Z_body});
    add_columns(sec, "tanaka_dam_break.probe", {&r.probe_t, &r.probe_p});
    io::save_simulation(pieces.checkpoint, sim, std::move(sec));
    saving = false;
  };
  // before the first step: a bad path or section name is refused at once
  if (!pieces.checkpoint.empty()) save();
  try {
    while (db.t_star(sim.time()) < T_end) {
      sim.step();
      observe(sim);
      const index_t n = sim.state().n_real();
      const auto& P = sim.state().template get<field::pressure>();
      for (index_t i = 0; i < n; ++i) r.p_min = std::min(r.p_min, P[i]);
      const double u_step = n > 0 ? sim.state().u().leftCols(n).colwise().norm().maxCoeff() : 0.0;
      if (u_step > r.u_max) {
        r.u_max = u_step;
        r.T_u_max = db.t_star(sim.time());
      }
      for (index_t i = n; i < sim.state().size(); ++i) r.p_min_copies = std::min(r.p_min_copies, P[i]);
      const pair_ratios q = min_pair_ratios(sim.state(), p.domain);
      if (q.all < r.min_pair_ratio) {
        r.min_pair_ratio = q.all;
        r.T_min_pair = db.t_star(sim.time());
      }
      r.min_pair_ratio_non_isolated = std::min(r.min_pair_ratio_non_isolated, q.non_isolated);
      r.probe_t.push_back(sim.time());
      r.probe_p.push_back(probe_pressure(sim, db.probe(), c.L));
      const double T = db.t_star(sim.time());
      if (T >= next) {
        next += 0.05;
        const auto& fl = sim.state().flags();
        // Per-particle diameters (sqrt of the 2D volume): with splitting the front particle may be a fine
        // one.
        const Eigen::VectorXd d = sim.state().template get<field::volume>().head(n).cwiseSqrt();
        const auto counted = [&](index_t i) {
          return (fl[static_cast<std::size_t>(i)] & flag::isolated) == 0;
        };
        const double Z = db.front_star(sim.state().x(), d, n, counted);
        // may throw: push after it
        const std::vector<char> body = io::largest_body(sim.state().x(), d, n, counted);
        const double Z_body = db.front_star(
            sim.state().x(), d, n, [&](index_t i) { return body[static_cast<std::size_t>(i)] != 0; });
        r.T.push_back(T);
        r.Z.push_back(Z);
        r.Z_body.push_back(Z_body);
      }
      if (clock.after_step(save,
                           T < T_end)) {  // after the step's measurements: checkpoint, and stop when asked
        r.stopped = true;
        break;
      }
    }
    if (!r.stopped) clock.at_end(save);
  } catch (const mpskit::error& e) {
    if (!catch_failure || saving) throw;
    r.failed = true;
    r.T_failed = db.t_star(sim.time());
    r.failure = e.what();
  }
  r.T_reached = db.t_star(sim.time());
  r.wall_seconds = r.wall_seconds_before + wall();
  r.read_counts(sim.counters());
  r.particles_end = sim.state().n_real();
  r.L_min = std::sqrt(sim.state().template get<field::volume>().head(r.particles_end).minCoeff());
  r.splits = sim.counters().splits;
  r.merges = sim.counters().merges;
  r.left_domain_volume = sim.counters().left_domain_volume;
  r.volume_change = (volume() + r.left_domain_volume) / V0 - 1.0;
  r.filtered = sim.counters().filtered;
  r.filter_amplifying = sim.counters().filter_amplifying;
  r.filter_tapered = sim.counters().filter_tapered;
  r.ppe_iterations = sim.counters().ppe_iterations;
  r.own_loop_checked = sim.counters().own_loop_checked;
  r.own_loop_dirichlet = sim.counters().own_loop_dirichlet;
  r.own_loop_one_point = sim.counters().own_loop_one_point;
  r.own_loop_solves = sim.counters().own_loop_solves;
  r.ppe_fallbacks = sim.counters().ppe_fallbacks;
  r.ppe_breakdown_restarts = sim.counters().ppe_breakdown_restarts;
  r.ppe_cold_restarts = sim.counters().ppe_cold_restarts;
  r.shift_velocity_clipped = sim.counters().shift_velocity_clipped;
  return r;
}

}  // namespace mpskit::cases
