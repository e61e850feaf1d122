#pragma once
/// \file surface/normals.hpp
/// \brief Outward unit normals of fluid particles, Tanaka, Cardoso & Bahai 2018 (seed 000) eqs. 30–31,
/// with the weight of eq. 29 at the pair-mean radius R_ij = (R_i + R_j)/2, R_i = R_e L_i (eqs. 27–28).
/// docs/surface.md, "Tanaka 2018 (LSMPS scenes)".
///
/// Sign: eq. 31 with x_ij = x_j − x_i (eq. 1) gives n*_i = M_i⁻¹ Σ w_ij x_ij, which points towards the
/// neighbours, i.e. into the fluid; the paper says fluid normals point "toward outside of fluid", so
/// mpskit returns n_i = −n*_i/|n*_i|.
///
/// Units: n*_i is computed with x̂_ij = x_ij / L_i, so it is dimensionless (the physical n* of eq. 31
/// has units 1/m and equals n̂*/L_i). A normal is degenerate (n_i = 0) when the moment matrix
/// M̂_i = Σ w x̂⊗x̂ is singular — smallest |pivot| of its pivoting LDLᵀ ≤ singular_tol · trace(M̂_i), or
/// trace 0 (no neighbour) — or when |n̂*_i| < zero_tol (a symmetric neighbourhood: n* ≈ 0, no direction).
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::surface {

/// Every particle is wanted (default selection of normals() and geometric()).
struct all_particles {
  constexpr bool operator()(index_t) const noexcept { return true; }
};

/// Why a normal is degenerate (values of the `degenerate` array of normals()).
namespace degenerate_normal {
inline constexpr std::uint8_t none = 0;       ///< a unit normal was computed
inline constexpr std::uint8_t vanishing = 1;  ///< |n̂*| < zero_tol: symmetric neighbourhood (interior)
inline constexpr std::uint8_t singular = 2;   ///< singular moment matrix: no neighbour or all on a line/plane
}  // namespace degenerate_normal

/// Numbers of the normal computation.
struct normals_params {
  double re_ratio = 3.1;       ///< R_e of eq. 27: R_i = R_e L_i, pairs read at R_ij (eq. 28); finite, > 0
  double zero_tol = 1e-8;      ///< |n̂*_i| below this (dimensionless) → degenerate; finite, ≥ 0
  double singular_tol = 1e-12; ///< min |LDLᵀ pivot| ≤ this · trace(M̂) → singular; in [0, 1)
  /// Throws mpskit::error listing every bad value with its accepted range.
  void validate() const {
    validator v("normals_params");
    v.positive("re_ratio", re_ratio).non_negative("zero_tol", zero_tol);
    v.require(std::isfinite(singular_tol) && singular_tol >= 0.0 && singular_tol < 1.0, "singular_tol",
              mpskit::detail::concat("is ", singular_tol, "; must be in [0, 1)"));
    v.throw_if_any();
  }
};

/// Result of one particle: the outward unit normal (0 when degenerate), the reason, and n̂*.
template <int D>
struct normal_result {
  vec<D> n = vec<D>::Zero();       ///< outward unit normal −n̂*/|n̂*| (zero when degenerate)
  vec<D> n_star = vec<D>::Zero();  ///< n̂* of eq. 31, x̂ = x_ij/L_i (inward, dimensionless; 0 if singular)
  std::uint8_t degenerate = degenerate_normal::none;  ///< a degenerate_normal value
};

/// Eqs. 29–31 for particle i over its participating neighbours (p valid, not re-checked).
template <int D, class Participates>
  requires Dimension<D>
normal_result<D> normal_of(const points<D>& x, const Eigen::VectorXd& L, const search::neighbour_list<D>& nl,
                           const Participates& participates, const normals_params& p, index_t i) {
  using M = mat<D>;
  M m = M::Zero();
  vec<D> b = vec<D>::Zero();
  const double inv_Li = 1.0 / L[i];
  const double Ri = p.re_ratio * L[i];
  const search::support<search::per_particle_radius> s{{&L, p.re_ratio}, search::radius_rule::pair_mean};
  nl.for_each_neighbour(x, i, s, [&](index_t j, const vec<D>& d, double r2) {
    if (!participates(j)) return;
    const double Rij = 0.5 * (Ri + p.re_ratio * L[j]);          // eq. 28
    const double w = kernel::quadratic::w(std::sqrt(r2), Rij);  // eq. 29
    const vec<D> xh = d * inv_Li;
    m.noalias() += w * xh * xh.transpose();  // eq. 31, moment matrix
    b.noalias() += w * xh;                   // eq. 31, moment vector
  });
  normal_result<D> out;
  const double tr = m.trace();
  if (!(tr > 0.0)) {
    out.degenerate = degenerate_normal::singular;
    return out;
  }
  const Eigen::LDLT<M> ldlt(m);
  const double min_pivot = ldlt.vectorD().cwiseAbs().minCoeff();
  if (ldlt.info() != Eigen::Success || !(min_pivot > p.singular_tol * tr)) {
    out.degenerate = degenerate_normal::singular;
    return out;
  }
  out.n_star = ldlt.solve(b);  // eq. 31
  const double len = out.n_star.norm();
  if (!(len >= p.zero_tol) || len == 0.0) {
    out.degenerate = degenerate_normal::vanishing;
    return out;
  }
  out.n = -out.n_star / len;  // eq. 30 with the outward sign (see the file comment)
  return out;
}

/// Outward unit normals n.col(i) of the particles with wanted(i) (default: all), eqs. 29–31. n and
/// degenerate are resized to x.cols() when their size differs (new entries zero); entries of particles
/// not wanted are left as they were (ghosts: their normal comes from the wall geometry). degenerate[i] is
/// a degenerate_normal value; degenerate particles get n_i = 0. `participates(j)` selects the neighbours
/// j ≠ i that count (the caller excludes isolated particles). The list must hold the pairs with
/// r < R_ij at ratio ≥ p.re_ratio (the scene's 3.1 L list does). Throws mpskit::error on bad p or sizes.
template <int D, Execution E, class Participates, class Wanted = all_particles>
  requires Dimension<D>
void normals(E e, const points<D>& x, const Eigen::VectorXd& L, const search::neighbour_list<D>& nl,
             const Participates& participates, points<D>& n, std::vector<std::uint8_t>& degenerate,
             const Wanted& wanted = {}, const normals_params& p = {}) {
  p.validate();
  const index_t np = x.cols();
  if (L.size() != np) fail("normals: L has ", L.size(), " entries for ", np, " particles");
  if (nl.rows() != np)
    fail("normals: the neighbour list has ", nl.rows(), " rows for ", np, " particles (rebuild it)");
  if (n.cols() != np) n.setZero(D, np);
  check_diameters("normals", L, np);
  if (static_cast<index_t>(degenerate.size()) != np) degenerate.assign(static_cast<std::size_t>(np), 0);
  for_each_particle(e, np, [&](index_t i) {
    if (!wanted(i)) return;
    const normal_result<D> r = normal_of<D>(x, L, nl, participates, p, i);
    n.col(i) = r.n;
    degenerate[static_cast<std::size_t>(i)] = r.degenerate;
  });
}

}  // namespace mpskit::surface
