#pragma once
/// \file op/lsmps_params.hpp
/// \brief Numbers and options shared by LSMPS type A and type B (Tanaka 2018 §4.1–4.2, eqs. 27–29, 41–52,
/// 85–87; Tamai & Koshizuka 2014), and the Neumann-constraint description.
#include <cstdint>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::op {

/// What a degenerate neighbourhood falls back to (docs/operators.md "Degenerate neighbourhoods").
enum class degenerate_fallback : std::uint8_t {
  lower_order,  ///< the highest lower order whose moment block passes; if none, regularised lowest order
  regularise,   ///< the full order with M + δ I, δ = regularisation · max_k M_kk
};

/// Reading of Tanaka eqs. 86–87 (the Neumann constraint), docs/operators.md "Neumann constraint".
enum class neumann_form : std::uint8_t {
  derivative,  ///< constraint row ∂p/∂(−n)(0): the linear entries of p(−n), higher entries 0 (exact on
               ///< polynomials)
  literal,  ///< p(−n_i) as printed: a virtual neighbour at x_i − L_i n_i valued f_i − L_i ∂f/∂n (O(L²) error)
};

/// Numbers of LSMPS operators.
struct lsmps_params {
  double re_ratio = 3.1;  ///< R_i = re_ratio · L_i (Tanaka eq. 27, R_e = 3.1)
  search::radius_rule rule = search::radius_rule::pair_mean;  ///< pair radius (Tanaka eq. 28: pair mean)
  /// Degenerate test: the moment matrix fails when an LDLᵀ pivot is singular to working precision or when
  /// cond₁(M) = ‖M‖₁‖M⁻¹‖₁ > max_condition (derivative rounding grows like cond · 1e-15, docs/operators.md).
  double max_condition = 1e8;
  degenerate_fallback fallback = degenerate_fallback::lower_order;  ///< what a failed test falls back to
  double regularisation = 1e-6;  ///< δ / max_k M_kk of the regularised fallback
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("lsmps_params");
    v.positive("re_ratio", re_ratio).in_range("max_condition", max_condition, 1.0, 1e15);
    v.in_open_range("regularisation", regularisation, 0.0, 1.0);
    v.throw_if_any();
  }
};

/// Particles carrying the Neumann constraint of Tanaka eqs. 85–87 (type A only).
template <int D>
struct neumann_constraint {
  const points<D>* normal = nullptr;  ///< unit normals n_i (wall particles: towards the fluid, Tanaka §4.1)
  const std::vector<std::uint8_t>* constrained = nullptr;  ///< nonzero entry: particle i is constrained
  neumann_form form = neumann_form::derivative;            ///< reading of eqs. 86–87
};

/// Neighbours that enter every fit of a particle as Neumann data instead of values (wall points): a marked
/// neighbour j contributes the equation L_i n_j·∇φ(x_j) = L_i q_j to the least squares of particle i
/// (type A only; our reading of a Neumann wall in LSMPS without wall unknowns, docs/lsmps_scheme.md).
template <int D>
struct neumann_points {
  const points<D>* normal = nullptr;                 ///< n_j of marked neighbours (toward the fluid)
  const std::vector<std::uint8_t>* mark = nullptr;   ///< nonzero entry: j is a Neumann point
  const Eigen::VectorXd* dfdn = nullptr;             ///< q_j = ∂φ/∂n at j (read when rows or values are made)
};

}  // namespace mpskit::op
