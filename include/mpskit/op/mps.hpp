#pragma once
/// \file op/mps.hpp
/// \brief Classic MPS operators (Koshizuka & Oka 1996) as written in Tanaka 2018 eqs. 8–12 and 22 and
/// bmmr.md §2.3: gradient and divergence at the small radius (2.1 l0 by default), Laplacian at the large
/// radius (3.1 l0) with the reference-lattice λ0 and n0 of that radius (bmmr.md §2.2 [AMBIG]: one n0
/// per radius, as polymps does). Single resolution: one l0 for every particle.
#include <algorithm>
#include <cmath>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/kernel/reference_lattice.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::op {

/// Numbers of the classic operators.
struct mps_params {
  double l0 = 0.0;            ///< initial particle spacing (m)
  double re_small = 2.1;      ///< gradient / divergence / number-density radius, in l0
  double re_large = 3.1;      ///< Laplacian radius, in l0
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("mps_params");
    v.positive("l0", l0).positive("re_small", re_small).positive("re_large", re_large);
    v.throw_if_any();
  }
};

/// Classic MPS operators with kernel K (quadratic by default; `kernel::classic` for the original).
template <int D, Kernel K = kernel::quadratic>
  requires Dimension<D>
class mps final {
 public:
  static constexpr int dim = D;
  using kernel_type = K;

  explicit mps(const mps_params& p) : p_(p) {
    p_.validate();
    small_ = kernel::reference_lattice<K, D>(p.re_small);
    large_ = kernel::reference_lattice<K, D>(p.re_large);
    re_s_ = p.re_small * p.l0;
    re_l_ = p.re_large * p.l0;
    lambda0_ = large_.lambda0(p.l0);
  }

  const mps_params& params() const { return p_; }          ///< the numbers
  double re_small() const { return re_s_; }                ///< small radius (m)
  double re_large() const { return re_l_; }                ///< large radius (m)
  double n0_small() const { return small_.n0; }            ///< n0 at the small radius
  double n0_large() const { return large_.n0; }            ///< n0 at the large radius
  double lambda0() const { return lambda0_; }              ///< λ0 at the large radius (m²)
  /// Support of the small radius (for reading a list built at ≥ re_large).
  search::support<search::uniform_radius> small_support() const { return {{re_s_}, search::radius_rule::own}; }
  /// Support of the large radius.
  search::support<search::uniform_radius> large_support() const { return {{re_l_}, search::radius_rule::own}; }

  /// n_i = Σ_{j≠i} w(r_ij, re_small) (Tanaka eq. 8) over neighbours accepted by `filter`.
  template <class Filter = all_neighbours>
  double number_density(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                        const Filter& filter = {}) const {
    double n = 0.0;
    nl.for_each_neighbour(x, i, small_support(), [&](index_t j, const vec<D>&, double r2) {
      if (filter(j)) n += K::w(std::sqrt(r2), re_s_);
    });
    return n;
  }

  /// n_i at the large radius (for Laplacian-radius surface tests and diagnostics).
  template <class Filter = all_neighbours>
  double number_density_large(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                              const Filter& filter = {}) const {
    double n = 0.0;
    nl.for_each_neighbour(x, i, large_support(), [&](index_t j, const vec<D>&, double r2) {
      if (filter(j)) n += K::w(std::sqrt(r2), re_l_);
    });
    return n;
  }

  /// Laplacian stencil (eq. 10 with λ0): f(j, a_ij), a_ij = 2d/(λ0 n0) w(r_ij, re_large).
  template <class Filter, class F>
  void for_each_laplacian_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                 const Filter& filter, F&& f) const {
    const double c = 2.0 * D / (lambda0_ * large_.n0);
    nl.for_each_neighbour(x, i, large_support(), [&](index_t j, const vec<D>&, double r2) {
      if (filter(j)) f(j, c * K::w(std::sqrt(r2), re_l_));
    });
  }

  /// Gradient stencil (eq. 9): f(j, c_ij), c_ij = d/n0 x_ij w(r_ij, re_small)/r_ij².
  template <class Filter, class F>
  void for_each_gradient_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                const Filter& filter, F&& f) const {
    const double c = double(D) / small_.n0;
    nl.for_each_neighbour(x, i, small_support(), [&](index_t j, const vec<D>& d, double r2) {
      if (filter(j)) f(j, vec<D>((c * K::w(std::sqrt(r2), re_s_) / r2) * d));
    });
  }

  /// ⟨∇²φ⟩_i (eq. 10).
  template <class Filter = all_neighbours>
  double laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                   const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {}) const {
    double s = 0.0;
    for_each_laplacian_weight(x, nl, i, filter, [&](index_t j, double a) { s += a * (phi[j] - phi[i]); });
    return s;
  }

  /// ⟨∇²u⟩_i of a vector field, component-wise (eq. 10; the viscous term).
  template <class Filter = all_neighbours>
  vec<D> laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const points<D>& u,
                   const Filter& filter = {}) const {
    vec<D> s = vec<D>::Zero();
    for_each_laplacian_weight(x, nl, i, filter, [&](index_t j, double a) { s += a * (u.col(j) - u.col(i)); });
    return s;
  }

  /// ⟨∇φ⟩_i (eq. 9).
  template <class Filter = all_neighbours>
  vec<D> gradient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                  const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {}) const {
    vec<D> g = vec<D>::Zero();
    for_each_gradient_weight(x, nl, i, filter, [&](index_t j, const vec<D>& c) { g += c * (phi[j] - phi[i]); });
    return g;
  }

  /// ⟨∇·u⟩_i (eq. 11).
  template <class Filter = all_neighbours>
  double divergence(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const points<D>& u,
                    const Filter& filter = {}) const {
    double s = 0.0;
    for_each_gradient_weight(x, nl, i, filter,
                             [&](index_t j, const vec<D>& c) { s += c.dot(u.col(j) - u.col(i)); });
    return s;
  }

  /// Pressure gradient with the minimum neighbour pressure (Tanaka eq. 22):
  /// d/n0 Σ (p_j − p̂_i) x_ij w/r², p̂_i = min(p_i, min_j p_j) over the accepted neighbours in re_small.
  /// Every pair force is then repulsive.
  template <class Filter = all_neighbours>
  vec<D> min_pressure_gradient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                               const Eigen::Ref<const Eigen::VectorXd>& p, const Filter& filter = {}) const {
    double pmin = p[i];
    nl.for_each_neighbour(x, i, small_support(), [&](index_t j, const vec<D>&, double) {
      if (filter(j)) pmin = std::min(pmin, p[j]);
    });
    vec<D> g = vec<D>::Zero();
    for_each_gradient_weight(x, nl, i, filter, [&](index_t j, const vec<D>& c) { g += c * (p[j] - pmin); });
    return g;
  }

 private:
  mps_params p_;
  kernel::lattice_constants small_{}, large_{};
  double re_s_ = 0.0, re_l_ = 0.0, lambda0_ = 0.0;
};

}  // namespace mpskit::op
