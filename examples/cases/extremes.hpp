#pragma once
// Extreme fluid pressures and speeds over a run, with where and when (the channel and gear cases' summaries).
#include <algorithm>

#include "mpskit/core/fields.hpp"

namespace mpskit::cases {

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

}  // namespace mpskit::cases
