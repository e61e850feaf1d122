#pragma once
/// \file surface/packing_ratio.hpp
/// \brief Packing ratio c_i of Tanaka, Cardoso & Bahai 2018 (seed 000 §4.1, eqs. 26, 32–40) and the
/// isolated-particle flag c_i < α_c (§4.6, first step). docs/surface.md, "Tanaka 2018 (LSMPS scenes)".
///
/// c_i is the least-squares fit of the particle volume ⟨N_i⟩_a inside A radii ⟨R_i⟩_a (eqs. 37–39) by
/// c_i V_R(⟨R_i⟩_a) (eq. 33). Minimising eq. 37 over c_i gives
///     c_i = Σ_a ⟨N_i⟩_a V_R(⟨R_i⟩_a) / Σ_a V_R(⟨R_i⟩_a)²,
/// which is what eq. 40 should read (the extraction prints Σ⟨N⟩⟨R⟩ / Σ π⟨R⟩, which has units m^(D−1)
/// and gives c ≈ R/2 on a full lattice; the least-squares form gives c ≈ 1 there).
///
/// Neighbours the list must hold: j contributes to ⟨N_i⟩_a when r_ij − L_j/2 ≤ ⟨R_i⟩_a (eqs. 35–36),
/// and the largest radius is ⟨R_i⟩_{A−1} = R_i − L_i/2 (eq. 39), so j is needed when
///     r_ij < (R_e − 1/2) L_i + L_j/2        (a pair exactly at equality contributes 0).
/// This is read from the list with the `max` rule at ratio R_e: max(R_e L_i, R_e L_j) ≥ (R_e − 1/2) L_i
/// + L_j/2 for every L_i, L_j when R_e ≥ 1/2, so a list built (it always stores the `max` rule) with
/// per_particle_radius{&L, r} and r ≥ R_e covers it, multi-resolution included. At single resolution
/// the needed radius equals the pair-mean radius R_e L exactly (so the caller's 3.1 L list is just
/// enough); the extra pairs of the `max` read have r ≥ needed radius and contribute exactly 0.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::surface {

/// Largest number of radii A accepted by packing_ratio_params (a stack buffer per particle).
inline constexpr int packing_ratio_max_radii = 64;

/// Numbers of the packing ratio (Tanaka 2018 §4.1 and parameter table).
struct packing_ratio_params {
  /// A, the number of radii of eq. 39. The paper gives no value; mpskit's default 8 (docs/surface.md):
  /// radii L/2, L/2 + 0.3 L, …, 2.6 L at R_e = 3.1. Accepted: 2 … 64.
  int radii = 8;
  double re_ratio = 3.1;  ///< R_e of eq. 27 (R_i = R_e L_i); accepted: finite, > 1
  double alpha_c = 0.3;   ///< α_c: isolated when c_i < α_c (§4.6, parameter table); accepted: [0, 1]
  /// Throws mpskit::error listing every bad value with its accepted range.
  void validate() const {
    validator v("packing_ratio_params");
    v.require(radii >= 2 && radii <= packing_ratio_max_radii, "radii",
              mpskit::detail::concat("is ", radii, "; must be an integer in [2, ", packing_ratio_max_radii,
                                     "] (eq. 39 divides by A − 1)"));
    v.require(std::isfinite(re_ratio) && re_ratio > 1.0, "re_ratio",
              mpskit::detail::concat("is ", re_ratio,
                                     "; must be a finite number > 1 (eq. 39 needs R_i > L_i)"));
    v.in_range("alpha_c", alpha_c, 0.0, 1.0);
    v.throw_if_any();
  }
};

/// V_R(R) of eq. 33: π R² (2D), 4/3 π R³ (3D).
template <int D>
  requires Dimension<D>
constexpr double sphere_volume(double R) noexcept {
  if constexpr (D == 2)
    return std::numbers::pi * R * R;
  else
    return 4.0 / 3.0 * std::numbers::pi * R * R * R;
}

/// W_ij(R) of eq. 35 (fluid: capped at V_j) or W*_ij(R) of eq. 36 (wall: no cap), for a neighbour of
/// diameter Lj and volume Vj = Lj^D (eq. 26) at distance r.
inline double volume_function(double R, double r, double Lj, double Vj, bool wall) noexcept {
  const double lo = r - 0.5 * Lj;
  if (R < lo) return 0.0;
  if (!wall && R > r + 0.5 * Lj) return Vj;
  return (R - lo) / Lj * Vj;
}

/// c_i (eqs. 32–40, least-squares form above) of particle i. `participates(j)` selects the neighbours
/// j ≠ i that count; i itself always counts (⟨N_i⟩ includes it, with W* when is_wall(i)); `is_wall(j)`
/// selects eq. 36 over eq. 35. p must be valid (not re-checked here).
template <int D, class Participates, class IsWall>
  requires Dimension<D>
double packing_ratio_of(const points<D>& x, const Eigen::VectorXd& L, const search::neighbour_list<D>& nl,
                        const Participates& participates, const IsWall& is_wall,
                        const packing_ratio_params& p, index_t i) {
  const int A = p.radii;
  const double Li = L[i];
  const double Ri = p.re_ratio * Li;  // eq. 27
  const double R0 = 0.5 * Li, h = (Ri - Li) / (A - 1);  // eq. 39: ⟨R_i⟩_a = R0 + a h
  // Each neighbour adds a ramp (R_a − lo) V_j / L_j on the radii a ∈ [a0, a1) and its full volume V_j on
  // a ≥ a1 (eq. 35; eq. 36 has no cap, a1 = A). Both are written into difference arrays of the slope
  // (coefficient of R_a) and the constant, and summed once: O(1) per neighbour instead of O(A). Only the
  // radii at the ends of a ramp can fall on the other side by rounding, where the two branches agree.
  std::array<double, packing_ratio_max_radii + 1> dS{}, dC{};
  const auto first_at_least = [&](double v) {  // smallest a with R_a ≥ v, in [0, A]
    if (v <= R0) return 0;
    const double t = std::ceil((v - R0) / h);
    return t >= A ? A : static_cast<int>(t);
  };
  const auto first_above = [&](double v) {  // smallest a with R_a > v, in [0, A]
    if (v < R0) return 0;
    const double t = std::floor((v - R0) / h) + 1.0;
    return t >= A ? A : static_cast<int>(t);
  };
  const auto add = [&](double r, double Lj, bool wall) {
    double Vj = Lj;
    for (int k = 1; k < D; ++k) Vj *= Lj;  // eq. 26
    const double lo = r - 0.5 * Lj;
    const int a0 = first_at_least(lo);
    const int a1 = wall ? A : std::max(a0, first_above(r + 0.5 * Lj));
    const double k = Vj / Lj;
    dS[static_cast<std::size_t>(a0)] += k;
    dS[static_cast<std::size_t>(a1)] -= k;
    dC[static_cast<std::size_t>(a0)] -= k * lo;
    dC[static_cast<std::size_t>(a1)] += k * lo;
    if (!wall) dC[static_cast<std::size_t>(a1)] += Vj;  // the cap V_j of eq. 35 beyond r + L_j/2
  };
  add(0.0, Li, static_cast<bool>(is_wall(i)));  // particle i itself (eq. 34 sums over j ∈ F ∪ W, i included)
  // The `max` read: a superset of every contributing pair (file comment).
  const search::support<search::per_particle_radius> s{{&L, p.re_ratio}, search::radius_rule::max};
  nl.for_each_neighbour(x, i, s, [&](index_t j, const vec<D>&, double r2) {
    if (!participates(j)) return;
    add(std::sqrt(r2), L[j], static_cast<bool>(is_wall(j)));
  });
  std::array<double, packing_ratio_max_radii> Ra{}, Na{};
  double slope = 0.0, constant = 0.0;
  for (int a = 0; a < A; ++a) {
    const std::size_t u = static_cast<std::size_t>(a);
    Ra[u] = R0 + a * h;
    slope += dS[u];
    constant += dC[u];
    Na[u] = slope * Ra[u] + constant;  // ⟨N_i⟩_a of eq. 38
  }
  // Least squares of eq. 37: dE/dc = 0 ⇒ c = Σ N_a V_a / Σ V_a² (the corrected eq. 40).
  double num = 0.0, den = 0.0;
  for (int a = 0; a < A; ++a) {
    const double V = sphere_volume<D>(Ra[static_cast<std::size_t>(a)]);
    num += Na[static_cast<std::size_t>(a)] * V;
    den += V * V;
  }
  return num / den;
}

/// c_i for every column of x (real and ghost: imaginary copies need c too), written to c (resized to
/// x.cols()). L holds one diameter per column (copies: eq. 76); the list must have been built over the
/// same columns at ratio ≥ p.re_ratio (see the file comment). Throws mpskit::error on bad p, sizes or a
/// non-positive / non-finite diameter (naming the particle).
template <int D, Execution E, class Participates, class IsWall>
  requires Dimension<D>
void packing_ratio(E e, const points<D>& x, const Eigen::VectorXd& L, const search::neighbour_list<D>& nl,
                   const Participates& participates, const IsWall& is_wall, const packing_ratio_params& p,
                   Eigen::VectorXd& c) {
  p.validate();
  const index_t n = x.cols();
  if (L.size() != n) fail("packing_ratio: L has ", L.size(), " entries for ", n, " particles");
  if (nl.rows() != n)
    fail("packing_ratio: the neighbour list has ", nl.rows(), " rows for ", n, " particles (rebuild it)");
  check_diameters("packing_ratio", L, n);
  c.resize(n);
  for_each_particle(e, n,
                    [&](index_t i) { c[i] = packing_ratio_of<D>(x, L, nl, participates, is_wall, p, i); });
}

/// Tanaka 2018 §4.6, first step: sets flag::isolated on entry i where c_i < alpha_c and clears it where
/// c_i ≥ alpha_c (so a particle rejoins when its c recovers), for i < c.size(); other bits and entries
/// beyond c.size() are untouched (pass c.head(n_real) to flag real particles only). Returns the number
/// flagged. Throws mpskit::error when alpha_c is outside [0, 1], flags is shorter than c, or a c_i is NaN.
inline index_t isolated_flags(Eigen::Ref<const Eigen::VectorXd> c, double alpha_c,
                              std::vector<flag::type>& flags) {
  if (!(alpha_c >= 0.0 && alpha_c <= 1.0)) fail("isolated_flags: alpha_c = ", alpha_c, ": must be in [0, 1]");
  if (static_cast<index_t>(flags.size()) < c.size())
    fail("isolated_flags: flags has ", flags.size(), " entries for ", c.size(), " packing ratios");
  index_t count = 0;
  for (index_t i = 0; i < c.size(); ++i) {
    if (std::isnan(c[i])) fail("isolated_flags: packing ratio of particle ", i, " is NaN");
    flag::type& f = flags[static_cast<std::size_t>(i)];
    if (c[i] < alpha_c) {
      f |= flag::isolated;
      ++count;
    } else {
      f &= ~flag::isolated;
    }
  }
  return count;
}

}  // namespace mpskit::surface
