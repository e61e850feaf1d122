#pragma once
/// \file ppe/interleaved_product.hpp
/// \brief The PPE matrix's product with a vector, four rows at a time, for the BiCGSTAB solvers
/// (ppe/eigen_iterative.hpp): the same arithmetic as Eigen's row-major sparse × dense product, so the same bits,
/// in about 0.7× its time.
///
/// Eigen sums each row in one chain, `tmp += a_ik x_k` in storage order, and finishes the rows one after the
/// other: each addition waits for the one before it. Here four rows are summed side by side, each in its own
/// chain and in the same order, so the processor overlaps four chains. Each row's sum is Eigen's (the same
/// operations in the same order; no reassociation), and y_i += α tmp_i as Eigen does, so the result is the same to
/// the bit (test "the interleaved product gives Eigen's bits", label solver). Measured: 0.55–0.84× Eigen's time
/// on systems of 1200–5000 rows with 25–46 entries per row (docs/performance.md, "The interleaved sparse product").
/// Ours: an implementation device, not a method of the papers.
#include <algorithm>
#include <cstddef>

#include <Eigen/SparseCore>

#include "mpskit/core/error.hpp"
#include "mpskit/ppe/concepts.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace mpskit::ppe::detail {
class interleaved_operator;
}
namespace Eigen::internal {
template <>  // the operator's traits are the matrix's (declared before the operator: EigenBase reads them)
struct traits<mpskit::ppe::detail::interleaved_operator> : public traits<mpskit::ppe::matrix> {};
}  // namespace Eigen::internal

namespace mpskit::ppe {

/// y += α A x for the row-major PPE matrix A (compressed, as every assembly leaves it). Rows in blocks of four,
/// each summed in storage order from 0 (Eigen's arithmetic, above). With more than one Eigen thread
/// (Eigen::nbThreads(), which core/exec.hpp's eigen_threads_scope holds to one for small systems) and more than
/// 20 000 entries, the blocks are shared among the threads, Eigen's own rule; each row is one thread's, so the
/// result does not depend on the thread count.
inline void add_product(const matrix& A, const double* x, double* y, double alpha) {
  MPSKIT_ASSERT(A.isCompressed());  // every assembly leaves it compressed
  const std::ptrdiff_t n = A.rows();
  const std::ptrdiff_t* op = A.outerIndexPtr();
  const std::ptrdiff_t* ix = A.innerIndexPtr();
  const double* va = A.valuePtr();
  const std::ptrdiff_t blocks = n / 4;
  const auto block = [&](std::ptrdiff_t b) {
    const std::ptrdiff_t i = 4 * b;
    const std::ptrdiff_t r0 = op[i], r1 = op[i + 1], r2 = op[i + 2], r3 = op[i + 3], r4 = op[i + 4];
    const std::ptrdiff_t common = std::min(std::min(r1 - r0, r2 - r1), std::min(r3 - r2, r4 - r3));
    double t0 = 0.0, t1 = 0.0, t2 = 0.0, t3 = 0.0;
    for (std::ptrdiff_t k = 0; k < common; ++k) {  // four independent chains
      t0 += va[r0 + k] * x[ix[r0 + k]];
      t1 += va[r1 + k] * x[ix[r1 + k]];
      t2 += va[r2 + k] * x[ix[r2 + k]];
      t3 += va[r3 + k] * x[ix[r3 + k]];
    }
    for (std::ptrdiff_t k = r0 + common; k < r1; ++k) t0 += va[k] * x[ix[k]];  // each row's rest, in order
    for (std::ptrdiff_t k = r1 + common; k < r2; ++k) t1 += va[k] * x[ix[k]];
    for (std::ptrdiff_t k = r2 + common; k < r3; ++k) t2 += va[k] * x[ix[k]];
    for (std::ptrdiff_t k = r3 + common; k < r4; ++k) t3 += va[k] * x[ix[k]];
    y[i] += alpha * t0;
    y[i + 1] += alpha * t1;
    y[i + 2] += alpha * t2;
    y[i + 3] += alpha * t3;
  };
#ifdef _OPENMP
  const int threads = Eigen::nbThreads();
  if (threads > 1 && A.nonZeros() > 20000) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::ptrdiff_t b = 0; b < blocks; ++b) block(b);
  } else {
    for (std::ptrdiff_t b = 0; b < blocks; ++b) block(b);
  }
#else
  for (std::ptrdiff_t b = 0; b < blocks; ++b) block(b);
#endif
  for (std::ptrdiff_t i = 4 * blocks; i < n; ++i) {  // the last n mod 4 rows
    double t = 0.0;
    for (std::ptrdiff_t k = op[i]; k < op[i + 1]; ++k) t += va[k] * x[ix[k]];
    y[i] += alpha * t;
  }
}

namespace detail {

/// The PPE matrix as an Eigen matrix-free operator (Eigen's "matrix-free solvers" pattern): Eigen's BiCGSTAB
/// multiplies through it, so its products run through add_product. The matrix is not copied and must outlive the
/// operator.
class interleaved_operator : public Eigen::EigenBase<interleaved_operator> {
 public:
  using Scalar = double;
  using RealScalar = double;
  using StorageIndex = std::ptrdiff_t;
  enum { ColsAtCompileTime = Eigen::Dynamic, MaxColsAtCompileTime = Eigen::Dynamic, IsRowMajor = false };

  interleaved_operator() = default;
  explicit interleaved_operator(const matrix& A) : A_(&A) {}
  Eigen::Index rows() const { return A_ ? A_->rows() : 0; }
  Eigen::Index cols() const { return A_ ? A_->cols() : 0; }
  const matrix& sparse() const { return *A_; }  ///< the wrapped matrix

  template <class Rhs>
  Eigen::Product<interleaved_operator, Rhs, Eigen::AliasFreeProduct> operator*(const Eigen::MatrixBase<Rhs>& x) const {
    return Eigen::Product<interleaved_operator, Rhs, Eigen::AliasFreeProduct>(*this, x.derived());
  }

 private:
  const matrix* A_ = nullptr;
};

/// A preconditioner P of the sparse matrix used with interleaved_operator: Eigen hands it the operator, P gets
/// the matrix. Everything else (solve, info, the lagged preconditioner's controls) is P's.
template <class P>
class on_sparse : public P {
 public:
  on_sparse() = default;
  on_sparse& analyzePattern(const interleaved_operator& A) {
    P::analyzePattern(A.sparse());
    return *this;
  }
  on_sparse& factorize(const interleaved_operator& A) {
    P::factorize(A.sparse());
    return *this;
  }
  on_sparse& compute(const interleaved_operator& A) {
    P::compute(A.sparse());
    return *this;
  }
};

}  // namespace detail
}  // namespace mpskit::ppe

namespace Eigen::internal {
/// operator × dense vector: y = 0 then y += α A x (Eigen's evalTo and scaleAndAddTo for sparse × dense).
template <class Rhs>
struct generic_product_impl<mpskit::ppe::detail::interleaved_operator, Rhs, SparseShape, DenseShape, GemvProduct>
    : generic_product_impl_base<mpskit::ppe::detail::interleaved_operator, Rhs,
                                generic_product_impl<mpskit::ppe::detail::interleaved_operator, Rhs>> {
  template <class Dest>
  static void scaleAndAddTo(Dest& dst, const mpskit::ppe::detail::interleaved_operator& lhs, const Rhs& rhs,
                            const double& alpha) {
    static_assert(Rhs::ColsAtCompileTime == 1 && Dest::ColsAtCompileTime == 1, "a vector");
    // Contiguous storage: the solvers' vectors are VectorXd; an expression is evaluated first.
    const Eigen::Ref<const Eigen::VectorXd> x(rhs);
    Eigen::Ref<Eigen::VectorXd> y(dst);
    mpskit::ppe::add_product(lhs.sparse(), x.data(), y.data(), alpha);
  }
};
}  // namespace Eigen::internal
