#pragma once
// What the runners measure during a run: the fluid volume, the velocity flux through a slab, the extreme
// fluid pressures and speeds with where and when (channels, gears), a pressure probe's first impact (dam
// breaks), and the closest pair of particles (clustering), and a trace of the fastest particle's
// neighbourhood (failures).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <ostream>
#include <type_traits>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/search/domain.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::cases {

/// Fills particles_end, L_min, L_max (diameters V^(1/D)) and the split/merge counts of a finished run.
template <class Sim, class Result>
void record_sizes(const Sim& sim, Result& r) {
  const auto& st = sim.state();
  constexpr int D = std::remove_cvref_t<decltype(st)>::dim;
  const auto& V = st.template get<field::volume>();
  r.particles_end = st.n_real();
  r.L_min = 1e300;
  r.L_max = 0.0;
  for (index_t i = 0; i < st.n_real(); ++i) {
    const double Li = D == 2 ? std::sqrt(V[i]) : std::cbrt(V[i]);
    r.L_min = std::min(r.L_min, Li);
    r.L_max = std::max(r.L_max, Li);
  }
  r.splits = sim.counters().splits;
  r.merges = sim.counters().merges;
}

/// The closest pairs of real particles (issue #9's clustering measure r_ij / L_ij, L_ij = (L_i + L_j)/2,
/// diameters V^(1/D)), over pairs closer than 1.5 L_ij; +1e300 when no pair is that close.
struct pair_ratios {
  double all = 1e300;           ///< every pair (the strict reading of the issue's bound)
  double non_isolated = 1e300;  ///< pairs of which neither particle carries flag::isolated (spray left out)
};

/// Both readings of the clustering measure at once (pair_ratios). Builds its own list (sequential); the
/// isolated flags are the ones the last step set.
template <class State, int D>
pair_ratios min_pair_ratios(const State& st, const search::domain<D>& dom) {
  const index_t n = st.n_real();
  Eigen::VectorXd Ld(n);
  for (index_t i = 0; i < n; ++i) Ld[i] = std::pow(st.template get<field::volume>()[i], 1.0 / D);
  points<D> x = st.x().leftCols(n);
  search::neighbour_list<D> nl;
  nl.build(exec::seq{}, x, search::per_particle_radius{&Ld, 1.5}, {0.0, dom});
  const auto& fl = st.flags();
  const auto isolated = [&](index_t i) { return (fl[static_cast<std::size_t>(i)] & flag::isolated) != 0; };
  pair_ratios m;
  for (index_t i = 0; i < n; ++i)
    for (const auto jj : nl.neighbours(i)) {
      const index_t j = static_cast<index_t>(jj);
      const double q = nl.displacement(x, i, j).norm() / (0.5 * (Ld[i] + Ld[j]));
      m.all = std::min(m.all, q);
      if (!isolated(i) && !isolated(j)) m.non_isolated = std::min(m.non_isolated, q);
    }
  return m;
}

/// pair_ratios::all: the closest pair of real particles, isolated ones included.
template <class State, int D>
double min_pair_ratio(const State& st, const search::domain<D>& dom) {
  return min_pair_ratios(st, dom).all;
}

/// Σ V over the real particles (m² in 2D).
template <class State>
double fluid_volume(const State& st) {
  return st.template get<field::volume>().head(st.n_real()).sum();
}

/// Velocity flux through the slab |x_0 − x0| < h across axis 0: Σ V u_x / (2 h) over the real particles in
/// it.
template <class State>
double slab_flux(const State& st, double x0, double h) {
  const auto& V = st.template get<field::volume>();
  double q = 0.0;
  for (index_t i = 0; i < st.n_real(); ++i)
    if (std::abs(st.x()(0, i) - x0) < h) q += V[i] * st.u()(0, i);
  return q / (2.0 * h);
}

/// Updates r.p_min / r.p_max (and their _at position and _t time), r.u_max (and u_max_at / u_max_t when the
/// result has them) and, inside the averaging window, r.u_max_window, from the real particles of `st` at time
/// t. Start a run with r.p_min = +1e300 and r.p_max = −1e300.
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
/// creations and removals, removals behind a face, guard activations, splits, merges), the volume ledger's
/// error |V_end − V0 − (inflow − outflow volume)| / V0, and the final particle count and smallest / largest
/// diameter (V^(1/2), 2D) of the real particles of st.
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
  if constexpr (requires { r.ppe_iterations; }) r.ppe_iterations = k.ppe_iterations;
  r.ledger_error = std::abs(V_end - V0 - k.net_boundary_volume()) / V0;
  r.particles_end = st.n_real();
  r.L_min = std::sqrt(V.minCoeff());
  r.L_max = std::sqrt(V.maxCoeff());
}

/// A pressure probe's first impact, from its time series sampled every step (measure_impact).
struct impact_measures {
  /// first sample with a value (the probe wet), s
  double t_arrival = std::numeric_limits<double>::quiet_NaN();
  double window = 0.0;    ///< length of the impact window [t_arrival, t_arrival + window], s
  bool complete = false;  ///< the series reaches the window's end (else the numbers are partial)
  double impulse = 0.0;   ///< ∫ p dt over the window (trapezoids; dry samples count 0), Pa s
  double peak = std::numeric_limits<double>::quiet_NaN();             ///< largest sample in the window, Pa
  double t_peak = std::numeric_limits<double>::quiet_NaN();           ///< its time, s
  double peak_filtered = std::numeric_limits<double>::quiet_NaN();    ///< largest centred moving average, Pa
  double t_peak_filtered = std::numeric_limits<double>::quiet_NaN();  ///< its time, s
  /// largest of every `every`-th step's sample, Pa
  double peak_sparse = std::numeric_limits<double>::quiet_NaN();
};

/// The first impact of a probe series (t_k, p_k), one sample per step, p_k NaN while the probe is dry:
/// arrival = the first finite sample; impulse = ∫ p dt over [t_arrival, t_arrival + window] (trapezoids, dry
/// samples as 0); peak = the largest sample there; peak_filtered = the largest centred moving average over
/// `filter` s ((C(t + f/2) − C(t − f/2))/f with C the trapezoid integral, linear between samples; only
/// centres whose average lies inside the series); peak_sparse = the largest sample at steps that are
/// multiples of `every` (step k of the series is step k + 1 of the run), inside the window: Tanaka sampled
/// every 100 steps (§5.6.1). A series that never gets wet gives NaN numbers; t must increase.
inline impact_measures measure_impact(const std::vector<double>& t, const std::vector<double>& p,
                                      double window, double filter, long every = 100) {
  if (t.size() != p.size()) fail("measure_impact: ", t.size(), " times but ", p.size(), " values");
  if (!(window > 0.0) || !(filter > 0.0) || every < 1)
    fail("measure_impact: window = ", window, " s and filter = ", filter, " s must be > 0, every = ", every,
         " >= 1");
  for (std::size_t k = 1; k < t.size(); ++k)
    if (!(t[k] > t[k - 1])) fail("measure_impact: times not increasing at sample ", k);
  impact_measures m;
  m.window = window;
  std::size_t a = 0;
  while (a < p.size() && !std::isfinite(p[a])) ++a;
  if (a == p.size()) return m;
  m.t_arrival = t[a];
  const double t_end = m.t_arrival + window;
  m.complete = t.back() >= t_end;
  const auto val = [&](std::size_t k) { return std::isfinite(p[k]) ? p[k] : 0.0; };
  // C_k = ∫_{t_0}^{t_k} p dt; C at any time by linear interpolation (the filter's integral).
  std::vector<double> C(t.size(), 0.0);
  for (std::size_t k = 1; k < t.size(); ++k)
    C[k] = C[k - 1] + 0.5 * (val(k) + val(k - 1)) * (t[k] - t[k - 1]);
  const auto C_at = [&](double s) {
    const auto it = std::upper_bound(t.begin(), t.end(), s);
    if (it == t.begin()) return C.front();
    if (it == t.end()) return C.back();
    const std::size_t k = static_cast<std::size_t>(it - t.begin());
    const double f = (s - t[k - 1]) / (t[k] - t[k - 1]);
    return C[k - 1] + f * (C[k] - C[k - 1]);
  };
  m.impulse = C_at(std::min(t_end, t.back())) - C[a];
  for (std::size_t k = a; k < t.size() && t[k] <= t_end; ++k) {
    const double v = val(k);
    if (!(v <= m.peak)) {
      m.peak = v;
      m.t_peak = t[k];
    }
    if ((static_cast<long>(k) + 1) % every == 0 && !(v <= m.peak_sparse)) m.peak_sparse = v;
    if (t[k] - 0.5 * filter >= t.front() && t[k] + 0.5 * filter <= t.back()) {
      const double avg = (C_at(t[k] + 0.5 * filter) - C_at(t[k] - 0.5 * filter)) / filter;
      if (!(avg <= m.peak_filtered)) {
        m.peak_filtered = avg;
        m.t_peak_filtered = t[k];
      }
    }
  }
  return m;
}

/// Writes the fastest fluid particle of an LSMPS simulation's last step and every particle within its support
/// radius R_e = re_ratio L_i (fluid and imaginary wall copies, with each copy's parent) to `out`, when its
/// speed exceeds `speed` (m/s); returns whether it wrote. For finding where a run starts to fail (the error
/// of a collapsed time step names only the particle): offsets in L_i, pressures in units of `p_unit` (e.g.
/// ρgH), c the packing ratio of that step, s the surface flag. The neighbours are found by a full scan (O(N)
/// per call; offsets by the step's list's minimum image on periodic axes): meant for the few steps after a
/// threshold is first crossed. Positions are those after the step; the copies are the step's (made before the
/// move).
template <class Sim>
bool trace_fast_particle(std::ostream& out, const Sim& sim, double speed, double p_unit, double T) {
  const auto& st = sim.state();
  const index_t n = st.n_real(), nt = st.size();
  if (n == 0) return false;
  index_t f = 0;
  double umax = 0.0;
  for (index_t i = 0; i < n; ++i)
    if (const double v = st.u().col(i).norm(); v > umax) umax = v, f = i;
  if (!(umax > speed)) return false;
  const auto& P = st.template get<field::pressure>();
  const auto& parent = st.template get<field::parent>();
  const auto& c = sim.packing_ratio();
  const double L = sim.diameter(f), R = sim.params().op.re_ratio * L;
  const auto packing = [&](index_t j) { return j < c.size() ? c[j] : std::nan(""); };
  const auto line = [&](const char* what, index_t j) {
    const auto d = sim.neighbours().displacement(st.x(), f, j);  // x_j − x_f, minimum image on periodic axes
    out << "  " << what << ' ' << j << "  d/L (" << d[0] / L;
    for (int a = 1; a < d.size(); ++a) out << ", " << d[a] / L;
    out << ")  u (" << st.u()(0, j);
    for (int a = 1; a < st.x().rows(); ++a) out << ", " << st.u()(a, j);
    out << ") m/s  p " << P[j] / p_unit << "  c " << packing(j) << "  s "
        << ((st.flags()[j] & flag::surface) != 0);
    if (j >= n) out << "  parent " << parent[static_cast<std::size_t>(j)];
    out << '\n';
  };
  out << "T " << T << " t " << sim.time() << " s, step " << sim.counters().steps << ", dt " << sim.dt()
      << " s: fastest fluid particle " << f << " at |u| = " << umax << " m/s, x = (" << st.x()(0, f);
  for (int a = 1; a < st.x().rows(); ++a) out << ", " << st.x()(a, f);
  out << ") m\n";
  line("self", f);
  for (index_t j = 0; j < nt; ++j)
    if (j != f && sim.neighbours().displacement(st.x(), f, j).norm() < R) line(j < n ? "fluid" : "copy ", j);
  return true;
}

}  // namespace mpskit::cases
