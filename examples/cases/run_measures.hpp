#pragma once
// What the channel and gear runners measure during a run: the fluid volume, the velocity flux through a slab,
// and the extreme fluid pressures and speeds with where and when.
#include <algorithm>
#include <cmath>

#include "mpskit/core/fields.hpp"

namespace mpskit::cases {

/// Σ V over the real particles (m² in 2D).
template <class State>
double fluid_volume(const State& st) {
  return st.template get<field::volume>().head(st.n_real()).sum();
}

/// Velocity flux through the slab |x_0 − x0| < h across axis 0: Σ V u_x / (2 h) over the real particles in it.
template <class State>
double slab_flux(const State& st, double x0, double h) {
  const auto& V = st.template get<field::volume>();
  double q = 0.0;
  for (index_t i = 0; i < st.n_real(); ++i)
    if (std::abs(st.x()(0, i) - x0) < h) q += V[i] * st.u()(0, i);
  return q / (2.0 * h);
}

/// Updates r.p_min / r.p_max (and their _at position and _t time), r.u_max (and u_max_at / u_max_t when the
/// result has them) and, inside the averaging window, r.u_max_window, from the real particles of `st` at time t.
/// Start a run with r.p_min = +1e300 and r.p_max = −1e300.
template <class Result, class State>
void track_extremes(Result& r, const State& st, double t, bool in_window) {
  const auto& P = st.template get<field::pressure>();
  for (index_t i = 0; i < st.n_real(); ++i) {
    if (P[i] < r.p_min) {
      r.p_min = P[i];
      r.p_min_at = st.x().col(i);
      r.p_min_t = t;
    }
    if (P[i] > r.p_max) {
      r.p_max = P[i];
      r.p_max_at = st.x().col(i);
      r.p_max_t = t;
    }
    const double u = st.u().col(i).norm();
    if (u > r.u_max) {
      r.u_max = u;
      if constexpr (requires { r.u_max_at; r.u_max_t; }) {
        r.u_max_at = st.x().col(i);
        r.u_max_t = t;
      }
    }
    if (in_window) r.u_max_window = std::max(r.u_max_window, u);
  }
}

/// The channel runners' end of run: event counts from the stepper's counters k (steps, pressure-boundary
/// creations and removals, removals behind a face, guard activations, splits, merges), the volume ledger's error
/// |V_end − V0 − (inflow − outflow volume)| / V0, and the final particle count and smallest / largest diameter
/// (V^(1/2), 2D) of the real particles of st.
template <class Result, class Counters, class State>
void record_channel_end(Result& r, const Counters& k, const State& st, double V0) {
  const auto V = st.template get<field::volume>().head(st.n_real());
  const double V_end = V.sum();
  r.steps = k.steps;
  r.inflow = k.inflow;
  r.outflow = k.outflow;
  r.outflow_behind = k.outflow_behind;
  r.guarded = k.guarded;
  r.splits = k.splits;
  r.merges = k.merges;
  r.ledger_error = std::abs(V_end - V0 - (k.inflow_volume - k.outflow_volume)) / V0;
  r.particles_end = st.n_real();
  r.L_min = std::sqrt(V.minCoeff());
  r.L_max = std::sqrt(V.maxCoeff());
}

}  // namespace mpskit::cases
