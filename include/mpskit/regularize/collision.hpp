#pragma once
/// \file regularize/collision.hpp
/// \brief Pairwise collision model (Lee et al. 2011) as used by BMMR (seed 001 eq. 13; bmmr.md §2.6):
/// for each approaching neighbour j (r_ij · u_ij < 0) with |r_ij| ≤ α1 l0,
///   Δu_i = Σ_j (1 + α2)/α3 (r_ij · u_ij)/|r_ij| r_ij/|r_ij|,   r_ij = r_j − r_i, u_ij = u_j − u_i,
/// α3 = 2 when j is movable (an equal-mass fluid particle) and α3 = 1 when j is immovable (wall,
/// dummy: an infinitely heavy partner). Then u** = u* + Δu and r** = r* + Δu Δt (seed 001 eqs. 23–24).
///
/// Readings (docs/regularize.md): every Δu_i is computed from the same u* first and committed after
/// (Jacobi, bmmr.md §2.6 [AMBIG]); only movable particles change; the distance test is the paper's
/// |r_ij| ≤ α1 l0 (inclusive, unlike mpskit's strict search rule), so the list must be built at a radius
/// > α1 l0 (any classic MPS list is); coincident pairs (r = 0, no direction) are skipped and counted.
/// For α3 = 2 the pair's relative normal velocity becomes −α2 times its old value and the pair momentum is
/// unchanged; for α3 = 1 the same holds against a wall of infinite mass.
#include <algorithm>
#include <cmath>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/regularize/concepts.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::regularize {

/// Numbers of the collision model (BMMR defaults, bmmr.md §2.13).
struct collision_params {
  double l0 = 0.0;       ///< initial particle spacing (m)
  double alpha1 = 0.85;  ///< collision distance α1 in l0 (paper range [0.8, 1.0])
  double alpha2 = 0.2;   ///< coefficient of restitution α2 (paper range [0, 0.2])
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("collision_params");
    v.positive("l0", l0).positive("alpha1", alpha1).in_range("alpha2", alpha2, 0.0, 1.0);
    v.throw_if_any();
  }
};

/// What one application did.
struct collision_report {
  index_t pairs = 0;       ///< directed pairs (i movable, j) that collided
  index_t particles = 0;   ///< particles whose velocity changed
  index_t coincident = 0;  ///< directed pairs at r = 0 (skipped: no direction)
  double max_dv = 0.0;     ///< max |Δu_i| (m/s)
};

/// The pair rule of seed 001 eq. 13 for both forms below. For every movable i and participating neighbour j
/// with |r_ij|² ≤ contact2(i, j) that approaches (r_ij · u_ij < 0):
///   Δu_i += (1 + α2) share(i, j) (r_ij · u_ij)/|r_ij|² r_ij,
/// share = 1/α3 of the paper (1/2 between equal masses, 1 against an immovable partner). Every Δu_i is read
/// from the same u (Jacobi); coincident pairs are skipped and counted. The pair momentum m_i Δu_i + m_j Δu_j
/// is zero when share(i, j) = m_j/(m_i + m_j) (and the list is symmetric).
template <Execution E, int D, class Participates, class Movable, class Contact2, class Share>
collision_report pair_collisions(E e, const points<D>& x, const points<D>& u,
                                 const search::neighbour_list<D>& nl, const Participates& participates,
                                 const Movable& movable, const Contact2& contact2, const Share& share,
                                 double alpha2, points<D>& du) {
  const index_t n = x.cols();
  du.setZero(D, n);
  std::vector<index_t> hits(static_cast<std::size_t>(n), 0), zero(static_cast<std::size_t>(n), 0);
  for_each_particle(e, n, [&](index_t i) {
    if (!movable(i)) return;
    vec<D> s = vec<D>::Zero();
    index_t h = 0, z = 0;
    for (const auto jj : nl.neighbours(i)) {
      const index_t j = jj;
      if (!participates(j)) continue;
      const vec<D> d = nl.displacement(x, i, j);
      const double r2 = d.squaredNorm();
      if (r2 > contact2(i, j)) continue;  // eq. 13: |r_ij| ≤ the contact distance
      if (r2 == 0.0) {
        ++z;
        continue;
      }
      const double dot = d.dot(u.col(j) - u.col(i));
      if (!(dot < 0.0)) continue;  // eq. 13: approaching pairs only
      // (1+α2)/α3 (r_ij·u_ij)/|r_ij| r_ij/|r_ij| = (1+α2) share (r_ij·u_ij)/r² r_ij
      s += ((1.0 + alpha2) * share(i, j) * (dot / r2)) * d;
      ++h;
    }
    du.col(i) = s;
    hits[static_cast<std::size_t>(i)] = h;
    zero[static_cast<std::size_t>(i)] = z;
  });
  collision_report rep;
  const auto add = [](index_t a, index_t b) { return a + b; };
  rep.pairs = reduce(
      e, n, index_t{0}, [&](index_t i) { return hits[static_cast<std::size_t>(i)]; }, add);
  rep.particles = reduce(
      e, n, index_t{0}, [&](index_t i) { return index_t{hits[static_cast<std::size_t>(i)] > 0}; }, add);
  rep.coincident = reduce(
      e, n, index_t{0}, [&](index_t i) { return zero[static_cast<std::size_t>(i)]; }, add);
  rep.max_dv = reduce(
      e, n, 0.0, [&](index_t i) { return du.col(i).norm(); },
      [](double a, double b) { return std::max(a, b); });
  return rep;
}

/// Numbers of the collision stage for particles of different sizes (sized_collisions; the LSMPS scheme's
/// opt-in stage, lsmps_params::collision, docs/lsmps_scheme.md deviation 17).
struct sized_collision_params {
  double alpha1 = 0.0;  ///< contact distance in units of the pair-mean diameter L_ij = (L_i + L_j)/2; 0: off
  double alpha2 = 0.2;  ///< coefficient of restitution (seed 001's range [0, 0.2])
  /// Read by the LSMPS stepper (lsmps_params::collision): isolated particles (c < α_c) and their wall copies
  /// take part too (ours; false: they move ballistically, Tanaka §4.5.1 and issue #7 item 5, and pass through
  /// each other and into the fluid they fall back on). The functions below take part through their predicates
  /// only.
  bool isolated = false;
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("sized_collision_params");
    v.in_range("alpha1", alpha1, 0.0, 1.5).in_range("alpha2", alpha2, 0.0, 1.0);
    v.throw_if_any();
  }
};

/// Seed 001 eq. 13 between particles of different sizes (ours): contact when |r_ij| ≤ α1 L_ij with the
/// pair-mean diameter, share(i, j) = V_j/(V_i + V_j) between movable particles (the pair's momentum Σ V u is
/// kept: the paper's α3 = 2 for equal volumes) and 1 against an immovable partner (α3 = 1). `L` and `V` hold
/// every particle's diameter and volume (V is read for movable particles only; volumes > 0). Δu into du (D
/// × n), nothing changed. Throws mpskit::error on bad params or sizes that do not match x.
template <Execution E, int D, class Diameters, class Volumes, class Participates, class Movable>
collision_report sized_collisions(E e, const points<D>& x, const points<D>& u, const Diameters& L,
                                  const Volumes& V, const search::neighbour_list<D>& nl,
                                  const Participates& participates, const Movable& movable,
                                  const sized_collision_params& p, points<D>& du) {
  p.validate();
  const index_t n = x.cols();
  if (u.cols() != n || nl.rows() != n || static_cast<index_t>(L.size()) != n ||
      static_cast<index_t>(V.size()) != n)
    fail("sized_collisions: x has ", n, " columns but u ", u.cols(), ", the neighbour list ", nl.rows(),
         " rows, L ", L.size(), " and V ", V.size(), " values (one per particle, the list built on x)");
  const auto contact2 = [&](index_t i, index_t j) {
    const double r = 0.5 * p.alpha1 * (L[i] + L[j]);
    return r * r;
  };
  const auto share = [&](index_t i, index_t j) { return movable(j) ? V[j] / (V[i] + V[j]) : 1.0; };
  return pair_collisions(e, x, u, nl, participates, movable, contact2, share, p.alpha2, du);
}

/// Lee et al. (2011) collision model, seed 001 eq. 13.
class collision final {
 /// fields beyond the core: none (uses position, velocity)
 public: using fields = field_list<>;
  using params_type = collision_params;
  /// Validates p.
  explicit collision(const params_type& p) : p_(p) { p_.validate(); }
  const params_type& params() const { return p_; }  ///< the numbers

  /// Δu (D × n) from x and u without changing them; zero columns for immovable particles.
  /// `participates(j)`: j counts as a partner; `movable(i)`: i is a fluid particle (changes, α3 = 2 as a
  /// partner); immovable partners act with α3 = 1.
  template <Execution E, int D, class Participates, class Movable>
  collision_report velocity_change(E e, const points<D>& x, const points<D>& u,
                                   const search::neighbour_list<D>& nl, const Participates& participates,
                                   const Movable& movable, points<D>& du) const {
    check_sizes(x, u, nl);
    const double rc = p_.alpha1 * p_.l0, rc2 = rc * rc;
    return pair_collisions(
        e, x, u, nl, participates, movable, [rc2](index_t, index_t) { return rc2; },
        [&movable](index_t, index_t j) { return movable(j) ? 0.5 : 1.0; }, p_.alpha2, du);  // 1/α3
  }

  /// u ← u + Δu, x ← x + Δu dt for movable particles (seed 001 eqs. 23–24); dt = 0 leaves x alone.
  template <Execution E, int D, class Participates, class Movable>
  collision_report apply(E e, points<D>& x, points<D>& u, const search::neighbour_list<D>& nl,
                         const Participates& participates, const Movable& movable, double dt) const {
    if (!(std::isfinite(dt) && dt >= 0.0)) fail("collision: dt = ", dt, ": must be a finite number >= 0");
    points<D> du;
    const collision_report rep = velocity_change(e, x, u, nl, participates, movable, du);
    for_each_particle(e, x.cols(), [&](index_t i) {
      if (!movable(i)) return;
      u.col(i) += du.col(i);
      if (dt > 0.0) x.col(i) += dt * du.col(i);
    });
    return rep;
  }

 private:
  template <int D>
  static void check_sizes(const points<D>& x, const points<D>& u, const search::neighbour_list<D>& nl) {
    if (u.cols() != x.cols()) fail("collision: u has ", u.cols(), " columns for ", x.cols(), " particles");
    if (nl.rows() != x.cols())
      fail("collision: the neighbour list has ", nl.rows(), " rows for ", x.cols(),
           " particles (rebuild it)");
  }
  params_type p_;
};

}  // namespace mpskit::regularize
