#pragma once
/// \file io/simulation_checkpoint.hpp
/// \brief Checkpoint and restart of a simulation (scheme::semi_implicit): the particle state through
/// io::save_checkpoint plus sections for the simulated time, the run counters and the Δt controller.
///
/// Sections (docs/run.md, "Checkpoint and restart"):
///   `semi_implicit.time`       doubles {t}                          simulated time (s), bitwise
///   `semi_implicit.l0`         doubles {l0}                         spacing the run used (checked on load)
///   `semi_implicit.counters`   int64 {steps, ppe_iterations, ppe_iterations_max, pinned_components,
///                                     isolated, list_builds, reorders, negative_clamped, ppe_fallbacks,
///                                     ppe_breakdown_restarts, ppe_cold_restarts} (files before
///                                     ppe_fallbacks, 2026-12-02, hold 8 values, before
///                                     ppe_breakdown_restarts, 2026-12-03, 9, before ppe_cold_restarts,
///                                     2026-12-05, 10: still read, with 0)
///   `semi_implicit.time_step`  int64 {halvings, held, changes}
///
/// Not saved: the neighbour list and the solver's factorisation. The scheme builds its list from the
/// particle state at every step start, so a restart is bitwise identical to the uninterrupted run at any
/// step (tested at step 113, not a multiple of reorder_every).
#include <cmath>
#include <concepts>
#include <cstdint>
#include <filesystem>
#include <type_traits>
#include <utility>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/io/checkpoint.hpp"
#include "mpskit/scheme/semi_implicit.hpp"

namespace mpskit::io {

/// A classic-scheme simulation (scheme::semi_implicit); the LSMPS scheme has its own overloads in
/// io/lsmps_checkpoint.hpp.
template <class Sim>
concept classic_simulation =
    std::same_as<std::remove_cvref_t<decltype(std::declval<const Sim&>().counters())>,
                 scheme::semi_implicit_counters>;

/// The sections that hold a simulation's non-particle state (time, l0, counters, Δt controller).
template <classic_simulation Sim>
checkpoint_sections simulation_sections(const Sim& sim) {
  checkpoint_sections s;
  s.add("semi_implicit.time", sim.time());
  s.add("semi_implicit.l0", sim.params().l0);
  const scheme::semi_implicit_counters& c = sim.counters();
  std::vector<std::int64_t> cv;
  for (long scheme::semi_implicit_counters::*f : scheme::semi_implicit_counter_fields) cv.push_back(c.*f);
  s.add_int64s("semi_implicit.counters", cv);
  const scheme::time_step_state& ts = sim.time_step().state();
  s.add_int64s("semi_implicit.time_step", scheme::section_values(ts));
  return s;
}

/// Writes the simulation's particles and sections to `path` (atomically; see io::save_checkpoint).
template <classic_simulation Sim>
void save_simulation(const std::filesystem::path& path, const Sim& sim) {
  save_checkpoint(path, sim.state(), simulation_sections(sim));
}

/// \brief Restores a simulation written by save_simulation into `sim`, which must never have stepped
/// (its neighbour list is then empty and the next step builds one; a stepped simulation would keep a
/// list of other particles). Refuses, with an mpskit::error naming the file: everything load_checkpoint
/// refuses, a missing or malformed section, another l0, ghosts, a stepped target. On error `sim` is
/// left untouched.
template <classic_simulation Sim>
void load_simulation(const std::filesystem::path& path, Sim& sim) {
  const std::string file = path.string();
  if (sim.neighbours().rows() != 0)
    fail("load_simulation: '", file, "': the target simulation has already stepped (load into a new one)");
  typename Sim::state_type st;
  checkpoint_sections s;
  load_checkpoint(path, st, s);
  if (st.n_ghost() != 0)
    fail("load_simulation: '", file, "': the checkpoint holds ", st.n_ghost(), " ghosts");
  for (index_t i = 0; i < st.n_real(); ++i) {
    const kind k = st.kinds()[static_cast<std::size_t>(i)];
    if (k != kind::fluid && k != kind::wall && k != kind::dummy)
      fail("load_simulation: '", file, "': particle ", i, " has kind '", name(k),
           "' (the scheme takes fluid, wall, dummy)");
  }
  const double t = s.get_double("semi_implicit.time");
  if (!std::isfinite(t) || t < 0.0)
    fail("load_simulation: '", file, "': time ", t, " s is not finite and >= 0");
  const double l0 = s.get_double("semi_implicit.l0");
  if (l0 != sim.params().l0)
    fail("load_simulation: '", file, "': written with l0 = ", l0,
         " m, the simulation has l0 = ", sim.params().l0, " m");
  const std::vector<std::int64_t> c = s.get_int64s("semi_implicit.counters");
  const std::vector<std::int64_t> ts = s.get_int64s("semi_implicit.time_step");
  constexpr std::size_t count = scheme::semi_implicit_counter_fields.size(),
                        count_min = 8;  // 8 to 10: older files
  if (c.size() < count_min || c.size() > count)
    fail("load_simulation: '", file, "': section 'semi_implicit.counters' holds ", c.size(),
         " values, expected ", count, " (or ", count_min, " to ", count - 1, " from older files)");
  if (ts.size() != 3)
    fail("load_simulation: '", file, "': section 'semi_implicit.time_step' holds ", ts.size(),
         " values, expected 3");
  for (std::int64_t v : c)
    if (v < 0) fail("load_simulation: '", file, "': a counter is negative (", v, ")");
  if (ts[0] < 0 || ts[0] > sim.time_step().max_rungs() || ts[1] < 0 || ts[2] < 0)
    fail("load_simulation: '", file, "': time-step state {", ts[0], ", ", ts[1], ", ", ts[2],
         "} out of range (rungs in [0, ", sim.time_step().max_rungs(), "], counts >= 0)");
  scheme::semi_implicit_counters k;  // counters an older file lacks stay 0
  for (std::size_t j = 0; j < c.size(); ++j)
    k.*scheme::semi_implicit_counter_fields[j] = static_cast<long>(c[j]);
  const scheme::time_step_state tss = scheme::time_step_state_from(ts);
  sim.state() = std::move(st);
  sim.restore(t, k, tss);
}

}  // namespace mpskit::io
