#pragma once
/// \file resolution/ledger.hpp
/// \brief conservation_ledger<D>: the per-event and per-step bookkeeping of particle splitting and merging
/// (issue #9 item 2, docs/resolution.md "Conservation ledger").
///
/// Volume is the stored size, so a split halves it exactly and a merge adds two volumes (one rounding).
/// Every event is checked: |ΔΣV| ≤ volume_ulp · ε · ΣV and |ΔΣVu| ≤ momentum_ulp · ε · ΣV|u| (ε = 2⁻⁵², "one
/// ulp of X" = ε X; sums over the event's particles, before or after, whichever is larger), and a violation
/// throws mpskit::error naming the event. The changes are measured exactly (double-double sums, products by
/// fma), so the check sees the true rounding of the event and not the rounding of the check.
/// Kinetic energy and angular momentum are reported, not asserted: eq. 70 (split velocities) adds
/// ½ ρ V |δ ∇u t|² of kinetic energy and ρ V δ² t × (∇u t) of angular momentum, eqs. 72–73 (merge) remove
/// ½ ρ μ |u_ij|² and ρ μ x_ij × u_ij (μ = V_i V_j / (V_i + V_j)); docs/resolution.md works both examples.
/// Boundary fluxes (inflow, outflow, deletions) are added by other code through add_flux().
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/params.hpp"

namespace mpskit::resolution {

namespace detail {
/// Double-double accumulator (Knuth's TwoSum, products split exactly by fma): sums of a few hundred
/// doubles and products with a relative error near 2⁻¹⁰⁵, so a change of one ulp is measured exactly.
struct exact_sum {
  double hi = 0.0, lo = 0.0;
  /// Adds x.
  void add(double x) {
    const double s = hi + x;
    const double bp = s - hi;
    const double err = (hi - (s - bp)) + (x - bp);
    hi = s;
    lo += err;
    renormalise();
  }
  /// Adds a·b (the product's rounding error is kept: fma(a, b, −p) is exact).
  void add_product(double a, double b) {
    const double p = a * b;
    add(p);
    add(std::fma(a, b, -p));
  }
  /// The sum rounded to double.
  double value() const { return hi + lo; }
  /// this − o, rounded once.
  double minus(const exact_sum& o) const {
    exact_sum d = *this;
    d.add(-o.hi);
    d.add(-o.lo);
    return d.value();
  }

 private:
  void renormalise() {
    const double s = hi + lo;
    lo = lo - (s - hi);
    hi = s;
  }
};
}  // namespace detail

/// Angular momentum: a scalar (the z component) in 2D, a vector in 3D.
template <int D>
using angular_t = Eigen::Matrix<double, D == 2 ? 1 : 3, 1>;

/// a × b (2D: the scalar a_x b_y − a_y b_x).
template <int D>
angular_t<D> cross(const vec<D>& a, const vec<D>& b) {
  angular_t<D> c;
  if constexpr (D == 2) {
    c[0] = a[0] * b[1] - a[1] * b[0];
  } else {
    c = a.cross(b);
  }
  return c;
}

/// One particle as the ledger sees it: volume, position, velocity.
template <int D>
struct particle_view {
  double V = 0.0;             ///< volume (m^D)
  vec<D> x = vec<D>::Zero();  ///< position (m), unwrapped relative to the event
  vec<D> u = vec<D>::Zero();  ///< velocity (m/s)
};

/// Tolerances of the per-event checks and the density of the reports.
struct ledger_params {
  double volume_ulp = 4.0;    ///< |ΔΣV| ≤ volume_ulp · ε · ΣV per event (issue #9: 4)
  double momentum_ulp = 8.0;  ///< |ΔΣVu| ≤ momentum_ulp · ε · ΣV|u| per event (issue #9: 8)
  double rho = 1000.0;        ///< density (kg/m³) for the kinetic energy and angular momentum reports

  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("ledger_params");
    v.in_range("volume_ulp", volume_ulp, 0.0, 1e6).in_range("momentum_ulp", momentum_ulp, 0.0, 1e6);
    v.positive("rho", rho);
    v.throw_if_any();
  }
};

/// What one event changed (after − before).
template <int D>
struct event_balance {
  double dV = 0.0;                         ///< ΔΣV (m^D), exact to the last bit
  vec<D> dVu = vec<D>::Zero();             ///< ΔΣVu (m^(D+1)/s)
  double scale_V = 0.0;                    ///< ΣV of the event (larger of before/after)
  double scale_Vu = 0.0;                   ///< ΣV|u| of the event (larger of before/after)
  double dKE = 0.0;                        ///< Δ ½ ρ Σ V|u|² (J in 3D, J/m in 2D)
  angular_t<D> dL = angular_t<D>::Zero();  ///< Δ ρ Σ V x × u (origin-independent: ΣVu is kept)
  /// |ΔΣV| in units of ε ΣV.
  double volume_ulps() const { return scale_V > 0.0 ? std::abs(dV) / (eps() * scale_V) : 0.0; }
  /// |ΔΣVu| in units of ε ΣV|u|.
  double momentum_ulps() const { return scale_Vu > 0.0 ? dVu.norm() / (eps() * scale_Vu) : 0.0; }
  static constexpr double eps() { return std::numeric_limits<double>::epsilon(); }
};

/// Volume and momentum through one named boundary in a step (positive: into the domain).
template <int D>
struct flux_entry {
  std::string name;                  ///< boundary name (e.g. "inflow")
  double volume = 0.0;               ///< ΣV entering (m^D)
  vec<D> momentum = vec<D>::Zero();  ///< ΣVu entering (m^(D+1)/s)
  index_t particles = 0;             ///< particles entering (negative: leaving)
};

/// One step of the ledger.
template <int D>
struct ledger_step {
  index_t splits = 0;                      ///< split events
  index_t merges = 0;                      ///< merge events
  double dV = 0.0;                         ///< Σ of the events' ΔΣV
  vec<D> dVu = vec<D>::Zero();             ///< Σ of the events' ΔΣVu
  double dKE = 0.0;                        ///< Σ of the events' kinetic-energy change (reported)
  angular_t<D> dL = angular_t<D>::Zero();  ///< Σ of the events' angular-momentum change (reported)
  double max_volume_ulps = 0.0;            ///< largest per-event |ΔΣV| / (ε ΣV)
  double max_momentum_ulps = 0.0;          ///< largest per-event |ΔΣVu| / (ε ΣV|u|)
  std::vector<flux_entry<D>> fluxes;       ///< boundary fluxes added this step
  /// Total volume entering through boundaries.
  double flux_volume() const {
    double s = 0.0;
    for (const auto& f : fluxes) s += f.volume;
    return s;
  }
};

/// Per-event checks and per-step reports of split/merge (and boundary) changes; see the file comment.
template <int D>
requires Dimension<D>
class conservation_ledger {
 public:
  /// Takes the tolerances and density (validated).
  explicit conservation_ledger(const ledger_params& p = {}) : p_(p) { p_.validate(); }

  const ledger_params& params() const { return p_; }  ///< tolerances and density

  /// Checks one event (before → after particles) and adds it to the current step; throws mpskit::error
  /// naming the event (`what` and the ids) when volume or momentum moved by more than the tolerance.
  event_balance<D> record(std::string_view what, std::span<const particle_id> ids,
                          std::span<const particle_view<D>> before, std::span<const particle_view<D>> after) {
    event_balance<D> b = measure(before, after);
    const double eps = event_balance<D>::eps();
    const bool bad_v = !(std::abs(b.dV) <= p_.volume_ulp * eps * b.scale_V);
    const bool bad_u = !(b.dVu.norm() <= p_.momentum_ulp * eps * b.scale_Vu);
    if (bad_v || bad_u) {
      std::string who;
      for (particle_id id : ids) who += (who.empty() ? "" : ", ") + std::to_string(id);
      std::string at;
      if (!before.empty())
        for (int a = 0; a < D; ++a) at += mpskit::detail::concat(a ? ", " : "", before[0].x[a]);
      fail("conservation_ledger: ", what, " of particle id(s) ", who, " at x = (", at, ") changed ",
           bad_v ? "ΣV" : "ΣVu", " by ", bad_v ? b.volume_ulps() : b.momentum_ulps(), " ulp (accepted ",
           bad_v ? p_.volume_ulp : p_.momentum_ulp, ")");
    }
    step_.dV += b.dV;
    step_.dVu += b.dVu;
    step_.dKE += b.dKE;
    step_.dL += b.dL;
    step_.max_volume_ulps = std::max(step_.max_volume_ulps, b.volume_ulps());
    step_.max_momentum_ulps = std::max(step_.max_momentum_ulps, b.momentum_ulps());
    return b;
  }
  /// Counts a split (after record()).
  void count_split() { ++step_.splits; }
  /// Counts a merge (after record()).
  void count_merge() { ++step_.merges; }

  /// The hook for boundary code: volume/momentum (and particles) entering through `boundary` this step
  /// (negative: leaving). Entries with the same name are summed.
  void add_flux(std::string_view boundary, double volume, const vec<D>& momentum, index_t particles = 0) {
    if (!std::isfinite(volume) || !momentum.allFinite())
      fail("conservation_ledger: flux through '", boundary, "' is not finite (volume ", volume, ")");
    for (auto& f : step_.fluxes)
      if (f.name == boundary) {
        f.volume += volume;
        f.momentum += momentum;
        f.particles += particles;
        return;
      }
    step_.fluxes.push_back({std::string(boundary), volume, momentum, particles});
  }

  /// The step so far.
  const ledger_step<D>& current() const { return step_; }
  /// Closes the step: returns it, adds it to the totals, starts an empty one.
  ledger_step<D> close_step() {
    ledger_step<D> s = std::move(step_);
    step_ = {};
    total_.splits += s.splits;
    total_.merges += s.merges;
    total_.dV += s.dV;
    total_.dVu += s.dVu;
    total_.dKE += s.dKE;
    total_.dL += s.dL;
    total_.max_volume_ulps = std::max(total_.max_volume_ulps, s.max_volume_ulps);
    total_.max_momentum_ulps = std::max(total_.max_momentum_ulps, s.max_momentum_ulps);
    for (const auto& f : s.fluxes) {
      bool found = false;
      for (auto& t : total_.fluxes)
        if (t.name == f.name) {
          t.volume += f.volume;
          t.momentum += f.momentum;
          t.particles += f.particles;
          found = true;
        }
      if (!found) total_.fluxes.push_back(f);
    }
    ++steps_;
    return s;
  }
  /// Everything closed so far.
  const ledger_step<D>& totals() const { return total_; }
  /// Steps closed.
  long steps() const { return steps_; }
  /// Sets the totals and the step count (a checkpoint restart); the open step is emptied. Refuses
  /// (mpskit::error) negative counts, non-finite sums and two fluxes of one name; on error the ledger is
  /// unchanged.
  void restore(const ledger_step<D>& totals, long steps) {
    if (steps < 0 || totals.splits < 0 || totals.merges < 0)
      fail("conservation_ledger::restore: negative count (steps ", steps, ", splits ", totals.splits,
           ", merges ", totals.merges, ")");
    if (!std::isfinite(totals.dV) || !totals.dVu.allFinite() || !std::isfinite(totals.dKE) ||
        !totals.dL.allFinite() || !(totals.max_volume_ulps >= 0.0) || !(totals.max_momentum_ulps >= 0.0))
      fail("conservation_ledger::restore: the totals are not finite (or a largest ulp count is negative)");
    for (std::size_t a = 0; a < totals.fluxes.size(); ++a) {
      const auto& f = totals.fluxes[a];
      if (!std::isfinite(f.volume) || !f.momentum.allFinite())
        fail("conservation_ledger::restore: flux '", f.name, "' is not finite");
      for (std::size_t b = 0; b < a; ++b)
        if (totals.fluxes[b].name == f.name)
          fail("conservation_ledger::restore: flux '", f.name, "' appears twice");
    }
    total_ = totals;
    steps_ = steps;
    step_ = {};
  }

  /// The exact changes of one event (no check, nothing recorded).
  event_balance<D> measure(std::span<const particle_view<D>> before,
                           std::span<const particle_view<D>> after) const {
    event_balance<D> b;
    detail::exact_sum v0, v1, s0, s1;
    std::array<detail::exact_sum, D> m0{}, m1{};
    // Angular momentum about the volume centroid of `before` (the change does not depend on the origin when
    // ΣVu is kept, and a local origin avoids cancellation far from 0).
    vec<D> x0 = vec<D>::Zero();
    double vb = 0.0;
    for (const auto& p : before) {
      x0 += p.V * p.x;
      vb += p.V;
    }
    if (vb > 0.0) x0 /= vb;
    double ke0 = 0.0, ke1 = 0.0;
    angular_t<D> L0 = angular_t<D>::Zero(), L1 = angular_t<D>::Zero();
    const auto add = [&](const particle_view<D>& p, detail::exact_sum& v, detail::exact_sum& s,
                         std::array<detail::exact_sum, D>& m, double& ke, angular_t<D>& L) {
      v.add(p.V);
      s.add_product(p.V, p.u.norm());
      for (int a = 0; a < D; ++a) m[static_cast<std::size_t>(a)].add_product(p.V, p.u[a]);
      ke += 0.5 * p_.rho * p.V * p.u.squaredNorm();
      L += p_.rho * p.V * cross<D>(vec<D>(p.x - x0), p.u);
    };
    for (const auto& p : before) add(p, v0, s0, m0, ke0, L0);
    for (const auto& p : after) add(p, v1, s1, m1, ke1, L1);
    b.dV = v1.minus(v0);
    for (int a = 0; a < D; ++a)
      b.dVu[a] = m1[static_cast<std::size_t>(a)].minus(m0[static_cast<std::size_t>(a)]);
    b.scale_V = std::max(v0.value(), v1.value());
    b.scale_Vu = std::max(s0.value(), s1.value());
    b.dKE = ke1 - ke0;
    b.dL = L1 - L0;
    return b;
  }

 private:
  ledger_params p_;
  ledger_step<D> step_{}, total_{};
  long steps_ = 0;
};

}  // namespace mpskit::resolution
