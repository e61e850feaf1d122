#pragma once
/// \file ppe/eigen_iterative.hpp
/// \brief Eigen's iterative solvers behind one API: CG (Jacobi or incomplete Cholesky), BiCGSTAB (Jacobi,
/// ILUT or our ILU(0), ppe/ilu0.hpp), GMRES and IDR(s) from the unsupported module. Each solve starts from
/// the given x (warm start) and reports iterations and relative residual; non-convergence is returned, not
/// hidden.
#include <cmath>
#include <type_traits>
#include <vector>

#include <Eigen/IterativeLinearSolvers>
#include <unsupported/Eigen/IterativeSolvers>

#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/ilu0.hpp"
#include "mpskit/ppe/ilut.hpp"
#include "mpskit/ppe/interleaved_product.hpp"

namespace mpskit::ppe {

/// Stopping rule and restart of the iterative solvers.
struct solver_params {
  double tolerance = 1e-8;   ///< relative residual |A x − b| / |b| to reach
  long max_iterations = 2000;  ///< iteration cap (non-convergence is an error of the scheme)
  long restart = 50;         ///< GMRES restart length (set explicitly; Eigen's default is 30)
  long idrs_s = 4;           ///< IDR(s) shadow-space dimension
  /// ILUT (bicgstab, gmres; bicgstab_ilu0 has no fill and ignores both): Eigen's rule (ppe/ilut.hpp) drops
  /// multipliers at or below ilut_drop_tolerance and U entries at or below it × the row norm. Each row keeps
  /// about half of ilut_fill_factor × A's average row count in L and as many in U. Eigen's defaults (1e-12,
  /// 10) make ILUT a near exact LU: on the LSMPS PPE (≈ 30 entries per row) the factorisation took 81 % of a
  /// Taylor–Green step.
  double ilut_drop_tolerance = 1e-4;
  int ilut_fill_factor = 2;
  /// Incomplete LU (ILUT of bicgstab and gmres, ILU(0) of bicgstab_ilu0) kept for up to this many solves when
  /// the caller says the unknowns are the same particles in the same order as at the factorisation (1:
  /// factorised at every solve). The solve still runs to `tolerance` on the current matrix, so a lagged
  /// factorisation changes iterations, not what is accepted; a lagged solve that fails is repeated once with
  /// a fresh factorisation. Ours (a standard lagged-preconditioner device, not in the papers);
  /// docs/lsmps_scheme.md (deviation 7) has the measured trade.
  int ilut_reuse = 4;
  /// Keep the lagged ILUT or ILU(0) factors also when the unknowns changed (splits, merges, inflow, outflow,
  /// reordering, copies made or dropped), as long as at most `ilut_reuse_unmatched` of the current unknowns
  /// have no row in the factorised system: the preconditioner then scatters the residual to the factorised
  /// system's rows (by particle identity, given by the stepper), applies the kept factors and gathers back,
  /// with a Jacobi step on the unmatched unknowns. Off by default (ours; docs/lsmps_scheme.md deviation 7).
  bool ilut_reuse_across_changes = false;
  /// largest fraction of unmatched unknowns for which the factors are kept
  double ilut_reuse_unmatched = 0.1;
  /// A solve whose iterate is not finite (a Krylov breakdown) is restarted once from x = 0 with a fresh
  /// budget of max_iterations (since 2026-12-06; before, the iterations left), unless it started from 0; on
  /// lagged factors only the fresh-factor retry restarts (ours; docs/run.md, "Krylov breakdowns"). Only
  /// solves that would otherwise fail (or, lagged, be retried) are affected.
  bool breakdown_restart = true;
  /// A warm-started solve that does not converge (Eigen::NoConvergence: the iteration cap reached, or a true
  /// residual above 10× the tolerance; not a breakdown, nor IDR(s)'s own breakdown exit) is repeated once
  /// from x = 0 with a fresh budget of max_iterations; the report gives both attempts' iterations. On lagged
  /// factors only the fresh-factor retry restarts. Ours (docs/run.md, "Cold restarts"): only solves that
  /// would otherwise fail (or, lagged, be retried; with ppe::with_fallback, go to the fallback) are affected.
  /// Measured: the 1 mm dam-break PPE (19 117 unknowns) that BiCGSTAB-Jacobi left at 3.9e-6 after 2000
  /// iterations from the warm start converged in 219 from 0.
  bool cold_restart = true;
  /// Systems of fewer unknowns are solved with Eigen's own threads held to one (its sparse × vector product
  /// would otherwise open a parallel region per product; core/exec.hpp, eigen_threads_scope). The default is
  /// exec::par's threshold: on a 2-core machine it is 2.66× faster with one competing thread and the same
  /// when idle (docs/solver.md, deviation 7); 0 lets Eigen thread every system.
  index_t parallel_min_rows = parallel_min_items;
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("solver_params");
    v.in_open_range("tolerance", tolerance, 0.0, 1.0)
        .in_range("max_iterations", double(max_iterations), 1, 1e9);
    v.in_range("restart", double(restart), 1, 1e6).in_range("idrs_s", double(idrs_s), 1, 64);
    v.in_range("ilut_drop_tolerance", ilut_drop_tolerance, 0.0, 1.0)
        .in_range("ilut_fill_factor", ilut_fill_factor, 1, 100);
    v.in_range("ilut_reuse", ilut_reuse, 1, 1000)
        .in_range("parallel_min_rows", double(parallel_min_rows), 0, 1e18);
    v.in_range("ilut_reuse_unmatched", ilut_reuse_unmatched, 0.0, 1.0);
    v.throw_if_any();
  }
};

namespace detail {
/// An Eigen preconditioner P whose compute() can be skipped: with refactor(false) the next compute keeps the
/// factors of an earlier matrix (Eigen's IterativeSolverBase::compute always calls the preconditioner's).
template <class P>
class lagged_preconditioner {
 public:
  lagged_preconditioner() = default;
  template <class M>
  explicit lagged_preconditioner(const M& A) {
    compute(A);
  }
  template <class M>
  lagged_preconditioner& analyzePattern(const M& A) {
    if (refactor_) p_.analyzePattern(A);
    return *this;
  }
  template <class M>
  lagged_preconditioner& factorize(const M& A) {
    if (refactor_) p_.factorize(A);
    return *this;
  }
  template <class M>
  lagged_preconditioner& compute(const M& A) {
    if (refactor_) p_.compute(A);
    return *this;
  }
  /// z = M⁻¹ b: the factors' solve; with a map (kept factors of another unknown set), b scattered to the
  /// factorised rows (unmatched rows dropped), solved, and gathered back; unmatched unknowns get b_r / a_rr.
  /// The result is a buffer kept between calls (valid until the next call): no allocation per application.
  template <class R>
  const Eigen::VectorXd& solve(const R& b) const {
    if (map_.empty()) {
      // A factor solve that returns its own buffer (incomplete_lu0) is passed on; an expression (ILUT) is
      // evaluated into z_.
      if constexpr (std::is_lvalue_reference_v<decltype(p_.solve(b))>) {
        return p_.solve(b);
      } else {
        z_ = p_.solve(b);
        return z_;
      }
    }
    bf_.setZero(factor_rows_);  // buffers kept between the solver's calls (two per BiCGSTAB iteration)
    for (std::size_t r = 0; r < map_.size(); ++r)
      if (map_[r] >= 0) bf_[map_[r]] = b[static_cast<Eigen::Index>(r)];
    zf_ = p_.solve(bf_);
    z_.resize(b.size());
    for (std::size_t r = 0; r < map_.size(); ++r) {
      const auto e = static_cast<Eigen::Index>(r);
      z_[e] = map_[r] >= 0 ? zf_[map_[r]] : b[e] * inv_diag_[e];
    }
    return z_;
  }
  /// Sets the map from the current unknowns to the factorised rows (−1: unmatched, with 1/a_rr in inv_diag);
  /// an empty map: the current unknowns are the factorised ones.
  void set_map(std::vector<index_t> map, Eigen::VectorXd inv_diag, index_t factor_rows) {
    map_ = std::move(map);
    inv_diag_ = std::move(inv_diag);
    factor_rows_ = factor_rows;
  }
  Eigen::ComputationInfo info() const { return p_.info(); }
  void setDroptol(double d)
    requires requires(P& q) { q.setDroptol(1.0); }
  {
    p_.setDroptol(d);
  }
  void setFillfactor(int f)
    requires requires(P& q) { q.setFillfactor(1); }
  {
    p_.setFillfactor(f);
  }
  void refactor(bool on) { refactor_ = on; }  ///< whether the next compute factorises
  bool refactoring() const { return refactor_; }

 private:
  P p_;
  bool refactor_ = true;
  std::vector<index_t> map_;
  Eigen::VectorXd inv_diag_;
  index_t factor_rows_ = 0;
  mutable Eigen::VectorXd bf_, zf_;  // scatter and factor-solve buffers of the mapped solve
  mutable Eigen::VectorXd z_;        // solve()'s result, returned by reference (valid until the next call)
};

template <class EigenSolver, bool Symmetric>
class eigen_iterative {
 public:
  static constexpr bool requires_symmetric = Symmetric;
  using solver_type = EigenSolver;  ///< the Eigen solver behind it
  eigen_iterative() = default;
  explicit eigen_iterative(const solver_params& p) : p_(p) { p_.validate(); }
  const solver_params& params() const { return p_; }           ///< stopping rule
  void set_params(const solver_params& p) { p.validate(); p_ = p; }  ///< change the stopping rule
  /// Factorises / analyses A (A must outlive the following solves).
  Eigen::ComputationInfo compute(const matrix& A) { return prepare(A, false); }
  /// As compute(A); when same_unknowns (the rows and columns are the same particles in the same order as at
  /// the last factorisation) an ILUT or ILU(0) preconditioner is kept for up to solver_params::ilut_reuse
  /// solves.
  Eigen::ComputationInfo compute(const matrix& A, bool same_unknowns) {
    return prepare(A,
                   lagging && same_unknowns && A.rows() == rows_ && since_ + 1 < p_.ilut_reuse && factored_);
  }
  /// As compute(A); `to_previous[r]` is the row of unknown r in the previous system (−1: none). With
  /// solver_params::ilut_reuse_across_changes the ILUT or ILU(0) factors are kept (for up to ilut_reuse
  /// solves in all) when at most ilut_reuse_unmatched of the unknowns have no row in the factorised system
  /// (maps are composed over the lagged solves); otherwise, and without the option, A is factorised.
  Eigen::ComputationInfo compute(const matrix& A, const std::vector<index_t>& to_previous) {
    if constexpr (lagging) {
      if (p_.ilut_reuse_across_changes && factored_ && since_ + 1 < p_.ilut_reuse &&
          static_cast<index_t>(to_previous.size()) == A.rows()) {
        std::vector<index_t> to_factor(to_previous.size(), -1);
        index_t unmatched = 0;
        for (std::size_t r = 0; r < to_previous.size(); ++r) {
          const index_t q = to_previous[r];
          if (q >= 0 && q < rows_)
            to_factor[r] = to_factor_.empty() ? q : to_factor_[static_cast<std::size_t>(q)];
          if (to_factor[r] < 0) ++unmatched;
        }
        if (static_cast<double>(unmatched) <= p_.ilut_reuse_unmatched * static_cast<double>(A.rows())) {
          Eigen::VectorXd inv_diag = Eigen::VectorXd::Zero(A.rows());
          for (std::size_t r = 0; r < to_factor.size(); ++r)
            if (to_factor[r] < 0) {
              const double d = A.coeff(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(r));
              // a preconditioner value only (the solution is not touched): a zero diagonal gets the identity
              inv_diag[static_cast<Eigen::Index>(r)] = d != 0.0 ? 1.0 / d : 1.0;
            }
          s_.preconditioner().set_map(to_factor, std::move(inv_diag), factor_rows_);
          to_factor_ = std::move(to_factor);
          ++mapped_;
          return prepare(A, true);
        }
      }
    }
    return prepare(A, false);
  }
  /// Solves A x = b starting from x; reports iterations and the true relative residual. After a lagged
  /// factorisation that fails, the solve is repeated once from the same start with fresh factors; the
  /// iterations reported are then both attempts' (the fresh-factor attempt's include a restart's from 0 after
  /// a breakdown or a non-convergence, solver_params::breakdown_restart and cold_restart, each with a fresh
  /// budget of max_iterations, so the sum can reach 3 × max_iterations).
  solve_report solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    const Eigen::VectorXd x0 = lagged_ ? x : Eigen::VectorXd();
    // On lagged factors a breakdown goes to the fresh-factor retry (as before breakdown_restart existed), and
    // only that retry may restart from 0.
    solve_report r = solve_once(b, x, !lagged_);
    if (r.info != Eigen::Success && lagged_) {  // a lagged factorisation failed: once more with a fresh one
      ++relagged_;
      const long first = r.iterations;
      x = x0;
      if (prepare(*A_, false) != Eigen::Success) {
        r.info = Eigen::NumericalIssue;  // the fresh factorisation itself failed
        return r;
      }
      r = solve_once(b, x, true);
      r.iterations += first;
      r.lagged_retry = true;
    }
    return r;
  }
  /// lagged solves repeated with fresh factors
  long refactorised_after_failure() const { return relagged_; }
  long factorisations() const { return factorisations_; }  ///< ILUT or ILU(0) factorisations so far
  /// solves with factors kept across a change of the unknowns
  long mapped_reuses() const { return mapped_; }
  long breakdown_restarts() const { return breakdowns_; }  ///< solves restarted from 0 after a breakdown
  long cold_restarts() const { return colds_; }  ///< warm-started solves repeated from 0 after not converging

 private:
  static constexpr bool lagging = requires(EigenSolver& e) { e.preconditioner().refactor(true); };
  /// The solver multiplies through interleaved_operator (ppe/interleaved_product.hpp).
  static constexpr bool interleaved = std::is_same_v<typename EigenSolver::MatrixType, interleaved_operator>;

  /// Sets the solver up for A; keep: the ILUT or ILU(0) factors of the last factorisation are kept.
  Eigen::ComputationInfo prepare(const matrix& A, bool keep) {
    s_.setTolerance(p_.tolerance);
    s_.setMaxIterations(p_.max_iterations);
    if constexpr (requires { s_.set_restart(1); }) s_.set_restart(p_.restart);
    if constexpr (requires { s_.setS(1); }) s_.setS(p_.idrs_s);
    if constexpr (requires { s_.preconditioner().setDroptol(1.0); }) {
      s_.preconditioner().setDroptol(p_.ilut_drop_tolerance);
      s_.preconditioner().setFillfactor(p_.ilut_fill_factor);
    }
    if constexpr (lagging) s_.preconditioner().refactor(!keep);
    if constexpr (interleaved) {
      op_ = interleaved_operator(A);  // the solver keeps a pointer to op_, op_ one to A
      s_.compute(op_);
    } else {
      s_.compute(A);
    }
    A_ = &A;
    Eigen::ComputationInfo info = s_.info();
    if constexpr (lagging) {
      s_.preconditioner().refactor(true);
      if (keep) {
        ++since_;
      } else {
        ++factorisations_;
        since_ = 0;
        factored_ = info == Eigen::Success;
        factor_rows_ = A.rows();
        to_factor_.clear();  // the unknowns are the factorised ones
        s_.preconditioner().set_map({}, Eigen::VectorXd(), 0);
      }
    }
    lagged_ = keep;
    rows_ = A.rows();
    return info;
  }

  /// The solve from x = 0 that both restarts run (a fresh budget, its residual replacement and
  /// classification, no further restart of either kind); r becomes its report with the earlier attempt's
  /// iterations added.
  void again_from_zero(const Eigen::VectorXd& b, Eigen::VectorXd& x, solve_report& r) {
    const long first = r.iterations;
    x.setZero();
    r = solve_once(b, x, false);
    r.iterations += first;
  }

  /// One solve from x; restart: a breakdown may be restarted from 0 (solver_params::breakdown_restart).
  solve_report solve_once(const Eigen::VectorXd& b, Eigen::VectorXd& x, bool restart) {
    solve_report r;
    const double bn = b.norm();
    if (bn == 0.0) {  // the exact solution is 0: no iteration
      x.setZero();
      return r;
    }
    const bool from_zero = x.isZero(0.0);  // a restart from 0 would repeat this solve
    x = s_.solveWithGuess(b, x);
    r.info = s_.info();
    r.iterations = s_.iterations();
    r.residual = (*A_ * x - b).norm() / bn;
    // A Krylov breakdown (the iterate not finite: BiCGSTAB's α = ρ/(r̂₀·v), or β after ω = 0, divided by zero
    // or so nearly that the iterate overflowed) is restarted once from x = 0, which changes the shadow
    // residual r̂₀ = b − A x₀ the breakdown depends on (solver_params::breakdown_restart; ours, docs/run.md).
    // The restart is the solve from 0 (a fresh budget of max_iterations, its residual replacement and
    // classification), as the cold restart below is; since 2026-12-06 — before, it had the iterations left,
    // so a late breakdown failed for want of iterations (a restart that converged within them computes the
    // same iterate either way). A near-breakdown that leaves a finite iterate is not caught here (it is a
    // non-convergence), nor are IDR(s)'s own breakdown exits (finite iterate, NumericalIssue). Measured: a
    // 1.5 mm dam-break PPE (8912 unknowns) broke down after 280 BiCGSTAB-Jacobi iterations from the warm
    // start and converged in 250 from 0 (docs/lsmps_scheme.md, "The 1.5 mm breakdown").
    if (restart && p_.breakdown_restart && !from_zero && (!x.allFinite() || !std::isfinite(r.residual)) &&
        b.allFinite()) {
      ++breakdowns_;
      again_from_zero(b, x, r);
      r.breakdown_restart = true;
      return r;
    }
    // (A breakdown inside the residual replacement below is not restarted: it fails the solve.)
    // Solvers test their own residual estimates (IDR(s), GMRES and BiCGSTAB drift from the true one). When
    // the estimate claims success but the true residual is above 10× the tolerance, the solve is restarted
    // from its iterate (the residual recomputed exactly: "residual replacement"), at most 3 times within the
    // iteration cap. Measured: the left-null-vector solve of a periodic channel with walls (BiCGSTAB-Jacobi)
    // stopped after 38 iterations at a true residual of 1.6e-7 against 1e-8 (docs/channel.md).
    for (int k = 0; k < 3 && r.info == Eigen::Success && r.residual > 10.0 * p_.tolerance &&
                    r.iterations < p_.max_iterations;
         ++k) {
      s_.setMaxIterations(p_.max_iterations - r.iterations);
      x = s_.solveWithGuess(b, x);
      r.info = s_.info();
      r.iterations += s_.iterations();
      r.residual = (*A_ * x - b).norm() / bn;
      s_.setMaxIterations(p_.max_iterations);
    }
    // A true residual still more than 10× the tolerance is reported as non-convergence.
    if (r.info == Eigen::Success && r.residual > 10.0 * p_.tolerance) r.info = Eigen::NoConvergence;
    // Not finite: a breakdown, or a non-finite b (Eigen's solvers then stop at once and report success)
    if (!x.allFinite() || !std::isfinite(r.residual)) r.info = Eigen::NumericalIssue;
    // A warm-started solve that did not converge is repeated once from x = 0 with a fresh iteration budget
    // (solver_params::cold_restart; ours, docs/run.md "Cold restarts"): BiCGSTAB from a warm start can
    // stagnate where the same system converges from 0. (A breakdown's restart, above, already ran from 0 and
    // returned.)
    if (restart && p_.cold_restart && !from_zero && r.info == Eigen::NoConvergence) {
      ++colds_;
      again_from_zero(b, x, r);
      r.cold_restart = true;
    }
    return r;
  }

  solver_params p_{};
  EigenSolver s_;
  interleaved_operator op_;  // the operator the solver holds when `interleaved`
  const matrix* A_ = nullptr;
  index_t rows_ = -1;     // size at the last compute
  long since_ = 0;        // solves since the last factorisation
  bool factored_ = false;  // the last factorisation succeeded
  bool lagged_ = false;    // the current solve uses kept factors
  long relagged_ = 0, factorisations_ = 0, mapped_ = 0, breakdowns_ = 0, colds_ = 0;
  index_t factor_rows_ = 0;        // rows of the factorised system
  std::vector<index_t> to_factor_;  // current unknown → factorised row (empty: the same unknowns)
};
}  // namespace detail

/// CG with Jacobi preconditioning (symmetric positive definite systems only).
using cg_jacobi = detail::eigen_iterative<
    Eigen::ConjugateGradient<matrix, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<double>>,
    true>;
/// CG with incomplete Cholesky in natural order (symmetric positive definite systems only; natural
/// order because states are kept in cell order, and Eigen 3.4's AMD was seen to stall on PPE patterns).
using cg_ichol = detail::eigen_iterative<
    Eigen::ConjugateGradient<
        matrix, Eigen::Lower | Eigen::Upper,
        Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::NaturalOrdering<std::ptrdiff_t>>>,
    true>;
/// The BiCGSTAB solvers multiply through detail::interleaved_operator: Eigen's products' bits (without FMA
/// contraction) in less time (ppe/interleaved_product.hpp); P, the preconditioner, is built on the sparse
/// matrix.
namespace detail {
template <class P>
using bicgstab_interleaved = Eigen::BiCGSTAB<interleaved_operator, on_sparse<P>>;
}  // namespace detail
/// BiCGSTAB with incomplete LU (any non-singular system): Eigen's ILUT, factorised faster with the same bits
/// (ppe/ilut.hpp).
using bicgstab = detail::eigen_iterative<
    detail::bicgstab_interleaved<detail::lagged_preconditioner<incomplete_lut>>, false>;
/// BiCGSTAB with Jacobi preconditioning (any non-singular system; no factorisation cost).
using bicgstab_jacobi =
    detail::eigen_iterative<detail::bicgstab_interleaved<Eigen::DiagonalPreconditioner<double>>, false>;
/// BiCGSTAB with ILU(0) (ppe/ilu0.hpp: no fill; any non-singular system whose elimination on A's pattern
/// meets no zero pivot: a zero pivot fails compute, where ILUT replaces it). Lagged as ILUT
/// (solver_params::ilut_reuse, ilut_reuse_across_changes); ilut_drop_tolerance and ilut_fill_factor do not
/// apply.
using bicgstab_ilu0 =
    detail::eigen_iterative<detail::bicgstab_interleaved<detail::lagged_preconditioner<incomplete_lu0>>,
                            false>;
/// Restarted GMRES with incomplete LU (restart set from solver_params::restart; ILUT as bicgstab's).
using gmres =
    detail::eigen_iterative<Eigen::GMRES<matrix, detail::lagged_preconditioner<incomplete_lut>>, false>;
/// IDR(s) with Jacobi preconditioning (s from solver_params::idrs_s).
using idrs = detail::eigen_iterative<Eigen::IDRS<matrix, Eigen::DiagonalPreconditioner<double>>, false>;

}  // namespace mpskit::ppe
