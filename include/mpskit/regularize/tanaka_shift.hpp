#pragma once
/// \file regularize/tanaka_shift.hpp
/// \brief Multi-resolution particle shifting of Tanaka, Cardoso & Bahai (2018), §4.7 eqs. (93)–(100)
/// (seed 000): a centre-of-mass displacement towards target distances (eqs. 93–95), a penalty
/// displacement down the packing-ratio gradient for overlapping pairs (eqs. 96–97), their sum (eq. 98),
/// the normal component removed at surface and near-wall particles (eq. 99, after Khayyer et al. 2017)
/// and the length limited to α_S L_i (eq. 100). Velocities follow δu = (∇u) δx (eq. 91):
/// `apply_tanaka_shift` does it with the caller's velocity gradient.
///
/// Readings and deviations (docs/regularize.md, "Tanaka shifting"):
/// - Eq. (96) as extracted is dimensionless (w and ε of eq. 97 are pure numbers). mpskit multiplies
///   each pair term by L_ij, i.e. the penalty depth is the length (1 − α_p) L_ij − r_ij.
/// - Coincident pairs (r_ij = 0) have no direction x_ji/|x_ji| in eq. (94): they are left out of both
///   sums of eq. (94) and counted; they still enter the penalty of eq. (96), whose direction is ∇c.
/// - With eq. (95) as printed, r*_ij > r_ij for every r_ij < R_ij, so every neighbour inside the
///   support pushes i away (by w_ij (r*_ij − r_ij)); nothing pulls. On a uniform lattice the pushes
///   cancel; a particle closer to one side is pushed back to the middle.
/// - The table's α_s = 2.5e-4 ("distance ratio in particle shifting") appears in no equation of §4.7
///   and is not a parameter here.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::regularize {

/// Direction of the penalty displacement δx** (eq. 96).
enum class penalty_direction : std::uint8_t {
  concentration_gradient,  ///< −⟨∇c⟩/|⟨∇c⟩| for every overlapping pair, as eq. 96 is printed
  pair                     ///< −x_ij/r_ij per overlapping pair: pushes i away from each overlapping j (a
                           ///< deviation, docs/regularize.md: the printed direction does not separate a
                           ///< pair and let the Taylor–Green vortex collapse at its saddles)
};

/// Which part of δx eq. 99 projects for particles on the free surface or beside a wall.
enum class penalty_projection : std::uint8_t {
  with_displacement,  ///< (I − n⊗n) applied to δx = δx* + δx** (eq. 99 as printed)
  wall_only  ///< eq. 99 on δx* and on the penalty from wall copies as printed; the fluid pairs' overlap
             ///< penalty (penalty_direction::pair only) loses just its component into a wall, and a
             ///< copy closer than (1 − α_p) L_i/2 (the wall overlaps i) pushes i off the wall
             ///< (a deviation, docs/regularize.md: at a contact line the surface and wall normals
             ///< together remove every direction in 2D, two particles there closed to 0.34 L and
             ///< broke Tanaka's dam break at T ≈ 1.44)
};

/// Numbers of Tanaka's shifting (Tanaka 2018, parameter table of §2).
struct tanaka_shift_params {
  double alpha_g = 0.001;  ///< α_g: δx* = 0 when |g_i − x_i| ≤ α_g L_i (eq. 93); accepted [0, inf)
  double alpha_T = 0.8;    ///< α_T: target distance r* = L_ij below α_T L_ij (eq. 95); accepted [0, re_ratio)
  double alpha_p = 0.1;    ///< α_p: penalty below (1 − α_p) L_ij (eq. 97); accepted [0, 1)
  double alpha_S = 0.01;   ///< α_S: |δx_i| ≤ α_S L_i (eq. 100); accepted (0, inf)
  double re_ratio = 3.1;   ///< R_i = re_ratio L_i, R_ij = (R_i + R_j)/2 (eqs. 27–28); accepted (1, inf)
  penalty_direction penalty = penalty_direction::concentration_gradient;  ///< eq. 96 as printed, or per pair
  penalty_projection projection = penalty_projection::with_displacement;  ///< eq. 99 as printed, or wall only
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("tanaka_shift_params");
    v.non_negative("alpha_g", alpha_g).non_negative("alpha_T", alpha_T).positive("alpha_S", alpha_S);
    if (!(alpha_p >= 0.0 && alpha_p < 1.0))
      v.require(false, "alpha_p", mpskit::detail::concat("is ", alpha_p, ", must be in [0, 1)"));
    if (!(std::isfinite(re_ratio) && re_ratio > 1.0))
      v.require(false, "re_ratio",
                mpskit::detail::concat("is ", re_ratio, ", must be a finite number > 1 (R_ij > L_ij)"));
    else if (std::isfinite(alpha_T) && !(alpha_T < re_ratio))
      v.require(false, "alpha_T",
                mpskit::detail::concat("is ", alpha_T, ", must be < re_ratio = ", re_ratio,
                                       " (eq. 95 divides by R_ij - alpha_T L_ij)"));
    v.throw_if_any();
  }
};

/// The scene policy naming this shifting (`using shifting = mpskit::regularize::tanaka_shift;`), run by
/// scheme::lsmps_semi_implicit; the numbers are in tanaka_shift_params.
struct tanaka_shift final {
  using params_type = tanaka_shift_params;
};

/// What one evaluation did.
struct tanaka_shift_report {
  index_t active = 0;            ///< particles computed (active[i] = 1)
  index_t moved = 0;             ///< active particles with δx ≠ 0
  index_t limited = 0;           ///< displacements scaled down to α_S L_i (eq. 100)
  index_t projected = 0;         ///< tangential_only particles projected with a non-zero normal (eq. 99)
  index_t unprojected = 0;       ///< tangential_only particles with n = 0: left unprojected (I − 0⊗0 = I)
  index_t coincident_pairs = 0;  ///< directed pairs at r = 0 left out of eq. (94)
  double max_shift_over_L = 0.0; ///< max_i |δx_i| / L_i after the limit
};

namespace detail {
/// Target distance r*_ij, Tanaka 2018 eq. (95): L_ij up to α_T L_ij, then linear to R_ij at R_ij.
inline double target_distance(double r, double Lij, double Rij, double alpha_T) noexcept {
  const double rT = alpha_T * Lij;
  if (r <= rT) return Lij;
  return (Rij - Lij) / (Rij - alpha_T * Lij) * (r - rT) + Lij;
}
}  // namespace detail

/// Shifting displacement δx (D × m, m = active.size()) of Tanaka 2018 eqs. (93)–(100), nothing moved.
///
/// - x: positions of every list row (real particles, then ghosts such as imaginary wall copies);
///   L: their diameters (x.cols() entries, finite and > 0); nl: built over x with
///   `per_particle_radius{&L, r}` for some r ≥ re_ratio (any skin); pairs are read with the support
///   {per_particle_radius{&L, re_ratio}, pair_mean}, i.e. r_ij < R_ij (eqs. 28–29).
/// - participates(j): j counts as a neighbour (non-isolated fluid or wall copy).
/// - Rows i < m with active[i] = 1 are computed (non-isolated real fluid); others get δx = 0.
///   grad_c (⟨∇c⟩_i), n (outward unit normal or 0) and tangential_only (eq. 99) must cover ≥ m rows.
/// - n_wall (optional, ≥ m columns, unit or 0): a second normal for tangential_only particles near a
///   wall (the wall normal of their imaginary copy); eq. 99 then removes the components along n and
///   n_wall, so a surface particle at a wall, or a particle in a concave corner, does not slide off it.
/// - n_wall2 (optional, ≥ m columns, unit or 0): the normal of a second wall the particle is copied onto (a
///   3D edge or corner, a 2D corner); eq. 99 removes its component too (ours: Tanaka's eq. 99 has one
///   normal).
/// - penalty_only (optional, x.cols() entries, set only below active.size(): real particles): rows j with
///   penalty_only[j] ≠ 0 that do not participate enter eq. 96's per-pair overlap penalty only (not eq. 94,
///   not the weight sum), so an isolated particle pushes i away when r_ij < (1 − α_p) L_ij (after
///   eqs. 99–100, like every pair term) and never draws it (ours, opt-in through
///   lsmps_params::shift_isolated_penalty). Needs penalty_direction::pair: the printed direction −⟨∇c⟩
///   ignores where j is, and near the surface it points at the spray.
/// Returns the counters; dx is resized to D × m.
template <int D, Execution E, class Participates>
  requires std::predicate<const Participates&, index_t>
tanaka_shift_report tanaka_shift_displacement(E e, const points<D>& x, const Eigen::VectorXd& L,
                                              const search::neighbour_list<D>& nl,
                                              const Participates& participates, const points<D>& grad_c,
                                              const points<D>& n,
                                              const std::vector<std::uint8_t>& tangential_only,
                                              const std::vector<std::uint8_t>& active,
                                              const tanaka_shift_params& p, points<D>& dx,
                                              const points<D>* n_wall = nullptr,
                                              const points<D>* n_wall2 = nullptr,
                                              const std::vector<std::uint8_t>* penalty_only = nullptr) {
  p.validate();
  const index_t rows = x.cols();
  const index_t m = static_cast<index_t>(active.size());
  if (nl.rows() != rows)
    fail("tanaka_shift: the neighbour list has ", nl.rows(), " rows for ", rows, " positions");
  if (L.size() != rows) fail("tanaka_shift: L has ", L.size(), " entries for ", rows, " positions");
  if (m > rows)
    fail("tanaka_shift: active has ", m, " entries for ", rows, " positions (accepted: at most x.cols())");
  if (grad_c.cols() < m)
    fail("tanaka_shift: grad_c has ", grad_c.cols(), " columns, need >= active.size() = ", m);
  if (n.cols() < m) fail("tanaka_shift: n has ", n.cols(), " columns, need >= active.size() = ", m);
  if (n_wall && n_wall->cols() < m)
    fail("tanaka_shift: n_wall has ", n_wall->cols(), " columns, need >= active.size() = ", m);
  if (n_wall2 && !n_wall) fail("tanaka_shift: n_wall2 given without n_wall");
  if (n_wall2 && n_wall2->cols() < m)
    fail("tanaka_shift: n_wall2 has ", n_wall2->cols(), " columns, need >= active.size() = ", m);
  if (penalty_only) {
    if (static_cast<index_t>(penalty_only->size()) != rows)
      fail("tanaka_shift: penalty_only has ", penalty_only->size(), " entries for ", rows, " positions");
    if (p.penalty != penalty_direction::pair)
      fail(
          "tanaka_shift: penalty_only needs penalty_direction::pair (the printed direction -grad c does not "
          "push i away from j)");
    for (index_t j = m; j < rows; ++j)
      if ((*penalty_only)[static_cast<std::size_t>(j)])
        fail("tanaka_shift: penalty_only is set at row ", j, " >= active.size() = ", m,
             " (accepted: real particles only; rows beyond are ghosts, e.g. wall copies)");
  }
  if (static_cast<index_t>(tangential_only.size()) < m)
    fail("tanaka_shift: tangential_only has ", tangential_only.size(),
         " entries, need >= active.size() = ", m);
  check_diameters("tanaka_shift", L, rows);

  const search::support<search::per_particle_radius> sup{search::per_particle_radius{&L, p.re_ratio},
                                                         search::radius_rule::pair_mean};
  dx.setZero(D, m);
  // Per-particle outcome codes, summed afterwards in fixed blocks (thread-count independent).
  std::vector<std::uint8_t> moved(static_cast<std::size_t>(m), 0), limited(static_cast<std::size_t>(m), 0),
      projected(static_cast<std::size_t>(m), 0), unprojected(static_cast<std::size_t>(m), 0);
  std::vector<index_t> coincident(static_cast<std::size_t>(m), 0);

  for_each_particle(e, m, [&](index_t i) {
    const std::size_t k = static_cast<std::size_t>(i);
    if (!active[k]) return;
    const double Li = L[i];
    vec<D> sum_g = vec<D>::Zero();  // Σ_j w_ij (x_j + r*_ij x_ji/|x_ji| − x_i)   (eq. 94 minus x_i Σ w)
    double sum_w = 0.0;             // Σ_j w_ij                                   (eq. 94)
    double penalty = 0.0;           // Σ_j w_ij ε_ij L_ij                         (eqs. 96–97, length form)
    vec<D> penalty_pair = vec<D>::Zero();  // −Σ_j w_ij ε_ij L_ij x_ij/r_ij      (penalty_direction::pair)
    vec<D> penalty_ghost = vec<D>::Zero();  // the part of penalty_pair from rows j ≥ m (imaginary copies)
    // wall_only: a copy closer than (1 − α_p) L_i/2 (the wall inside i). Every row j ≥ m counts as a wall
    // copy here; the LSMPS scheme's other ghosts, pressure-boundary particles, have no shifted particle
    // within 2 L_i (scheme/lsmps_semi_implicit.hpp), so they never reach this test.
    vec<D> penalty_wall = vec<D>::Zero();
    const double wall_edge =
        p.projection == penalty_projection::wall_only ? 0.5 * (1.0 - p.alpha_p) * Li : 0.0;
    index_t zero_pairs = 0;
    nl.for_each_neighbour(x, i, sup, [&](index_t j, const vec<D>& xij, double r2) {
      const bool full = participates(j);
      if (!full && !(penalty_only && (*penalty_only)[static_cast<std::size_t>(j)])) return;
      const double r = std::sqrt(r2);
      const double Lij = 0.5 * (Li + L[j]);   // averaged diameter (below eq. 94)
      const double Rij = p.re_ratio * Lij;    // R_ij = (R_i + R_j)/2 (eq. 28)
      const double w = kernel::quadratic::w(r, Rij);  // eq. 29
      const double pen_edge = (1.0 - p.alpha_p) * Lij;
      if (r < pen_edge) {
        penalty += w * (pen_edge - r);  // eq. 97 times L_ij (see file comment)
        if (r2 > 0.0) (j >= m ? penalty_ghost : penalty_pair) -= (w * (pen_edge - r) / r) * xij;
      }
      if (!full) return;  // penalty_only: out of eq. 94 and of the wall test
      if (j >= m && r < wall_edge && r2 > 0.0) penalty_wall -= (w * (wall_edge - r) / r) * xij;
      if (r2 == 0.0) {  // x_ji/|x_ji| undefined: out of eq. 94
        ++zero_pairs;
        return;
      }
      // Eq. 94: the target point of neighbour j is x_j + r*_ij x_ji/|x_ji| with x_ji = x_i − x_j = −x_ij,
      // i.e. x_j moved by r*_ij toward i. Its offset from x_i is x_ij − r* x_ij/r = x_ij (1 − r*/r).
      // Two particles alone at r = 0.5 L: r* = L (eq. 95, r ≤ α_T L), offset = −x_ij: i is sent to
      // distance L from j, away from j (pushed apart). At r = 2 L (R = 3.1 L): r* = 2.096 L > r, so
      // i is again pushed away, by w (r* − r) = 0.126 × 0.096 L: eq. 95 never pulls inside R_ij.
      const double rs = detail::target_distance(r, Lij, Rij, p.alpha_T);
      sum_g += (w * (1.0 - rs / r)) * xij;
      sum_w += w;
    });
    coincident[k] = zero_pairs;
    vec<D> d = vec<D>::Zero(), dp = vec<D>::Zero();  // δx* (eq. 93) and δx** (eq. 96)
    if (sum_w > 0.0) {
      const vec<D> gx = sum_g / sum_w;  // g_i − x_i (eq. 94)
      if (gx.norm() > p.alpha_g * Li) d = gx;  // eq. 93
    }
    const bool split = tangential_only[k] && p.projection == penalty_projection::wall_only;
    if (p.penalty == penalty_direction::pair) {
      dp = penalty_pair;  // eq. 96 read per pair (a deviation)
      // A copy sits L/2 from its parent, inside the penalty range: its push is always along the wall normal
      // and eq. 99 removes it; with wall_only it stays with δx* (projected as printed).
      if (split) {
        d += penalty_ghost;
        dp += penalty_wall;  // pushes i off a wall it overlaps (away from the wall: kept by the rule below)
      } else {
        dp += penalty_ghost;
      }
    } else {
      const vec<D> gc = grad_c.col(i);
      const double gnorm = gc.norm();
      // eq. 96: δx** = −Σ w ε ⟨∇c⟩/|⟨∇c⟩|
      if (gnorm > 0.0 && std::isfinite(gnorm) && penalty > 0.0) dp = -(penalty / gnorm) * gc;
    }
    if (!split) d += dp;  // eq. 98: δx = δx* + δx**, then eq. 99 below
    if (tangential_only[k]) {
      const vec<D> ni = n.col(i);
      bool any = false;
      if (ni.squaredNorm() > 0.0) {
        d -= ni.dot(d) * ni;  // eq. 99: (I − n⊗n) δx
        any = true;
      }
      if (n_wall) {
        // Further constraints (a surface particle next to a wall, a concave corner, a 3D edge): eq. 99
        // applied to the part of each wall normal orthogonal to the directions already removed
        // (Gram–Schmidt), so δx ⊥ n, δx ⊥ n_wall and δx ⊥ n_wall2.
        std::array<vec<D>, D> basis;  // orthonormal directions removed so far
        int nb = 0;
        if (any) basis[nb++] = ni;
        for (const points<D>* nw : {n_wall, n_wall2}) {
          if (!nw || nb == D) continue;  // D directions removed: δx = 0 already
          vec<D> t = nw->col(i);
          for (int b = 0; b < nb; ++b) t -= basis[b].dot(t) * basis[b];
          const double tn = t.norm();
          if (tn > 1e-8) {  // else 0 or in the span already: nothing more to remove
            t /= tn;
            d -= t.dot(d) * t;
            any = true;
            basis[nb++] = t;
          }
        }
      }
      (any ? projected[k] : unprojected[k]) = 1;
      if (split) {  // δx** keeps every direction but into a wall (each n_wall points into the fluid)
        for (const points<D>* nw : {n_wall, n_wall2}) {
          if (!nw || nw->col(i).squaredNorm() == 0.0) continue;
          const vec<D> w = nw->col(i);
          const double into = w.dot(dp);
          if (into < 0.0) dp -= into * w;
        }
        d += dp;
      }
    }
    const double len = d.norm(), cap = p.alpha_S * Li;
    if (len > cap) {  // eq. 100: scaled down, direction kept (stays tangential after eq. 99)
      d *= cap / len;
      limited[k] = 1;
    }
    moved[k] = (d.array() != 0.0).any() ? 1 : 0;
    dx.col(i) = d;
  });

  tanaka_shift_report rep;
  const auto count = [&](const std::vector<std::uint8_t>& v) {
    return reduce(e, m, index_t{0}, [&](index_t i) { return index_t{v[static_cast<std::size_t>(i)]}; },
                  [](index_t a, index_t b) { return a + b; });
  };
  rep.active = reduce(
      e, m, index_t{0}, [&](index_t i) { return index_t{active[static_cast<std::size_t>(i)] != 0}; },
      [](index_t a, index_t b) { return a + b; });
  rep.moved = count(moved);
  rep.limited = count(limited);
  rep.projected = count(projected);
  rep.unprojected = count(unprojected);
  rep.coincident_pairs = reduce(
      e, m, index_t{0}, [&](index_t i) { return coincident[static_cast<std::size_t>(i)]; },
      [](index_t a, index_t b) { return a + b; });
  rep.max_shift_over_L = reduce(
      e, m, 0.0, [&](index_t i) { return dx.col(i).norm() / L[i]; },
      [](double a, double b) { return std::max(a, b); });
  return rep;
}

/// Every neighbour counts (the default predicate of limit_to_neighbour_range).
struct all_neighbours {
  bool operator()(index_t) const { return true; }
};

/// Limits eq. 91's shifted velocity (ours, opt-in; docs/lsmps_scheme.md "The shifted velocity's limiter"):
/// each component of u_new is clipped to the range of that component over u_i and the velocities u_j of i's
/// neighbours (`neighbours`, a range of indices into u; a wall copy carries the wall velocity). For one
/// evaluation point this is Barth and Jespersen's limiter (the Taylor step scaled by φ ≤ 1 so that no new
/// extremum is made): eq. 91 extrapolates ∇u beyond the data where a particle is shifted away from the only
/// neighbours that define its gradient, e.g. a particle sliding on a floor beside its copy at the wall
/// velocity, whose δu = u δy / y then grows |u| by a fixed amount per step (Tanaka's dam break at 2 mm).
/// A field linear over the neighbourhood is left exact where x_i + δx_i stays inside the neighbours' bounding
/// range of values (the interior). Only the neighbours j with counted(j) enter (default: all). Returns true
/// when a component was clipped.
template <int D, class Neighbours, class Counted = all_neighbours>
bool limit_to_neighbour_range(vec<D>& u_new, const points<D>& u, index_t i, const Neighbours& neighbours,
                              const Counted& counted = {}) {
  vec<D> lo = u.col(i), hi = lo;
  for (const auto jj : neighbours) {
    const index_t j = static_cast<index_t>(jj);
    if (!counted(j)) continue;
    lo = lo.cwiseMin(vec<D>(u.col(j)));
    hi = hi.cwiseMax(vec<D>(u.col(j)));
  }
  const vec<D> clipped = u_new.cwiseMax(lo).cwiseMin(hi);
  const bool changed = (clipped.array() != u_new.array()).any();
  u_new = clipped;
  return changed;
}

/// Commits a shift: x_i += δx_i and u_i += (∇u)_i δx_i (Tanaka 2018 eq. 91, first-order Taylor) for
/// i < dx.cols(). grad_u(i) returns mat<D> with (∇u)_ab = ∂u_a/∂x_b, evaluated at the unshifted
/// positions (e.g. the caller's LSMPS type-A velocity gradient, computed before this call).
template <int D, Execution E, class GradU>
  requires std::convertible_to<std::invoke_result_t<const GradU&, index_t>, mat<D>>
void apply_tanaka_shift(E e, const points<D>& dx, const GradU& grad_u, points<D>& x, points<D>& u) {
  const index_t m = dx.cols();
  if (x.cols() < m || u.cols() < m)
    fail("apply_tanaka_shift: x has ", x.cols(), " and u has ", u.cols(),
         " columns, need >= dx.cols() = ", m);
  for_each_particle(e, m, [&](index_t i) {
    const vec<D> d = dx.col(i);
    if ((d.array() == 0.0).all()) return;  // unshifted particles keep x and u bitwise
    const mat<D> G = grad_u(i);
    u.col(i) += G * d;  // eq. 91
    x.col(i) += d;
  });
}

}  // namespace mpskit::regularize
