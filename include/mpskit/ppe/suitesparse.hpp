#pragma once
/// \file ppe/suitesparse.hpp
/// \brief Direct PPE solvers from SuiteSparse behind the ppe::LinearSolver API: CHOLMOD's supernodal
/// Cholesky (symmetric positive definite PPE) and UMFPACK's LU (any non-singular PPE). The only header
/// that includes <Eigen/CholmodSupport> and <Eigen/UmfPackSupport>; usable only when linked to
/// mpskit::suitesparse (which defines MPSKIT_HAS_SUITESPARSE).
///
/// Licences: UMFPACK and CHOLMOD's Supernodal module are GPL (v2+); a binary linking them is GPL.
/// Reproducibility: CHOLMOD's supernodal factorisation calls BLAS/LAPACK (dsyrk, dgemm, dpotrf); with
/// a threaded BLAS (OpenBLAS, MKL) the results change in the last bits with the thread count, so runs
/// are then not bitwise reproducible. With the reference BLAS (Debian libblas3) they are.
#ifndef MPSKIT_HAS_SUITESPARSE
#error "mpskit: ppe/suitesparse.hpp needs SuiteSparse: link the CMake target mpskit::suitesparse"
#endif

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>
#include <Eigen/UmfPackSupport>
#include <memory>

#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"

namespace mpskit::ppe {

namespace detail {
/// Column-major copy of a PPE matrix with SuiteSparse's index type (CHOLMOD and UMFPACK read CSC).
using suitesparse_matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, SuiteSparse_long>;

/// A direct factorisation behind the LinearSolver API: compute() copies A to CSC and factorises;
/// solve() ignores the warm start, reports 0 iterations and the true relative residual, and reports
/// NumericalIssue when that residual exceeds solver_params::tolerance or x is not finite.
template <class EigenSolver, bool Symmetric>
class suitesparse_direct {
 public:
  static constexpr bool requires_symmetric = Symmetric;
  suitesparse_direct() : s_(std::make_unique<EigenSolver>()) {}
  /// Takes the stopping rule of the iterative solvers: only `tolerance` is read (the residual check).
  explicit suitesparse_direct(const solver_params& p) : p_(p), s_(std::make_unique<EigenSolver>()) { p_.validate(); }
  suitesparse_direct(const suitesparse_direct& o) : p_(o.p_), s_(std::make_unique<EigenSolver>()) {}  ///< copies the params only
  suitesparse_direct& operator=(const suitesparse_direct& o) {  ///< copies the params only
    p_ = o.p_;
    s_ = std::make_unique<EigenSolver>();
    A_ = nullptr;
    return *this;
  }
  suitesparse_direct(suitesparse_direct&&) noexcept = default;             ///< moves the factorisation
  suitesparse_direct& operator=(suitesparse_direct&&) noexcept = default;  ///< moves the factorisation
  ~suitesparse_direct() = default;

  const solver_params& params() const { return p_; }                   ///< residual tolerance
  void set_params(const solver_params& p) { p.validate(); p_ = p; }   ///< change the residual tolerance
  EigenSolver& native() { return *s_; }                                ///< the Eigen wrapper (CHOLMOD/UMFPACK settings)

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
      return r;
    }
    r.residual = (*A_ * x - b).norm() / bn;
    if (r.info == Eigen::Success && r.residual > p_.tolerance) r.info = Eigen::NumericalIssue;
    return r;
  }

 private:
  solver_params p_{};
  std::unique_ptr<EigenSolver> s_;  // Eigen's CHOLMOD/UMFPACK wrappers are neither copyable nor movable
  suitesparse_matrix csc_;
  const matrix* A_ = nullptr;
};
}  // namespace detail

/// CHOLMOD supernodal LLᵀ (symmetric positive definite PPE; GPL through CHOLMOD/Supernodal).
using cholmod = detail::suitesparse_direct<Eigen::CholmodSupernodalLLT<detail::suitesparse_matrix, Eigen::Lower>, true>;
/// UMFPACK LU (any non-singular PPE; GPL).
using umfpack = detail::suitesparse_direct<Eigen::UmfPackLU<detail::suitesparse_matrix>, false>;

static_assert(LinearSolver<cholmod>);
static_assert(LinearSolver<umfpack>);

}  // namespace mpskit::ppe
