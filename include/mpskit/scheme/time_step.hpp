#pragma once
/// \file scheme/time_step.hpp
/// \brief Δt = min(α_C min L / max |u|, α_ν min L²/ν, Δt_max) (Tanaka 2018 eq. 64, whose min_i α_C L_i/|u_i|
/// is the option time_step_params::per_particle_courant — the extraction writes α_c, the Courant coefficient
/// is α_C = 0.1 — plus a viscous limit, ARCHITECTURE.md §4), changed piecewise-constantly on a ladder Δt_max
/// / r^k (r = 2 by default: halved at once when the limit requires, doubled only with hysteresis) so the PPE
/// source sees a steady Δt; or a fixed Δt that is refused when above the limit. The ladder is ours (Tanaka
/// asks for a constant Δt in the source and gives no rule for changing it); with r = 2 a flow limited by its
/// Courant number runs at between 0.5 and 1 of its limit, with a finer r (e.g. 2^(1/4)) at between 1/r and 1
/// of it, for more frequent but smaller changes (docs/solver.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/core/params.hpp"

namespace mpskit::scheme {

/// Adaptive (piecewise constant) or fixed Δt.
enum class time_step_mode { adaptive, fixed };

/// Numbers of the Δt controller.
struct time_step_params {
  time_step_mode mode = time_step_mode::adaptive;  ///< adaptive or fixed
  double dt_max = 1e-3;                            ///< largest Δt (s); the adaptive Δt is dt_max / ratio^k
  double ratio = 2.0;  ///< r of the ladder Δt_max / r^k, in [1.001, 2] (above 1 so the rungs stay countable);
                       ///< 2 keeps Δt_max / 2^k exactly
  double dt_fixed = 0.0;  ///< Δt in fixed mode (s)
  double courant = 0.1;   ///< α_C (Tanaka 2018 Table 2: 0.1)
  /// Schemes with per-particle diameters (LSMPS): true, Tanaka eq. 64 as written, Δt ≤ min_i α_C L_i/|u_i|;
  /// false (default, a deviation), the stricter α_C min_i L_i / max_i |u_i|. With one diameter the two agree.
  /// Not the default: on the 2:1 dam break with the obstacle (5 mm / 2.5 mm, 4 mm / 2 mm, three refined
  /// zones) eq. 64 let coarse particles run into the block's refined zone at their own Courant number and
  /// ended with more steps (2849 vs 1709, 3256 vs 2245) and splashes (13.5 vs 2.9 m/s, 22 guard activations
  /// vs 0); docs/solver.md.
  bool per_particle_courant = false;
  double viscous = 0.1;      ///< α_ν in Δt ≤ α_ν L²/ν (our choice; the papers give none)
  double hysteresis = 1.5;   ///< Δt grows one rung only when r Δt ≤ limit / hysteresis
  int hold_steps = 10;       ///< and only after this many steps at the current Δt
  int max_halvings = 30;     ///< Δt below dt_max / 2^30 is a collapsed time step (error), whatever the ratio
  /// Blow-up bound (m/s; ours, no paper has one): a step that starts with a fluid particle faster than this
  /// throws (naming step, particle and speed). Default ∞, no bound. Without it a run that has blown up steps
  /// on at Δt ~ 1e-9 s for many minutes before the ladder collapses (Δt = α_C L / |u| tracks the runaway
  /// speed); the Tanaka dam-break runner sets 50 √(g H) (docs/solver.md, "Blow-up bound").
  double max_speed = std::numeric_limits<double>::infinity();
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("time_step_params");
    v.positive("dt_max", dt_max).in_open_range("courant", courant, 0.0, 1.0).positive("viscous", viscous);
    v.in_range("ratio", ratio, 1.0 + 1e-3, 2.0);
    v.in_range("hysteresis", hysteresis, 1.0, 100.0).in_range("hold_steps", hold_steps, 0, 1e6);
    v.in_range("max_halvings", max_halvings, 1, 60);
    v.require(max_speed > 0.0, "max_speed",
              mpskit::detail::concat("is ", max_speed, ", must be > 0 (infinity: no bound)"));
    if (mode == time_step_mode::fixed) v.positive("dt_fixed", dt_fixed);
    v.throw_if_any();
  }
};

/// The controller's state (part of a checkpoint).
struct time_step_state {
  int halvings = 0;        ///< k in Δt = dt_max / r^k (rungs down the ladder; halvings when r = 2)
  long held = 0;           ///< steps since the last change
  long changes = 0;        ///< number of changes so far
};

/// The state as a checkpoint section holds it: {halvings, held, changes}.
inline std::vector<std::int64_t> section_values(const time_step_state& s) {
  return {s.halvings, s.held, s.changes};
}
/// The state from a section's three values (the caller checks the count and the range).
inline time_step_state time_step_state_from(const std::vector<std::int64_t>& v) {
  time_step_state s;
  s.halvings = static_cast<int>(v.at(0));
  s.held = v.at(1);
  s.changes = v.at(2);
  return s;
}

/// Piecewise-constant Δt controller.
class time_step_controller {
 public:
  explicit time_step_controller(const time_step_params& p) : p_(p) {
    p_.validate();
    // The rung below which Δt < dt_max / 2^max_halvings: the collapse test is the same Δt for every ratio.
    max_rungs_ = p_.ratio == 2.0
                     ? p_.max_halvings
                     : static_cast<int>(std::ceil(p_.max_halvings * std::log(2.0) / std::log(p_.ratio)));
  }

  /// The limit min(α_C L/u_max, α_ν L²/ν, Δt_max) for spacing L, fastest speed u_max, viscosity ν.
  double limit(double L, double u_max, double nu) const { return limit(L, u_max, L, nu); }
  /// The limit min(α_C L_c/u_c, α_ν L_ν²/ν, Δt_max) with the Courant pair (L_c, u_c) and the viscous spacing
  /// L_ν given apart: per particle (eq. 64 as written), (L_c, u_c) is the particle of least L_i/|u_i| and L_ν
  /// the smallest diameter; with one spacing all three are that spacing and the fastest speed.
  double limit(double L_courant, double u_courant, double L_viscous, double nu) const {
    double lim = p_.dt_max;
    if (u_courant > 0.0) lim = std::min(lim, p_.courant * L_courant / u_courant);
    if (nu > 0.0) lim = std::min(lim, p_.viscous * L_viscous * L_viscous / nu);
    return lim;
  }

  /// Δt for the next step. Fixed mode: throws (naming step and the fastest particle) when above the
  /// limit. Adaptive: steps down the ladder as often as needed, up one rung with hysteresis; throws when
  /// collapsed.
  double next(double L, double u_max, double nu, long step, long fastest_particle) {
    return next(L, u_max, L, nu, step, fastest_particle);
  }
  /// The same with the Courant pair (L_c, u_c) of the limiting particle and the viscous spacing L_ν apart
  /// (see limit()); `particle` is the limiting particle's id, named in errors.
  double next(double L_courant, double u_courant, double L_viscous, double nu, long step, long particle) {
    const double lim = limit(L_courant, u_courant, L_viscous, nu);
    if (p_.mode == time_step_mode::fixed) {
      if (p_.dt_fixed > lim)
        fail("time step: fixed dt = ", p_.dt_fixed, " s exceeds the limit ", lim, " s at step ", step,
             " (limiting particle ", particle, ", |u| = ", u_courant, " m/s, L = ", L_courant, " m; Courant ",
             p_.courant, ", viscous ", p_.viscous, ")");
      return p_.dt_fixed;
    }
    const int before = s_.halvings;
    while (dt() > lim) {
      if (++s_.halvings > max_rungs_)
        fail("time step collapsed at step ", step, ": limit ", lim, " s below dt_max / 2^", p_.max_halvings,
             " (limiting particle ", particle, ", |u| = ", u_courant, " m/s, L = ", L_courant, " m)");
    }
    if (s_.halvings == before && s_.halvings > 0 && s_.held >= p_.hold_steps &&
        p_.ratio * dt() * p_.hysteresis <= lim)
      --s_.halvings;
    if (s_.halvings != before) {
      s_.held = 0;
      ++s_.changes;
    } else {
      ++s_.held;
    }
    return dt();
  }

  /// Throws when the fastest speed `u_max` (of particle id `particle`, at step `step`) exceeds max_speed.
  void check_speed(double u_max, long step, long particle) const {
    if (u_max > p_.max_speed)
      fail("blow-up at step ", step, ": particle ", particle, " moves at |u| = ", u_max,
           " m/s, above max_speed = ", p_.max_speed, " m/s (time_step_params::max_speed)");
  }

  /// Current Δt (r = 2: exactly dt_max / 2^k, as before the ratio existed).
  double dt() const {
    if (p_.mode == time_step_mode::fixed) return p_.dt_fixed;
    return p_.ratio == 2.0 ? std::ldexp(p_.dt_max, -s_.halvings)
                           : p_.dt_max * std::pow(p_.ratio, -s_.halvings);
  }
  /// The deepest rung k before the collapse (max_halvings when r = 2); a checkpoint's k is valid in [0,
  /// max_rungs()].
  int max_rungs() const { return max_rungs_; }
  const time_step_state& state() const { return s_; }   ///< for checkpoints
  void restore(const time_step_state& s) { s_ = s; }    ///< from a checkpoint
  const time_step_params& params() const { return p_; } ///< the numbers

 private:
  time_step_params p_;
  int max_rungs_ = 0;
  time_step_state s_{};
};

/// The steppers' run_until: steps `stepper` until stepper.time() >= t_end (the last step is not shortened; a
/// slack of 1e-12 max(1, |t_end|) keeps a t_end reached up to rounding from taking one step more), calling
/// observer(stepper) after each step.
template <class Stepper, class Observer>
void step_until(Stepper& stepper, double t_end, Observer&& observer) {
  while (stepper.time() < t_end - 1e-12 * std::max(1.0, std::abs(t_end))) {
    stepper.step();
    observer(stepper);
  }
}

}  // namespace mpskit::scheme
