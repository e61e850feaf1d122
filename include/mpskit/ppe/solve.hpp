#pragma once
/// \file ppe/solve.hpp
/// \brief One checked PPE solve for every scheme: factorise, solve from the warm start, and turn a failed
/// preconditioner or a non-converged solve into mpskit::error naming the step, the time, the residual,
/// the stopping rule and the row with the largest residual (ARCHITECTURE.md §6).
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"

namespace mpskit::ppe {

/// Solves A x = b from the x given (warm start) with `solver`; `describe(r)` names row r in a message
/// (e.g. "particle 12 (id 40)"). same_unknowns: the rows and columns are the same particles in the same order
/// as at the previous solve (solvers with a lagged factorisation may then keep it,
/// solver_params::ilut_reuse); to_previous (optional, when not same_unknowns): the row of each unknown in the
/// previous solve's system (−1: none), for solvers that keep factors across such changes
/// (solver_params::ilut_reuse_across_changes). Returns the solver's report; throws on failure.
template <LinearSolver S, class Describe>
solve_report solve_checked(S& solver, const matrix& A, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                           const solver_params& p, long step, double t, const Describe& describe,
                           bool same_unknowns = false, const std::vector<index_t>* to_previous = nullptr) {
  const eigen_threads_scope threads(A.rows(), p.parallel_min_rows);  // small systems: Eigen on one thread
  Eigen::ComputationInfo info;
  if constexpr (requires { solver.compute(A, *to_previous); }) {
    if (to_previous && !same_unknowns) info = solver.compute(A, *to_previous);
    else info = solver.compute(A, same_unknowns);
  } else if constexpr (requires { solver.compute(A, same_unknowns); }) {
    info = solver.compute(A, same_unknowns);
  } else {
    info = solver.compute(A);
  }
  if (info != Eigen::Success)
    fail("PPE: the preconditioner failed at step ", step, ", t = ", t, " s (", A.rows(), " unknowns)");
  const solve_report rep = solver.solve(b, x);
  if (rep.info != Eigen::Success) {
    const std::string after =
        std::string(rep.breakdown_restart ? " (also after a restart from 0 following a breakdown)" : "") +
        (rep.cold_restart ? " (also after a restart from 0, solver_params::cold_restart)" : "") +
        (rep.fallback ? " (and the fallback solver failed too)" : "");
    const Eigen::VectorXd res = A * x - b;
    // A breakdown leaves a non-finite iterate or residual: name the first non-finite row, not a "largest
    // residual" (a NaN compares false with everything).
    for (Eigen::Index r = 0; r < x.size(); ++r)
      if (!std::isfinite(x[r]) || !std::isfinite(res[r]))
        fail("PPE: the solver broke down at step ", step, ", t = ", t,
             " s: non-finite solution or residual after ", rep.iterations, " iterations", after,
             ", first at ", std::string(describe(static_cast<index_t>(r))));
    index_t worst = 0;
    res.cwiseAbs().maxCoeff(&worst);
    fail("PPE: solver did not converge at step ", step, ", t = ", t, " s: relative residual ", rep.residual,
         " after ", rep.iterations, " iterations (tolerance ", p.tolerance, ", cap ", p.max_iterations, ")",
         after, "; largest residual at ", std::string(describe(worst)));
  }
  return rep;
}

}  // namespace mpskit::ppe
