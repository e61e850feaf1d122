#pragma once
/// \file ppe/concepts.hpp
/// \brief Concepts of the PPE area: source terms and linear solvers (one API for every solver,
/// after Eigen's compute/solve/info).
#include <Eigen/SparseCore>
#include <concepts>

#include "mpskit/core/dimension.hpp"

namespace mpskit::ppe {

/// Row-major CSR matrix every assembly produces.
using matrix = Eigen::SparseMatrix<double, Eigen::RowMajor, std::ptrdiff_t>;

/// Per-row inputs a source term may read (computed by the scheme only when a source asks for them).
struct source_inputs {
  double rho = 0.0;         ///< density (kg/m³)
  double dt = 0.0;          ///< this step's Δt (s)
  double l0 = 0.0;          ///< particle spacing (m)
  double n0 = 0.0;          ///< reference number density (small radius)
  double n_temporary = 0.0; ///< n′: number density at the temporary positions x + Δt u′
  double n_current = 0.0;   ///< n^k: number density at the positions of the step start
  double divergence = 0.0;  ///< ∇·u′ (1/s)
};

/// A PPE source term: `S::rhs(in)` is b_i in ∇²p_i − (ρ α_c/Δt²) p_i = b_i (units Pa/m²); the flags
/// say which inputs the scheme must compute.
template <class S>
concept SourceTerm = requires(const S& s, const source_inputs& in) {
  { s.rhs(in) } -> std::convertible_to<double>;
  { S::needs_divergence } -> std::convertible_to<bool>;
  { S::needs_current_density } -> std::convertible_to<bool>;
  s.validate();
};

/// What a linear solve did.
struct solve_report {
  Eigen::ComputationInfo info = Eigen::Success;  ///< Success, NoConvergence or NumericalIssue
  long iterations = 0;                           ///< iterations used
  double residual = 0.0;                         ///< relative residual |A x − b| / |b| reached
  /// a solve on lagged factors failed and was repeated with fresh ones (eigen_iterative)
  bool lagged_retry = false;
  /// the iterate was not finite and the solve was restarted from 0 (eigen_iterative)
  bool breakdown_restart = false;
  /// the warm-started solve did not converge and was repeated from 0 (eigen_iterative)
  bool cold_restart = false;
  /// the primary solver failed and the fallback solver made this solve (ppe::with_fallback)
  bool fallback = false;
};

/// A linear solver over `matrix`: `compute(A)` then `solve(b, x)` with x the warm start on entry.
template <class S>
concept LinearSolver = requires(S& s, const matrix& A, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  { S::requires_symmetric } -> std::convertible_to<bool>;
  { s.compute(A) } -> std::same_as<Eigen::ComputationInfo>;
  { s.solve(b, x) } -> std::same_as<solve_report>;
};

}  // namespace mpskit::ppe
