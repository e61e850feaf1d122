#pragma once
/// \file ppe/interleaved_product.hpp
/// \brief The PPE matrix's product with a vector, four rows at a time, for the BiCGSTAB solvers
/// (ppe/eigen_iterative.hpp): the same arithmetic as Eigen's row-major sparse × dense product, so the same
/// bits, in less time (0.69–0.92× on the benchmark's matrices, −O3; the 3 mm dam break 0.90–0.94× overall).
///
/// Eigen sums each row in one chain, `tmp += a_ik x_k` in storage order, and finishes the rows one after the
/// other: each addition waits for the one before it. Here four rows are summed side by side, each in its own
/// chain and in the same order, so the processor overlaps four chains. Each row's sum is Eigen's (the same
/// operations in the same order; no reassociation), and y_i += α tmp_i as Eigen does, so the result is the
/// same to the bit (test "the interleaved product gives Eigen's bits", label solver) — **when the compiler
/// does not fuse multiply-adds** (no -mfma / -march with FMA, or -ffp-contract=off): with FMA, g++ contracts
/// this loop and Eigen's differently, and the last bits of some rows differ (each result is as accurate).
/// Measured in docs/performance.md, "The interleaved sparse product". Ours: an implementation device, not a
/// method of the papers.
#include <algorithm>
#include <cstddef>
#include <functional>

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

/// y += α A x for the row-major PPE matrix A (compressed or not; x and y distinct). Rows in blocks of four,
/// each summed in storage order from 0 (Eigen's arithmetic, above). With more than one Eigen thread
/// (Eigen::nbThreads(), which core/exec.hpp's eigen_threads_scope holds to one for small systems) and more
/// than 20 000 entries, the blocks are shared among the threads, Eigen's own rule; each row is one thread's,
/// so the result does not depend on the thread count.
inline void add_product(const matrix& A, const double* x, double* y, double alpha) {
  const std::ptrdiff_t n = A.rows();
  // x and y must not overlap (y is written while x is read); Eigen's own sparse product would use a
  // temporary.
  MPSKIT_ASSERT(n == 0 || std::less_equal<const double*>()(x + A.cols(), y) ||
                std::less_equal<const double*>()(y + n, x));
  const std::ptrdiff_t* op = A.outerIndexPtr();
  const std::ptrdiff_t* ix = A.innerIndexPtr();
  const double* va = A.valuePtr();
  const auto* nnz = A.innerNonZeroPtr();  // null when compressed (every assembly); else each row's count
  const auto end = [&](std::ptrdiff_t i) { return nnz ? op[i] + nnz[i] : op[i + 1]; };
  const std::ptrdiff_t blocks = n / 4;
  const auto block = [&](std::ptrdiff_t b) {
    const std::ptrdiff_t i = 4 * b;
    const std::ptrdiff_t b0 = op[i], b1 = op[i + 1], b2 = op[i + 2], b3 = op[i + 3];
    const std::ptrdiff_t e0 = end(i), e1 = end(i + 1), e2 = end(i + 2), e3 = end(i + 3);
    const std::ptrdiff_t common = std::min(std::min(e0 - b0, e1 - b1), std::min(e2 - b2, e3 - b3));
    double t0 = 0.0, t1 = 0.0, t2 = 0.0, t3 = 0.0;
    for (std::ptrdiff_t k = 0; k < common; ++k) {  // four independent chains
      t0 += va[b0 + k] * x[ix[b0 + k]];
      t1 += va[b1 + k] * x[ix[b1 + k]];
      t2 += va[b2 + k] * x[ix[b2 + k]];
      t3 += va[b3 + k] * x[ix[b3 + k]];
    }
    for (std::ptrdiff_t k = b0 + common; k < e0; ++k) t0 += va[k] * x[ix[k]];  // each row's rest, in order
    for (std::ptrdiff_t k = b1 + common; k < e1; ++k) t1 += va[k] * x[ix[k]];
    for (std::ptrdiff_t k = b2 + common; k < e2; ++k) t2 += va[k] * x[ix[k]];
    for (std::ptrdiff_t k = b3 + common; k < e3; ++k) t3 += va[k] * x[ix[k]];
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
    for (std::ptrdiff_t k = op[i]; k < end(i); ++k) t += va[k] * x[ix[k]];
    y[i] += alpha * t;
  }
}

namespace detail {

/// The PPE matrix as an Eigen matrix-free operator (Eigen's "matrix-free solvers" pattern): Eigen's BiCGSTAB
/// multiplies through it, so its products run through add_product. The matrix is not copied and must outlive
/// the operator. For the solvers only: its products are alias-free (`w = op * w` is refused by add_product's
/// assertion) and a scaled product c * (op * x) is not Eigen's bitwise (Eigen folds c into the entries).
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
  Eigen::Product<interleaved_operator, Rhs, Eigen::AliasFreeProduct> operator*(
      const Eigen::MatrixBase<Rhs>& x) const {
    return Eigen::Product<interleaved_operator, Rhs, Eigen::AliasFreeProduct>(*this, x.derived());
  }

 private:
  const matrix* A_ = nullptr;
};

/// A preconditioner P of the sparse matrix used with interleaved_operator: Eigen hands it the operator, P
/// gets the matrix. Everything else (solve, info, the lagged preconditioner's controls) is P's.
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
struct generic_product_impl<mpskit::ppe::detail::interleaved_operator, Rhs, SparseShape, DenseShape,
                            GemvProduct>
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
