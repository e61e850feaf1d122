#pragma once
/// \file io/lsmps_checkpoint.hpp
/// \brief Checkpoint and restart of an LSMPS simulation (scheme::lsmps_semi_implicit): the real particles
/// through io::save_checkpoint plus sections for the time, the counters, the Δt controller and the
/// split/merge ledger.
///
/// Sections (docs/run.md, "Checkpoint and restart"):
///   `lsmps.time`                doubles {t, Δt of the last step}      (s), bitwise
///   `lsmps.counters`            int64 ×43, lsmps_counters' integer counters in the order of
///                               detail::lsmps_counter_values (older files hold 24 to 42, the missing ones
///                               read as 0: see lsmps_counter_count_min)
///   `lsmps.boundary_volumes`    doubles {inflow_volume, outflow_volume, left_domain_volume} (older files:
///                               the first two, the third read as 0)
///   `lsmps.time_step`           int64 {halvings, held, changes}
///   `lsmps.ledger.counts`       int64 {steps, splits, merges}         conservation_ledger totals
///   `lsmps.ledger.sums`         doubles {dV, dVu (D), dKE, dL (1 or 3), max volume ulps, max momentum ulps}
///   `lsmps.ledger.flux_names`   bytes, the boundary names joined by '\n'
///   `lsmps.ledger.fluxes`       doubles, per flux {volume, momentum (D)}
///   `lsmps.ledger.flux_particles` int64, per flux
///   `lsmps.active_set_held`     int64, the ids the active set held at the last pressure solve's end
///                               (lsmps_params::active_set_warm_start; empty without it; older files: none,
///                               read as empty)
///
/// Not saved: this step's imaginary copies and pressure-boundary particles (ghosts, made anew at every step
/// start), the neighbour list, the operators and the solver's lagged factorisation. A restart is therefore
/// bitwise identical to the uninterrupted run when the solver keeps no factorisation across steps
/// (solver_params::ilut_reuse = 1, or a preconditioner without one); with lagged ILUT factors the first solve
/// after the restart factorises afresh and the runs agree to the solver's tolerance (docs/run.md).
/// The walls and the pressure boundary are the caller's objects and are not saved: pass the same ones.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/io/checkpoint.hpp"
#include "mpskit/scheme/lsmps_semi_implicit.hpp"

namespace mpskit::io {

namespace detail {
inline std::vector<std::int64_t> lsmps_counter_values(const scheme::lsmps_counters& c) {
  std::vector<std::int64_t> v;
  v.reserve(scheme::lsmps_counter_fields.size());
  for (long scheme::lsmps_counters::*f : scheme::lsmps_counter_fields) v.push_back(c.*f);
  return v;
}
inline constexpr std::size_t lsmps_counter_count = scheme::lsmps_counter_fields.size();
/// The counts of files written before filter_amplifying (24) and filter_tapered (25) existed (both
/// 2026-12-01) or before the own-loop guard's four (26–29, 2026-12-02), ppe_fallbacks (30, 2026-12-02) or
/// shift_velocity_clipped (31, 2026-12-02), ppe_breakdown_restarts (32, 2026-12-03), collisions (33,
/// 2026-12-03) or collision_coincident and shift_coincident (34, 35, 2026-12-03) or left_domain (36,
/// 2026-12-03) or active_set_released (37, 2026-12-05) or ppe_cold_restarts (38, 2026-12-05) or ppe_solves
/// and ppe_factorisations (39, 40, 2026-12-07) or ppe_repeat_solves and ppe_repeat_iterations (41, 42,
/// 2026-12-07): still read, the missing counters 0.
inline constexpr std::size_t lsmps_counter_count_min = 24;
}  // namespace detail

/// Adds the LSMPS simulation's non-particle state to `s` (see the file comment).
template <class Scene>
void add_simulation_sections(checkpoint_sections& s, const scheme::lsmps_semi_implicit<Scene>& sim) {
  constexpr int D = Scene::dim;
  s.add_doubles("lsmps.time", {sim.time(), sim.dt()});
  const scheme::lsmps_counters& c = sim.counters();
  s.add_int64s("lsmps.counters", detail::lsmps_counter_values(c));
  s.add_doubles("lsmps.boundary_volumes", {c.inflow_volume, c.outflow_volume, c.left_domain_volume});
  const scheme::time_step_state& ts = sim.time_step().state();
  s.add_int64s("lsmps.time_step", scheme::section_values(ts));
  const resolution::ledger_step<D>& t = sim.ledger().totals();
  s.add_int64s("lsmps.ledger.counts", {sim.ledger().steps(), t.splits, t.merges});
  std::vector<double> sums{t.dV};
  for (int a = 0; a < D; ++a) sums.push_back(t.dVu[a]);
  sums.push_back(t.dKE);
  for (index_t a = 0; a < t.dL.size(); ++a) sums.push_back(t.dL[a]);
  sums.push_back(t.max_volume_ulps);
  sums.push_back(t.max_momentum_ulps);
  s.add_doubles("lsmps.ledger.sums", sums);
  std::string names;
  std::vector<double> fluxes;
  std::vector<std::int64_t> particles;
  for (const auto& f : t.fluxes) {
    if (f.name.find('\n') != std::string::npos || f.name.empty())
      fail("save_simulation: ledger flux name '", f.name, "' is empty or holds a line break");
    names += (names.empty() ? "" : "\n") + f.name;
    fluxes.push_back(f.volume);
    for (int a = 0; a < D; ++a) fluxes.push_back(f.momentum[a]);
    particles.push_back(f.particles);
  }
  s.add_bytes("lsmps.ledger.flux_names", names);
  s.add_doubles("lsmps.ledger.fluxes", fluxes);
  s.add_int64s("lsmps.ledger.flux_particles", particles);
  std::vector<std::int64_t> held;
  for (const particle_id id : sim.active_set_held()) held.push_back(static_cast<std::int64_t>(id));
  s.add_int64s("lsmps.active_set_held", held);
}

/// \brief Writes the LSMPS simulation's real particles (not this step's copies and boundary particles) and
/// its sections to `path` (atomically, io::save_checkpoint). `extra`: the caller's own sections (e.g. a
/// case's running measurements), saved beside the simulation's; their names must not start with "lsmps.".
template <class Scene>
void save_simulation(const std::filesystem::path& path, const scheme::lsmps_semi_implicit<Scene>& sim,
                     checkpoint_sections extra = {}) {
  for (const std::string& n : extra.names())
    if (n.rfind("lsmps.", 0) == 0)
      fail("save_simulation: '", path.string(), "': section name '", n, "' is reserved");
  add_simulation_sections(extra, sim);
  typename scheme::lsmps_semi_implicit<Scene>::state_type real = sim.state();
  real.clear_ghosts();
  save_checkpoint(path, real, extra);
}

/// \brief Restores an LSMPS simulation written by save_simulation into `sim`, which must be new (constructed
/// with the same scene, parameters, walls and pressure boundary, never stepped). `sections` (optional)
/// receives every section of the file, the caller's own included. Refuses, with an mpskit::error naming the
/// file: everything load_checkpoint refuses (another dimension or field list, e.g. a classic scheme's
/// checkpoint), a missing or malformed section, and everything lsmps_semi_implicit::restore refuses. On error
/// `sim` is unchanged.
template <class Scene>
void load_simulation(const std::filesystem::path& path, scheme::lsmps_semi_implicit<Scene>& sim,
                     checkpoint_sections* sections = nullptr) {
  constexpr int D = Scene::dim;
  const std::string file = path.string();
  if (sim.neighbours().rows() != 0)
    fail("load_simulation: '", file, "': the target simulation has already stepped (load into a new one)");
  typename scheme::lsmps_semi_implicit<Scene>::state_type st;
  checkpoint_sections s;
  load_checkpoint(path, st, s);
  const auto expect = [&](std::string_view name, std::size_t got, std::size_t want) {
    if (got != want)
      fail("load_simulation: '", file, "': section '", name, "' holds ", got, " values, expected ", want);
  };
  const std::vector<double> time = s.get_doubles("lsmps.time");
  expect("lsmps.time", time.size(), 2);
  const std::vector<std::int64_t> cv = s.get_int64s("lsmps.counters");
  if (cv.size() < detail::lsmps_counter_count_min || cv.size() > detail::lsmps_counter_count)
    fail("load_simulation: '", file, "': section 'lsmps.counters' holds ", cv.size(), " values, expected ",
         detail::lsmps_counter_count, " (or ", detail::lsmps_counter_count_min, " to ",
         detail::lsmps_counter_count - 1, " from older files)");
  const std::vector<double> bv = s.get_doubles("lsmps.boundary_volumes");
  if (bv.size() != 2 && bv.size() != 3)
    fail("load_simulation: '", file, "': section 'lsmps.boundary_volumes' holds ", bv.size(),
         " values, expected 3 (or 2 from older files)");
  const std::vector<std::int64_t> tsv = s.get_int64s("lsmps.time_step");
  expect("lsmps.time_step", tsv.size(), 3);
  scheme::lsmps_counters c;
  for (std::size_t k = 0; k < cv.size(); ++k) c.*scheme::lsmps_counter_fields[k] = static_cast<long>(cv[k]);
  c.inflow_volume = bv[0];
  c.outflow_volume = bv[1];
  c.left_domain_volume = bv.size() == 3 ? bv[2] : 0.0;
  const scheme::time_step_state ts = scheme::time_step_state_from(tsv);

  resolution::ledger_step<D> t;
  const std::vector<std::int64_t> lc = s.get_int64s("lsmps.ledger.counts");
  expect("lsmps.ledger.counts", lc.size(), 3);
  t.splits = static_cast<index_t>(lc[1]);
  t.merges = static_cast<index_t>(lc[2]);
  const std::vector<double> sums = s.get_doubles("lsmps.ledger.sums");
  const std::size_t nl = static_cast<std::size_t>(t.dL.size());
  expect("lsmps.ledger.sums", sums.size(), 1 + D + 1 + nl + 2);
  std::size_t k = 0;
  t.dV = sums[k++];
  for (int a = 0; a < D; ++a) t.dVu[a] = sums[k++];
  t.dKE = sums[k++];
  for (std::size_t a = 0; a < nl; ++a) t.dL[static_cast<index_t>(a)] = sums[k++];
  t.max_volume_ulps = sums[k++];
  t.max_momentum_ulps = sums[k++];
  const std::string& names = s.get_bytes("lsmps.ledger.flux_names");
  const std::vector<double> fl = s.get_doubles("lsmps.ledger.fluxes");
  const std::vector<std::int64_t> fp = s.get_int64s("lsmps.ledger.flux_particles");
  std::vector<std::string> split_names;
  for (std::size_t a = 0; a < names.size();) {
    const std::size_t e = std::min(names.find('\n', a), names.size());
    split_names.push_back(names.substr(a, e - a));
    a = e + 1;
  }
  expect("lsmps.ledger.flux_particles", fp.size(), split_names.size());
  expect("lsmps.ledger.fluxes", fl.size(), split_names.size() * (1 + D));
  for (std::size_t f = 0; f < split_names.size(); ++f) {
    resolution::flux_entry<D> e;
    e.name = split_names[f];
    e.volume = fl[f * (1 + D)];
    for (int a = 0; a < D; ++a) e.momentum[a] = fl[f * (1 + D) + 1 + static_cast<std::size_t>(a)];
    e.particles = static_cast<index_t>(fp[f]);
    t.fluxes.push_back(std::move(e));
  }
  std::vector<particle_id> held;
  if (s.contains("lsmps.active_set_held"))
    for (const std::int64_t id : s.get_int64s("lsmps.active_set_held"))
      held.push_back(static_cast<particle_id>(id));
  try {
    sim.restore(std::move(st), time[0], time[1], c, ts, t, static_cast<long>(lc[0]), std::move(held));
  } catch (const mpskit::error& e) {
    fail("load_simulation: '", file, "': ", e.what());
  }
  if (sections) *sections = std::move(s);
}

}  // namespace mpskit::io
