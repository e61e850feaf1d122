#pragma once
/// \file ppe/fallback.hpp
/// \brief ppe::with_fallback<Primary, Fallback>: a LinearSolver that solves with Primary (an iterative
/// solver) and, only when Primary fails (its preconditioner fails, it does not converge — also after its
/// restart from 0, solver_params::cold_restart — or its iterate is not finite, e.g. a BiCGSTAB breakdown that
/// its own restart from 0, solver_params::breakdown_restart, did not mend), solves the same system again with
/// Fallback (a direct solver: ppe::sparse_lu, ppe::umfpack). Counted: fallbacks() here,
/// solve_report::fallback per solve (both steppers sum it in counters().ppe_fallbacks). Ours, not in the
/// papers (docs/run.md, "A direct fallback").
///
/// The fallback is factorised only when it is needed, so a run in which Primary never fails costs one copy of
/// the warm start per solve. A singular system still fails (the fallback reports it): the fallback catches a
/// Krylov breakdown on a solvable system, not a badly posed one.
#include <Eigen/Core>
#include <vector>

#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"

namespace mpskit::ppe {

template <LinearSolver Primary, LinearSolver Fallback>
class with_fallback {
 public:
  static constexpr bool requires_symmetric = Primary::requires_symmetric || Fallback::requires_symmetric;
  with_fallback() = default;
  /// Both solvers take `p` (the direct one reads only the tolerance of its residual check).
  explicit with_fallback(const solver_params& p) : primary_(p), fallback_(p) {}
  const solver_params& params() const { return primary_.params(); }  ///< the primary's stopping rule
  void set_params(const solver_params& p) {  ///< sets both solvers' parameters
    primary_.set_params(p);
    fallback_.set_params(p);
  }
  Primary& primary() { return primary_; }
  Fallback& fallback() { return fallback_; }
  long fallbacks() const { return fallbacks_; }  ///< solves the fallback made, so far
  /// The primary's incomplete factorisations so far (ILUT, ILU(0):
  /// ppe::detail::eigen_iterative::factorisations); only for a primary that counts them. The fallback's
  /// direct factorisations are fallbacks().
  long factorisations() const
    requires requires(const Primary& s) { s.factorisations(); }
  {
    return primary_.factorisations();
  }

  /// Prepares the primary for A (A must outlive the following solves); a failure of the primary's
  /// preconditioner is not returned but sends the next solve to the fallback.
  Eigen::ComputationInfo compute(const matrix& A) { return prepared(A, primary_.compute(A)); }
  /// As compute(A), passing the stepper's same_unknowns to a primary that keeps factors (ppe::solve_checked).
  Eigen::ComputationInfo compute(const matrix& A, bool same_unknowns)
    requires requires(Primary& s) { s.compute(A, same_unknowns); }
  {
    return prepared(A, primary_.compute(A, same_unknowns));
  }
  /// As compute(A), passing the map to the previous unknowns to a primary that keeps factors across changes.
  Eigen::ComputationInfo compute(const matrix& A, const std::vector<index_t>& to_previous)
    requires requires(Primary& s) { s.compute(A, to_previous); }
  {
    return prepared(A, primary_.compute(A, to_previous));
  }

  /// Solves A x = b from x with the primary; when it fails, with the fallback (factorised now). The report is
  /// the primary's when it succeeded, otherwise the fallback's with fallback = true, the iterations of both
  /// and the primary's lagged_retry, breakdown_restart and cold_restart.
  solve_report solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    solve_report r;
    if (primary_ok_) {
      x0_ = x;
      r = primary_.solve(b, x);
      if (r.info == Eigen::Success) return r;
      x = x0_;
    }
    ++fallbacks_;
    solve_report f;
    if (fallback_.compute(*A_) != Eigen::Success) {
      f.info = Eigen::NumericalIssue;  // e.g. a singular matrix: SparseLU/UMFPACK find a zero pivot
      f.residual = r.residual;
    } else {
      f = fallback_.solve(b, x);
    }
    f.iterations += r.iterations;
    f.lagged_retry = r.lagged_retry;
    f.breakdown_restart = r.breakdown_restart;
    f.cold_restart = r.cold_restart;
    f.fallback = true;
    return f;
  }

 private:
  Eigen::ComputationInfo prepared(const matrix& A, Eigen::ComputationInfo primary) {
    A_ = &A;
    primary_ok_ = primary == Eigen::Success;
    return Eigen::Success;
  }
  Primary primary_;
  Fallback fallback_;
  const matrix* A_ = nullptr;
  bool primary_ok_ = false;
  long fallbacks_ = 0;
  Eigen::VectorXd x0_;  // the warm start, kept for the fallback (a buffer: no allocation per solve)
};

}  // namespace mpskit::ppe
