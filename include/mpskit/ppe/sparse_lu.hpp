#pragma once
/// \file ppe/sparse_lu.hpp
/// \brief Eigen's supernodal sparse LU (COLAMD ordering) behind the ppe::LinearSolver API: a direct solver
/// for any non-singular PPE that needs no other library (MPL2, like the rest of Eigen). Slower than UMFPACK
/// on large systems (it calls no BLAS); its use here is the fallback of ppe::with_fallback, which
/// factorises only when the iterative solver failed. The only header that includes <Eigen/SparseLU>.
#include <Eigen/OrderingMethods>
#include <Eigen/SparseLU>

#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/direct.hpp"

namespace mpskit::ppe {

namespace detail {
/// Column-major copy of a PPE matrix (SparseLU reads CSC).
using sparse_lu_matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
}  // namespace detail

/// Eigen::SparseLU with COLAMD ordering (any non-singular PPE).
using sparse_lu = detail::direct_solver<Eigen::SparseLU<detail::sparse_lu_matrix, Eigen::COLAMDOrdering<int>>,
                                        detail::sparse_lu_matrix, false>;

static_assert(LinearSolver<sparse_lu>);

}  // namespace mpskit::ppe
