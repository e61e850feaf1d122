#pragma once
/// \file ppe/det_f.hpp
/// \brief The det F volume condition of Nair & Tomar as used by Tanaka, Cardoso & Bahai 2018 §4.3
/// (eqs. 55–63) with the packing-ratio volume correction c′ (eqs. 61–62).
///
/// With F = I + Δt ∇u^{k+1} (eq. 57) and u^{k+1} = u′ − (Δt/ρ) ∇p (eq. 15), F = A − (Δt²/ρ) ∇∇p with
/// A = I + Δt ∇u′ (eq. 60). Jacobi's formula, det(A + δ) = det A + Σ_ab cof(A)_ab δ_ab + O(δ²), gives
/// to first order in the pressure term (the "higher order terms" eq. 59 neglects)
///
///     (1/ρ) Σ_ab cof(A)_ab ∂_a∂_b p = (det A − c′)/Δt²,
///
/// and since ∂_a∂_b p is symmetric only the symmetric part of cof(A) enters. In 2D cof(A) =
/// [[a22, −a21], [−a12, a11]], which is eq. 63 term by term. The operator needs every second derivative
/// separately, so it exists only for operators exposing them (LSMPS of order ≥ 2); classic MPS and LSMPS of
/// order 1 are refused at compile time (Tanaka §4.3: "Eqs. (59) and (63) cannot be employed in the
/// traditional MPS method").
#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/params.hpp"

namespace mpskit::ppe {

/// An operator that exposes every second derivative separately (LSMPS type A of order ≥ 2).
template <class Op>
concept SecondDerivativeOperator = requires {
  { Op::order } -> std::convertible_to<int>;
  { Op::derivative_index(2, 0, 0) } -> std::convertible_to<int>;
  typename Op::vector;
} && (Op::order >= 2);

/// Numbers of the volume correction (Tanaka 2018 Table 2 / eq. 62).
struct det_f_params {
  double c_min = 0.95;       ///< c_min: below it the volume is let grow (packing ratio)
  double c_max = 1.2;        ///< c_max: above it the volume is let shrink
  double c_prime_min = 0.999; ///< c′_min: the largest expansion per step
  double c_prime_max = 1.001; ///< c′_max: the largest compression per step
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("det_f_params");
    v.positive("c_min", c_min).positive("c_max", c_max);
    v.require(c_max >= c_min, "c_max", "must be >= c_min");
    v.in_range("c_prime_min", c_prime_min, 0.5, 1.0).in_range("c_prime_max", c_prime_max, 1.0, 2.0);
    v.throw_if_any();
  }
};

/// \brief Source policy: Tanaka 2018 eq. 63 (2D) and its 3D form. Marker type for scenes
/// (`using source = mpskit::ppe::det_f;`); the numbers live in det_f_params.
struct det_f final {
  using params_type = det_f_params;
  det_f() = default;
  explicit det_f(const det_f_params& p) : p_(p) { p_.validate(); }
  const det_f_params& params() const { return p_; }  ///< the numbers

  /// c′ of eq. 62 from the packing ratio c^k: 1 inside [c_min, c_max]; below, max(c − c_min + 1, c′_min) < 1;
  /// above, min(c − c_max + 1, c′_max) > 1. With eq. 61 (det F = V^{k+1}/V^k = c^k/c^{k+1}) a sparse region
  /// (c < c_min) is compressed and a crowded one (c > c_max) expanded, by at most 0.1 % per step with the
  /// defaults.
  double volume_ratio(double c) const {
    if (c < p_.c_min) return std::max(c - p_.c_min + 1.0, p_.c_prime_min);
    if (c > p_.c_max) return std::min(c - p_.c_max + 1.0, p_.c_prime_max);
    return 1.0;
  }

  /// Cofactor matrix of A (cof(A)_ab = (−1)^{a+b} minor_ab).
  template <int D>
  static mat<D> cofactor(const mat<D>& A) {
    mat<D> C;
    if constexpr (D == 2) {
      C << A(1, 1), -A(1, 0), -A(0, 1), A(0, 0);
    } else {
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          const int a1 = (a + 1) % 3, a2 = (a + 2) % 3, b1 = (b + 1) % 3, b2 = (b + 2) % 3;
          C(a, b) = A(a1, b1) * A(a2, b2) - A(a1, b2) * A(a2, b1);  // cyclic form carries the sign
        }
    }
    return C;
  }

  /// The row's combination of D_x: (1/ρ) Σ_ab sym(cof A)_ab ∂_a∂_b (left side of eq. 63).
  template <class Op, int D>
    requires SecondDerivativeOperator<Op>
  static typename Op::vector selector(const mat<D>& A, double rho) {
    const mat<D> C = cofactor<D>(A);
    typename Op::vector s = Op::vector::Zero();
    for (int a = 0; a < D; ++a)
      for (int b = a; b < D; ++b) {
        int e[3] = {0, 0, 0};
        ++e[a];
        ++e[b];
        const int k = Op::derivative_index(e[0], e[1], e[2]);
        // ∂_a∂_b = ∂_b∂_a: the pair (a, b) and (b, a) share one entry of D_x.
        s[k] += (a == b ? C(a, a) : C(a, b) + C(b, a)) / rho;
      }
    return s;
  }

  /// det A of a 2×2 or 3×3 matrix (explicit: no LU module needed).
  template <int D>
  static double determinant(const mat<D>& A) {
    if constexpr (D == 2) return A(0, 0) * A(1, 1) - A(0, 1) * A(1, 0);
    else
      return A(0, 0) * (A(1, 1) * A(2, 2) - A(1, 2) * A(2, 1)) -
             A(0, 1) * (A(1, 0) * A(2, 2) - A(1, 2) * A(2, 0)) +
             A(0, 2) * (A(1, 0) * A(2, 1) - A(1, 1) * A(2, 0));
  }

  /// Right-hand side (det A − c′)/Δt² (eq. 63).
  template <int D>
  double rhs(const mat<D>& A, double c, double dt) const {
    return (determinant<D>(A) - volume_ratio(c)) / (dt * dt);
  }

 private:
  det_f_params p_{};
};

}  // namespace mpskit::ppe
