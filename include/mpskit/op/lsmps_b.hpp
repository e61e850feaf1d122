#pragma once
/// \file op/lsmps_b.hpp
/// \brief LSMPS type B: value and derivatives at any point x (Tanaka 2018 eqs. 47–52; Tamai & Koshizuka
/// 2014), orders 1–3 in 2D and 3D. Basis p̂ = [1, p] (eq. 52), Ĥ = diag(1, α!/l^|α|) (eq. 49 read with
/// l^−|α|), M̂ = Σ_j w_j p̂((x_j − x)/l) p̂ᵀ (eq. 50). The point's own value is not known, so rows are
/// absolute: ⟨D̂ φ⟩(x) = Σ_j ĉ_j φ_j. A point on top of a particle has r = 0, so the kernel must be
/// finite at zero.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/op/detail/lsmps_basis.hpp"
#include "mpskit/op/lsmps_params.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::op {

/// \brief LSMPS type B of order Order (1–3) with kernel K.
template <int D, int Order, Kernel K = kernel::quadratic>
requires Dimension<D> &&(Order >= 1 && Order <= 3) class lsmps_b final {
  static_assert(
      K::finite_at_zero,
      "mpskit: LSMPS type B evaluates w at r = 0 when the point is a particle: use a kernel finite at zero");

 public:
  using basis = detail::lsmps_basis<D, Order>;
  static constexpr int dim = D;                       ///< spatial dimension
  static constexpr int order = Order;                 ///< polynomial order
  static constexpr int basis_size = basis::size + 1;  ///< m̂ = m + 1 (the constant)
  using kernel_type = K;
  using vector = Eigen::Matrix<double, basis_size, 1>;  ///< [value, D_x] (eq. 48 order)
  using matrix = Eigen::Matrix<double, basis_size, basis_size>;

  /// The weights of one point: ⟨D̂φ⟩(x) = Σ_k c_k φ_{j_k}.
  struct point_stencil {
    vec<D> x = vec<D>::Zero();     ///< the point
    double l = 0.0;                ///< its diameter
    int order_used = 0;            ///< exact order achieved (0: weighted average, regularised, or nothing)
    flag::type flags = 0;          ///< flag::degenerate when the fit fell back
    double condition = 0.0;        ///< cond₁ of the block of M̂ used (as lsmps_a::condition)
    std::vector<index_t> columns;  ///< particles with weight
    std::vector<vector> weights;   ///< ĉ_j per column (value, then D_x)
    /// [value, D_x φ] at the point.
    vector apply(const Eigen::Ref<const Eigen::VectorXd>& phi) const {
      vector s = vector::Zero();
      for (std::size_t k = 0; k < columns.size(); ++k) s += weights[k] * phi[columns[k]];
      return s;
    }
    double value(const Eigen::Ref<const Eigen::VectorXd>& phi) const { return apply(phi)[0]; }  ///< φ(x)
    /// ∇φ(x).
    vec<D> gradient(const Eigen::Ref<const Eigen::VectorXd>& phi) const {
      return vec<D>(apply(phi).template segment<D>(1));
    }
    /// ∇²φ(x) (zero at order 1).
    double laplacian(const Eigen::Ref<const Eigen::VectorXd>& phi) const {
      return apply(phi).template tail<basis_size - 1>().dot(basis::laplacian_selector());
    }
  };

  explicit lsmps_b(const lsmps_params& p = {}) : p_(p) { p_.validate(); }
  const lsmps_params& params() const { return p_; }  ///< the numbers

  /// Index in [value, D_x] of ∂^α (derivative_index(0, 0) = the value).
  static constexpr int derivative_index(int ax, int ay, int az = 0) {
    return ax + ay + az == 0 ? 0 : 1 + basis::index_of(ax, ay, az);
  }

  /// Scratch of `stencil` (kernel weights and basis vectors of the candidates kept): reused across calls,
  /// it keeps its capacity, so a loop over points allocates nothing once the largest neighbourhood was seen.
  struct workspace {
    std::vector<double> w;
    std::vector<vector> P;
  };

  /// Fits at point xq with diameter l over `candidates` (their sizes from `size`): weight
  /// w(|x_j − xq|, R_qj) with R_q = re_ratio·l, R_j = re_ratio·L_j and the params' rule; candidates
  /// outside R_qj or rejected by `filter` get no weight.
  template <SizeModel S, class Filter = all_neighbours>
  point_stencil stencil(const points<D>& x, const vec<D>& xq, double l, std::span<const index_t> candidates,
                        const S& size, const Filter& filter = {}) const {
    point_stencil st;
    workspace ws;
    stencil(x, xq, l, candidates, size, filter, st, ws);
    return st;
  }

  /// The same fit into `st`, every member overwritten, with the scratch `ws`: `st`'s and `ws`'s vectors keep
  /// their capacity (no allocation in a loop over points; the same numbers bit for bit as the returning
  /// form).
  template <SizeModel S, class Filter>
  void stencil(const points<D>& x, const vec<D>& xq, double l, std::span<const index_t> candidates,
               const S& size, const Filter& filter, point_stencil& st, workspace& ws) const {
    if (!(std::isfinite(l) && l > 0.0))
      fail("lsmps_b: point diameter l = ", l, ": must be a finite number > 0");
    st.x = xq;
    st.l = l;
    st.order_used = 0;
    st.flags = 0;
    st.condition = 0.0;
    st.columns.clear();
    std::vector<double>& w = ws.w;
    std::vector<vector>& P = ws.P;
    w.clear();
    P.clear();
    const double Rq = p_.re_ratio * l, linv = 1.0 / l;
    for (index_t j : candidates) {
      if (!filter(j)) continue;
      const vec<D> d = x.col(j) - xq;
      const double r2 = d.squaredNorm();
      const double Rj = p_.re_ratio * size(j);
      const double R2 = search::pair_radius2(p_.rule, Rq, Rj);
      if (!search::within(r2, R2)) continue;
      const double wj = K::w(std::sqrt(r2), std::sqrt(R2));
      if (!(wj > 0.0)) continue;
      vector pv;
      pv[0] = 1.0;
      typename basis::vector tail;
      basis::eval(vec<D>(d * linv), tail);
      pv.template tail<basis_size - 1>() = tail;
      st.columns.push_back(j);
      w.push_back(wj);
      P.push_back(pv);
    }
    matrix M = matrix::Zero();
    for (std::size_t k = 0; k < P.size(); ++k)
      for (int a = 0; a < basis_size; ++a)
        for (int b = 0; b <= a; ++b) M(a, b) += w[k] * P[k][a] * P[k][b];  // eq. 50 (lower triangle)
    matrix Minv;
    const bool lower = p_.fallback == degenerate_fallback::lower_order;
    const detail::factor_result r = detail::factorise(
        M, Order, [](int p) { return 1 + basis::size_at(p); }, 0, lower, p_.max_condition, p_.regularisation,
        lower ? 1 : basis_size, Minv);
    st.order_used = r.order;
    st.condition = r.condition;
    if (r.degenerate) st.flags |= flag::degenerate;
    // ĉ_j = Ĥ M̂⁻¹ w_j p̂_j (eq. 47 as weights).
    vector h;
    h[0] = 1.0;
    h.template tail<basis_size - 1>() = basis::h_diag(l);
    const matrix A = h.asDiagonal() * Minv;
    st.weights.resize(P.size());
    for (std::size_t k = 0; k < P.size(); ++k) st.weights[k] = A * (w[k] * P[k]);
  }

 private:
  lsmps_params p_;
};

}  // namespace mpskit::op
