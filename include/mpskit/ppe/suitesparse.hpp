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

#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/direct.hpp"

namespace mpskit::ppe {

namespace detail {
/// Column-major copy of a PPE matrix with SuiteSparse's index type (CHOLMOD and UMFPACK read CSC).
using suitesparse_matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, SuiteSparse_long>;
}  // namespace detail

/// CHOLMOD supernodal LLᵀ (symmetric positive definite PPE; GPL through CHOLMOD/Supernodal).
using cholmod = detail::direct_solver<Eigen::CholmodSupernodalLLT<detail::suitesparse_matrix, Eigen::Lower>,
                                     detail::suitesparse_matrix, true>;
/// UMFPACK LU (any non-singular PPE; GPL).
using umfpack =
    detail::direct_solver<Eigen::UmfPackLU<detail::suitesparse_matrix>, detail::suitesparse_matrix, false>;

static_assert(LinearSolver<cholmod>);
static_assert(LinearSolver<umfpack>);

}  // namespace mpskit::ppe
