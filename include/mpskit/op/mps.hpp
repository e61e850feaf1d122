#pragma once
/// \file op/mps.hpp
/// \brief Classic MPS operators (Koshizuka & Oka 1996) as written in Tanaka 2018 eqs. 8–12 and 22 and
/// bmmr.md §2.3: gradient and divergence at the small radius (2.1 l0 by default), Laplacian at the large
/// radius (3.1 l0) with the reference-lattice λ0 and n0 of that radius (bmmr.md §2.2 [AMBIG]: one n0
/// per radius, as polymps does). Single resolution: one l0 for every particle; `set_sizes(&L)` switches
/// to per-particle diameters (radius R_i = ratio · L_i read through `mps_params::rule`, λ0 ∝ L_i²).
///
/// Extensions (issue 3, docs/operators.md): n0/λ0 per particle (eqs. 8 and 12 evaluated at i), the
/// corrected-matrix gradient (Wang et al. 2017, bmmr.md eq. 29), the mass-weighted interface forms for
/// mixed sizes (Tang & Wan, seed 004 eqs. 18–20) and Laplacian rows with the row-contribution hook.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/kernel/reference_lattice.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/op/detail/lsmps_basis.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::op {

/// Where the n0 and λ of the classic operators come from.
enum class mps_normalisation : std::uint8_t {
  reference_lattice,  ///< n0, λ0 of the full square/cubic lattice (Tanaka eq. 8 with n*, bmmr.md §2.2)
  per_particle,       ///< n_i (eq. 8) and λ_i (eq. 12, Tang & Wan eq. 8) summed at particle i itself
};

/// Numbers of the classic operators.
struct mps_params {
  double l0 = 0.0;        ///< initial particle spacing (m)
  double re_small = 2.1;  ///< gradient / divergence / number-density radius, in l0 (or in L_i)
  double re_large = 3.1;  ///< Laplacian radius, in l0 (or in L_i)
  /// Pair radius with per-particle sizes (ignored with one l0): own R_i, pair mean (Tang & Wan
  /// eqs. 16–17, Tanaka eq. 28) or max.
  search::radius_rule rule = search::radius_rule::own;
  mps_normalisation normalisation = mps_normalisation::reference_lattice;  ///< n0/λ0 source
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

  /// Row view handed to a row-contribution hook (op/concepts.hpp) by `build_laplacian_row`.
  struct row_view {
    const mps* op = nullptr;   ///< the operator
    index_t i = npos;          ///< the row particle
    double coefficient = 0.0;  ///< 2d/(n λ) of the row (eq. 10)
    double re = 0.0;           ///< the row's Laplacian radius R_i (m)
    /// Weight a_i(d) the row gives a virtual neighbour at displacement d (eq. 10: c · w(|d|, R_i)).
    double weight(const vec<D>& d) const { return coefficient * K::w(d.norm(), re); }
  };

  explicit mps(const mps_params& p) : p_(p) {
    p_.validate();
    small_ = kernel::reference_lattice<K, D>(p.re_small);
    large_ = kernel::reference_lattice<K, D>(p.re_large);
    re_s_ = p.re_small * p.l0;
    re_l_ = p.re_large * p.l0;
    lambda0_ = large_.lambda0(p.l0);
  }

  const mps_params& params() const { return p_; }  ///< the numbers
  double re_small() const { return re_s_; }        ///< small radius (m)
  double re_large() const { return re_l_; }        ///< large radius (m)
  double n0_small() const { return small_.n0; }    ///< n0 at the small radius
  double n0_large() const { return large_.n0; }    ///< n0 at the large radius
  double lambda0() const { return lambda0_; }      ///< λ0 at the large radius (m²)
  /// Support of the small radius (for reading a list built at ≥ re_large).
  search::support<search::uniform_radius> small_support() const {
    return {{re_s_}, search::radius_rule::own};
  }
  /// Support of the large radius.
  search::support<search::uniform_radius> large_support() const {
    return {{re_l_}, search::radius_rule::own};
  }

  /// Per-particle diameters L_i (the array must outlive the operator's use; nullptr: back to one l0).
  /// Radii become R_i = re_small·L_i and re_large·L_i read with params().rule; λ0 of row i is λ0(L_i).
  void set_sizes(const Eigen::VectorXd* L) { L_ = L; }
  /// The bound diameters (nullptr with one l0).
  const Eigen::VectorXd* sizes() const { return L_; }
  /// L_i (l0 without sizes).
  double diameter(index_t i) const { return L_ ? (*L_)[i] : p_.l0; }
  /// Reference λ0 of particle i at the large radius (λ0 ∝ L², bmmr.md §2.2).
  double lambda0(index_t i) const { return L_ ? large_.lambda0((*L_)[i]) : lambda0_; }
  /// Per-particle support of the small / large radius (with bound sizes).
  search::support<search::per_particle_radius> small_support_sized() const {
    return {{L_, p_.re_small}, p_.rule};
  }
  search::support<search::per_particle_radius> large_support_sized() const {
    return {{L_, p_.re_large}, p_.rule};
  }

  /// n_i = Σ_{j≠i} w(r_ij, re_small) (Tanaka eq. 8) over neighbours accepted by `filter`.
  template <class Filter = all_neighbours>
  double number_density(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                        const Filter& filter = {}) const {
    double n = 0.0;
    sweep(x, nl, i, false, filter, [&](index_t, const vec<D>&, double, double w) { n += w; });
    return n;
  }

  /// n_i at the large radius (for Laplacian-radius surface tests and diagnostics).
  template <class Filter = all_neighbours>
  double number_density_large(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                              const Filter& filter = {}) const {
    double n = 0.0;
    sweep(x, nl, i, true, filter, [&](index_t, const vec<D>&, double, double w) { n += w; });
    return n;
  }

  /// λ_i = Σ w r² / Σ w at the large radius (Tanaka eq. 12, Tang & Wan eq. 8); 0 with no neighbour.
  template <class Filter = all_neighbours>
  double lambda(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                const Filter& filter = {}) const {
    double sw = 0.0, swr2 = 0.0;
    sweep(x, nl, i, true, filter, [&](index_t, const vec<D>&, double r2, double w) {
      sw += w;
      swr2 += w * r2;
    });
    return sw > 0.0 ? swr2 / sw : 0.0;
  }

  /// Laplacian stencil (eq. 10): f(j, a_ij), a_ij = 2d/(λ n) w(r_ij, re_large) with λ0, n0 of the
  /// reference lattice, or λ_i, n_i of the particle (mps_normalisation::per_particle; 0 when isolated).
  template <class Filter, class F>
  void for_each_laplacian_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                 const Filter& filter, F&& f) const {
    const double c = laplacian_coefficient(x, nl, i, filter);
    sweep(x, nl, i, true, filter, [&](index_t j, const vec<D>&, double, double w) { f(j, c * w); });
  }

  /// Gradient stencil (eq. 9): f(j, c_ij), c_ij = d/n0 x_ij w(r_ij, re_small)/r_ij² (n_i per particle).
  template <class Filter, class F>
  void for_each_gradient_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                const Filter& filter, F&& f) const {
    const double c = gradient_coefficient(x, nl, i, filter);
    sweep(x, nl, i, false, filter,
          [&](index_t j, const vec<D>& d, double r2, double w) { f(j, vec<D>((c * w / r2) * d)); });
  }

  /// Emits the Laplacian row of i (eq. 10) into a RowBuilder, then hook(i, row_view, builder).
  template <class Filter, class B, class Hook = no_contribution>
  requires RowBuilder<B>
  void build_laplacian_row(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                           const Filter& filter, B& builder, const Hook& hook = {}) const {
    row_view rv{this, i, laplacian_coefficient(x, nl, i, filter), p_.re_large * diameter(i)};
    double diag = 0.0;
    sweep(x, nl, i, true, filter, [&](index_t j, const vec<D>&, double, double w) {
      const double a = rv.coefficient * w;
      builder.add(j, a);
      diag -= a;
    });
    builder.add_diagonal(diag);
    hook(i, rv, builder);
  }

  /// ⟨∇²φ⟩_i (eq. 10).
  template <class Filter = all_neighbours>
  double laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                   const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {}) const {
    double s = 0.0;
    for_each_laplacian_weight(x, nl, i, filter, [&](index_t j, double a) { s += a * (phi[j] - phi[i]); });
    return s;
  }

  /// ⟨∇²φ⟩_i for an Eigen::VectorXd (exact match: a VectorXd also converts to points<D>).
  template <class Filter = all_neighbours>
  double laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                   const Eigen::VectorXd& phi, const Filter& filter = {}) const {
    return laplacian(x, nl, i, Eigen::Ref<const Eigen::VectorXd>(phi), filter);
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
    for_each_gradient_weight(x, nl, i, filter,
                             [&](index_t j, const vec<D>& c) { g += c * (phi[j] - phi[i]); });
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
    const double pmin = min_neighbour_value(x, nl, i, p, filter);
    vec<D> g = vec<D>::Zero();
    for_each_gradient_weight(x, nl, i, filter, [&](index_t j, const vec<D>& c) { g += c * (p[j] - pmin); });
    return g;
  }

  // ---- corrected-matrix gradient (Wang et al. 2017; bmmr.md eq. 29) ----------------------------------

  /// Pivot tolerance of the correction matrix C_i (same test as LSMPS: d_k ≤ τ max C_kk ⇒ degenerate).
  static constexpr double correction_pivot_tolerance = 1e-10;

  /// C_i⁻¹ with C_i = Σ_j (x_ij/r_ij)⊗(x_ij/r_ij) w_ij at re_small (bmmr.md eq. 29). When C_i fails the
  /// pivot test (fewer than d independent directions, isolated) returns d/n0 · I — the plain eq. 9
  /// normalisation — and sets flag::degenerate in *flags.
  template <class Filter = all_neighbours>
  mat<D> correction_matrix(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                           const Filter& filter = {}, flag::type* flags = nullptr) const {
    mat<D> C = mat<D>::Zero();
    sweep(x, nl, i, false, filter, [&](index_t, const vec<D>& d, double r2, double w) {
      C.noalias() += (w / r2) * (d * d.transpose());
    });
    mat<D> inv;
    if (invert_correction(C, inv)) return inv;
    if (flags) *flags |= flag::degenerate;
    return (gradient_coefficient(x, nl, i, filter) * mat<D>::Identity()).eval();
  }

  /// C⁻¹ of an accumulated C = Σ_j (x_ij/r_ij)⊗(x_ij/r_ij) w_ij into inv; false (inv untouched) when C fails
  /// the pivot test (fewer than d independent directions). For callers that sum C in their own sweep.
  static bool invert_correction(const mat<D>& C, mat<D>& inv) {
    mat<D> F = C;
    if (detail::ldlt_pivoted(F, D, correction_pivot_tolerance).passed != D) return false;
    detail::ldlt_inverse(F, D, inv);
    return true;
  }

  /// Corrected gradient stencil: f(j, c_ij), c_ij = C_i⁻¹ x_ij w_ij / r_ij² (bmmr.md eq. 29, no d/n0):
  /// exact for linear fields wherever C_i passes the pivot test.
  template <class Filter, class F>
  void for_each_corrected_gradient_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                          const Filter& filter, F&& f, flag::type* flags = nullptr) const {
    const mat<D> Ci = correction_matrix(x, nl, i, filter, flags);
    sweep(x, nl, i, false, filter,
          [&](index_t j, const vec<D>& d, double r2, double w) { f(j, vec<D>(Ci * ((w / r2) * d))); });
  }

  /// ⟨∇φ⟩_i with the correction matrix (bmmr.md eq. 29 with p̂_i = φ_i).
  template <class Filter = all_neighbours>
  vec<D> corrected_gradient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                            const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {},
                            flag::type* flags = nullptr) const {
    vec<D> g = vec<D>::Zero();
    for_each_corrected_gradient_weight(
        x, nl, i, filter, [&](index_t j, const vec<D>& c) { g += c * (phi[j] - phi[i]); }, flags);
    return g;
  }

  /// Corrected pressure gradient with the minimum neighbour pressure (bmmr.md eq. 29, p̂_i of eq. 22).
  template <class Filter = all_neighbours>
  vec<D> corrected_min_pressure_gradient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                         const Eigen::Ref<const Eigen::VectorXd>& p,
                                         const Filter& filter = {}, flag::type* flags = nullptr) const {
    const double pmin = min_neighbour_value(x, nl, i, p, filter);
    vec<D> g = vec<D>::Zero();
    for_each_corrected_gradient_weight(
        x, nl, i, filter, [&](index_t j, const vec<D>& c) { g += c * (p[j] - pmin); }, flags);
    return g;
  }

  // ---- mass-weighted interface forms (Tang & Wan, seed 004 eqs. 18–20) -------------------------------
  // Masses m_i = ρ L_i^d with one density: ρ cancels from every ratio, so m_i = L_i^d is used. With equal
  // sizes every factor is 1 and the plain forms return (up to rounding).

  /// A_{j→i} = (m_j/(L_i L_j))(L_i + L_j) / (m_i/L_i + m_j/L_j) (Tang & Wan eq. 19).
  double mass_factor(index_t i, index_t j) const {
    const double Li = diameter(i), Lj = diameter(j), mi = mass(Li), mj = mass(Lj);
    return (mj / (Li * Lj)) * (Li + Lj) / (mi / Li + mj / Lj);
  }

  /// Mass-weighted number density n_i = Σ w_ij A_{j→i} at re_small (Tang & Wan §2.6, "PND ... also").
  template <class Filter = all_neighbours>
  double mass_weighted_number_density(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                      const Filter& filter = {}) const {
    double n = 0.0;
    sweep(x, nl, i, false, filter,
          [&](index_t j, const vec<D>&, double, double w) { n += w * mass_factor(i, j); });
    return n;
  }

  /// Conservative mass-weighted pressure gradient (Tang & Wan eq. 18):
  /// d/n0 Σ (P_j + P_i) x_ij w_ij A_{j→i} / r². With a symmetric pair rule m_i⟨∇P⟩_i pair terms cancel.
  template <class Filter = all_neighbours>
  vec<D> mass_weighted_gradient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                const Eigen::Ref<const Eigen::VectorXd>& p, const Filter& filter = {}) const {
    const double c = gradient_coefficient(x, nl, i, filter);
    vec<D> g = vec<D>::Zero();
    sweep(x, nl, i, false, filter, [&](index_t j, const vec<D>& d, double r2, double w) {
      g += (c * (p[j] + p[i]) * w * mass_factor(i, j) / r2) * d;
    });
    return g;
  }

  /// Mass-weighted divergence d/n0 Σ (u_j − u_i)·x_ij w_ij A_{j→i} / r² (Tang & Wan eq. 6 with eq. 19).
  template <class Filter = all_neighbours>
  double mass_weighted_divergence(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                  const points<D>& u, const Filter& filter = {}) const {
    const double c = gradient_coefficient(x, nl, i, filter);
    double s = 0.0;
    sweep(x, nl, i, false, filter, [&](index_t j, const vec<D>& d, double r2, double w) {
      s += c * w * mass_factor(i, j) * (u.col(j) - u.col(i)).dot(d) / r2;
    });
    return s;
  }

  /// Mass-weighted Laplacian stencil (Tang & Wan eq. 20): a_ij = 2d/n0 w_ij ((m_j/L_i)/λ_j +
  /// (m_j/L_j)/λ_i) / (m_i/L_i + m_j/L_j), with λ from `lambda` (per particle, eq. 8) or, when null,
  /// the reference λ0(L). m_i a_ij = m_j a_ji for a symmetric pair rule (momentum-conserving viscosity).
  template <class Filter, class F>
  void for_each_mass_weighted_laplacian_weight(const points<D>& x, const search::neighbour_list<D>& nl,
                                               index_t i, const Filter& filter, F&& f,
                                               const Eigen::VectorXd* lambda = nullptr) const {
    const double c = 2.0 * D / n0_of(x, nl, i, true, filter);
    const double Li = diameter(i), mi = mass(Li), li = lambda ? (*lambda)[i] : lambda0(i);
    sweep(x, nl, i, true, filter, [&](index_t j, const vec<D>&, double, double w) {
      const double Lj = diameter(j), mj = mass(Lj), lj = lambda ? (*lambda)[j] : lambda0(j);
      f(j, c * w * ((mj / Li) / lj + (mj / Lj) / li) / (mi / Li + mj / Lj));
    });
  }

  /// ⟨∇²φ⟩_i with the mass-weighted interface form (Tang & Wan eq. 20).
  template <class Filter = all_neighbours>
  double mass_weighted_laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                 const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {},
                                 const Eigen::VectorXd* lambda = nullptr) const {
    double s = 0.0;
    for_each_mass_weighted_laplacian_weight(
        x, nl, i, filter, [&](index_t j, double a) { s += a * (phi[j] - phi[i]); }, lambda);
    return s;
  }

 private:
  static double mass(double L) { return D == 2 ? L * L : L * L * L; }

  /// Calls f(j, x_ij, r², w_ij) over accepted neighbours at the small or large radius. One l0: the
  /// original uniform sweep; with sizes: R_ij from params().rule and w(r, R_ij).
  template <class Filter, class F>
  void sweep(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, bool large,
             const Filter& filter, F&& f) const {
    if (!L_) {
      const double re = large ? re_l_ : re_s_;
      nl.for_each_neighbour(x, i, large ? large_support() : small_support(),
                            [&](index_t j, const vec<D>& d, double r2) {
                              if (filter(j)) f(j, d, r2, K::w(std::sqrt(r2), re));
                            });
    } else {
      const double ratio = large ? p_.re_large : p_.re_small, Ri = ratio * (*L_)[i];
      nl.for_each_neighbour(x, i, large ? large_support_sized() : small_support_sized(),
                            [&](index_t j, const vec<D>& d, double r2) {
                              if (!filter(j)) return;
                              const double Rij =
                                  std::sqrt(search::pair_radius2(p_.rule, Ri, ratio * (*L_)[j]));
                              f(j, d, r2, K::w(std::sqrt(r2), Rij));
                            });
    }
  }

  /// n0 (reference) or n_i (per particle) at the small or large radius.
  template <class Filter>
  double n0_of(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, bool large,
               const Filter& filter) const {
    if (p_.normalisation == mps_normalisation::reference_lattice) return large ? large_.n0 : small_.n0;
    return large ? number_density_large(x, nl, i, filter) : number_density(x, nl, i, filter);
  }

  /// d/n of the gradient row (0 for an isolated particle in per-particle mode).
  template <class Filter>
  double gradient_coefficient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                              const Filter& filter) const {
    if (p_.normalisation == mps_normalisation::reference_lattice) return double(D) / small_.n0;
    const double n = number_density(x, nl, i, filter);
    return n > 0.0 ? double(D) / n : 0.0;
  }

  /// 2d/(λ n) of the Laplacian row (per particle: 2d / Σ w r², 0 when isolated).
  template <class Filter>
  double laplacian_coefficient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                               const Filter& filter) const {
    if (p_.normalisation == mps_normalisation::reference_lattice) return 2.0 * D / (lambda0(i) * large_.n0);
    double swr2 = 0.0;
    sweep(x, nl, i, true, filter, [&](index_t, const vec<D>&, double r2, double w) { swr2 += w * r2; });
    return swr2 > 0.0 ? 2.0 * D / swr2 : 0.0;
  }

  /// p̂_i = min(p_i, min_j p_j) over accepted neighbours in re_small (Tanaka eq. 22).
  template <class Filter>
  double min_neighbour_value(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                             const Eigen::Ref<const Eigen::VectorXd>& p, const Filter& filter) const {
    double pmin = p[i];
    sweep(x, nl, i, false, filter,
          [&](index_t j, const vec<D>&, double, double) { pmin = std::min(pmin, p[j]); });
    return pmin;
  }

  mps_params p_;
  kernel::lattice_constants small_{}, large_{};
  double re_s_ = 0.0, re_l_ = 0.0, lambda0_ = 0.0;
  const Eigen::VectorXd* L_ = nullptr;
};

}  // namespace mpskit::op
