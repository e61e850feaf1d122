#pragma once
/// \file ppe/direct.hpp
/// \brief A sparse direct factorisation behind the ppe::LinearSolver API (the shared part of ppe::sparse_lu,
/// ppe::umfpack and ppe::cholmod): compute() copies the CSR matrix to the factorisation's column-major type
/// and factorises; solve() ignores the warm start, reports 0 iterations and the true relative residual, and
/// reports NumericalIssue when that residual exceeds solver_params::tolerance or x is not finite.
#include <Eigen/SparseCore>
#include <limits>
#include <memory>

#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"

namespace mpskit::ppe::detail {

/// EigenSolver: an Eigen sparse direct solver over the column-major matrix type Csc (compute/solve/info).
template <class EigenSolver, class Csc, bool Symmetric>
class direct_solver {
 public:
  static constexpr bool requires_symmetric = Symmetric;
  direct_solver() : s_(std::make_unique<EigenSolver>()) {}
  /// Takes the stopping rule of the iterative solvers: only `tolerance` is read (the residual check).
  explicit direct_solver(const solver_params& p) : p_(p), s_(std::make_unique<EigenSolver>()) {
    p_.validate();
  }
  direct_solver(const direct_solver& o)
      : p_(o.p_), s_(std::make_unique<EigenSolver>()) {}  ///< copies the params only
  direct_solver& operator=(const direct_solver& o) {      ///< copies the params only
    p_ = o.p_;
    s_ = std::make_unique<EigenSolver>();
    A_ = nullptr;
    return *this;
  }
  direct_solver(direct_solver&&) noexcept = default;             ///< moves the factorisation
  direct_solver& operator=(direct_solver&&) noexcept = default;  ///< moves the factorisation
  ~direct_solver() = default;

  const solver_params& params() const { return p_; }                  ///< residual tolerance
  void set_params(const solver_params& p) { p.validate(); p_ = p; }  ///< change the residual tolerance
  EigenSolver& native() { return *s_; }                               ///< the Eigen solver (its own settings)

  /// Analyses and factorises A (a new symbolic analysis every call: the PPE pattern changes each step).
  /// A must outlive the following solves.
  Eigen::ComputationInfo compute(const matrix& A) {
    csc_ = A;  // CSR → CSC (a transpose copy; for the symmetric PPE the arrays are the same)
    s_->compute(csc_);
    A_ = &A;
    return s_->info();
  }
  /// Solves A x = b (x on entry is ignored).
  solve_report solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    solve_report r;
    const double bn = b.norm();
    if (bn == 0.0) {
      x.setZero(b.size());
      return r;
    }
    x = s_->solve(b);
    r.info = s_->info();
    r.iterations = 0;  // direct: no iteration
    if (!x.allFinite()) {
      r.info = Eigen::NumericalIssue;
      r.residual = std::numeric_limits<double>::quiet_NaN();
      return r;
    }
    r.residual = (*A_ * x - b).norm() / bn;
    if (r.info == Eigen::Success && r.residual > p_.tolerance) r.info = Eigen::NumericalIssue;
    return r;
  }

 private:
  solver_params p_{};
  std::unique_ptr<EigenSolver> s_;  // Eigen's direct solvers are neither copyable nor (all) movable
  Csc csc_;
  const matrix* A_ = nullptr;
};

}  // namespace mpskit::ppe::detail
