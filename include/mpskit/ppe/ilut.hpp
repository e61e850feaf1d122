#pragma once
/// \file ppe/ilut.hpp
/// \brief ILUT with Eigen's factors, bit for bit, in less time: `ppe::incomplete_lut` is Eigen's
/// IncompleteLUT (Saad's dual-threshold ILUT, Saad, Iterative Methods for Sparse Linear Systems, 2nd ed.,
/// 2003, §10.4.1, Algorithm 10.6, as Eigen 3.4 implements it: AMD ordering of A + Aᵀ; multipliers at or below
/// the drop tolerance and U entries at or below it × the row's 2-norm dropped; with
/// p = ⌊(⌊fill_factor × nnz(A)/n⌋ + 1)/2⌋, each row keeps its p largest multipliers in L and its p − 1
/// largest entries beside the diagonal in U) with its factorisation rewritten for speed and nothing else
/// changed.
///
/// Two loops take most of Eigen's `IncompleteLUT::factorize` on the PPE matrices (perf on the 3D duct of
/// label `poiseuille_multires`, 2026-12-07: 55 % and 14 % of its samples; the factorisation was 18 % of the
/// label):
///  - the next row to eliminate is found by a linear scan for the smallest pending column (`minCoeff` over
///    the pending part of the row, once per elimination: quadratic in the row's lower length, which fill
///    makes long); here a binary min-heap of the pending columns gives the same ascending order (the columns
///    are distinct);
///  - the diagonal of each earlier row is found by walking its L part; here its position is kept per row.
/// Every floating-point operation is Eigen's, in Eigen's order: the row's norm in storage order, each
/// elimination in ascending column order with row k's U entries in their stored order, fill values
/// −fact·u_kj, the multipliers in elimination order, the same compaction of U and Eigen's own
/// `internal::QuickSplit` on the same arrays, the factors stored through the same sparse insertion calls. So
/// the stored L and U (values, column indices, their order in each row) are Eigen's. The solve is Eigen's
/// triangular sweeps with each row's diagonal found by its kept position rather than by walking the row's L
/// part (the walk took 12 % of Eigen's solve in the 2D multi-diameter channel). tests/test_flow.cpp (label
/// `solver`) compares the factors and the solves with Eigen's bit for bit. docs/performance.md, "ILUT with
/// Eigen's factors in less time".
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <vector>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

namespace mpskit::ppe {

/// Eigen::IncompleteLUT<double, std::ptrdiff_t> with the factorisation above and a solve that reads each
/// row's diagonal position, in the interface Eigen's iterative solvers expect of a preconditioner. The base
/// is protected: its own factorize and solve, which would not keep the diagonal positions, cannot be reached
/// from outside. As Eigen's, a zero row makes info() NumericalIssue (the factors are then not usable: solve
/// asserts), and a zero pivot is replaced by √droptol × the row's norm. An empty (0 × 0) matrix has empty
/// factors (Eigen's factorize divides by its size). solve() writes buffers kept in the object: one solve at a
/// time per object.
class incomplete_lut : protected Eigen::IncompleteLUT<double, std::ptrdiff_t> {
  using base = Eigen::IncompleteLUT<double, std::ptrdiff_t>;

 public:
  using StorageIndex = std::ptrdiff_t;
  using base::analyzePattern;
  using base::cols;
  using base::info;
  using base::rows;
  using base::setDroptol;
  using base::setFillfactor;

  incomplete_lut() = default;
  template <class M>
  explicit incomplete_lut(const M& A) {
    compute(A);
  }
  template <class M>
  incomplete_lut& compute(const M& A) {
    base::analyzePattern(A);
    factorize(A);
    return *this;
  }
  /// Eigen's IncompleteLUT::factorize (Eigen 3.4, IncompleteLUT.h), operation for operation;
  /// analyzePattern(A) must have been called on A's pattern.
  template <class M>
  incomplete_lut& factorize(const M& amat) {
    using Eigen::Index;
    eigen_assert(amat.rows() == amat.cols() && "incomplete_lut: the matrix must be square");
    eigen_assert(m_analysisIsOk && "incomplete_lut: analyzePattern() first");
    m_factorizationIsOk = false;
    const Index n = amat.cols();
    m_lu.resize(n, n);
    if (n == 0) {  // Eigen's fill count would divide by 0: an empty system has empty factors
      diag_.clear();
      m_factorizationIsOk = true;
      m_info = Eigen::Success;
      return *this;
    }
    Eigen::SparseMatrix<double, Eigen::RowMajor, std::ptrdiff_t> mat;
    mat = amat.twistedBy(m_Pinv);  // the fill-reducing permutation, as Eigen applies it
    Index fill_in = (amat.nonZeros() * m_fillfactor) / n + 1;
    if (fill_in > n) fill_in = n;
    const Index nnzL = fill_in / 2, nnzU = nnzL;
    m_lu.reserve(n * (nnzL + nnzU + 1));

    const auto un = static_cast<std::size_t>(n);
    w_.assign(un, 0.0);
    present_.assign(un, 0);
    diag_.assign(un, 0);
    for (Index ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      // 1 - the row of the permuted matrix: lower part pending in the heap, upper part in insertion order
      heap_.clear();
      ucols_.clear();
      w_[i] = 0.0;
      present_[i] = 1;
      double rownorm = 0.0;
      for (decltype(mat)::InnerIterator it(mat, ii); it; ++it) {
        const Index k = it.index();
        const auto uk = static_cast<std::size_t>(k);
        if (k < ii) {
          heap_.push_back(k);
          w_[uk] = it.value();
          present_[uk] = 1;
        } else if (k == ii) {
          w_[i] = it.value();
        } else {
          ucols_.push_back(k);
          w_[uk] = it.value();
          present_[uk] = 1;
        }
        rownorm += Eigen::numext::abs2(it.value());
      }
      std::make_heap(heap_.begin(), heap_.end(), std::greater<>{});
      // 2 - a zero row: NumericalIssue, the factors left incomplete (as Eigen's); the marks are reset by the
      // next factorisation's assign
      if (rownorm == 0) {
        m_info = Eigen::NumericalIssue;
        return *this;
      }
      rownorm = std::sqrt(rownorm);
      // 3 - eliminate with the earlier rows (complete in m_lu) in ascending column order
      const std::ptrdiff_t* lu_outer = m_lu.outerIndexPtr();
      const std::ptrdiff_t* lu_inner = m_lu.innerIndexPtr();
      const double* lu_value = m_lu.valuePtr();
      lvals_.clear();
      lcols_.clear();
      while (!heap_.empty()) {
        std::pop_heap(heap_.begin(), heap_.end(), std::greater<>{});
        const Index minrow = heap_.back();
        heap_.pop_back();
        const auto m = static_cast<std::size_t>(minrow);
        present_[m] = 0;
        const double fact = w_[m] / lu_value[diag_[m]];
        if (std::abs(fact) <= m_droptol) continue;  // Eigen's drop rule for the multipliers (absolute)
        for (Index q = diag_[m] + 1; q < lu_outer[m + 1]; ++q) {
          const double prod = fact * lu_value[q];
          const Index j = lu_inner[q];
          const auto uj = static_cast<std::size_t>(j);
          if (!present_[uj]) {  // fill-in
            if (j >= ii) {
              ucols_.push_back(j);
            } else {
              heap_.push_back(j);
              std::push_heap(heap_.begin(), heap_.end(), std::greater<>{});
            }
            w_[uj] = -prod;
            present_[uj] = 1;
          } else {
            w_[uj] -= prod;
          }
        }
        lvals_.push_back(fact);
        lcols_.push_back(minrow);
      }
      // 4 - keep the largest multipliers (Eigen's QuickSplit on the same arrays), the diagonal, then U,
      // stored with Eigen's insertion calls
      const Index sizel = static_cast<Index>(lvals_.size());
      Index len = std::min(sizel, nnzL);
      {
        Eigen::Map<Eigen::VectorXd> ul(lvals_.data(), sizel);
        Eigen::Map<index_vector> jul(lcols_.data(), sizel);
        Eigen::internal::QuickSplit(ul, jul, len);
      }
      m_lu.startVec(ii);
      for (Index k = 0; k < len; ++k)
        m_lu.insertBackByOuterInnerUnordered(ii, lcols_[std::size_t(k)]) = lvals_[std::size_t(k)];
      double diagonal = w_[i];
      if (diagonal == 0.0) diagonal = std::sqrt(m_droptol) * rownorm;  // Eigen's shift of a zero pivot
      diag_[i] = m_lu.outerIndexPtr()[ii + 1];  // where the next entry of row ii goes
      m_lu.insertBackByOuterInnerUnordered(ii, ii) = diagonal;
      uvals_.clear();
      ucols_kept_.clear();
      for (const Index j : ucols_) {  // the drop rule, compacting in insertion order
        const double v = w_[static_cast<std::size_t>(j)];
        present_[static_cast<std::size_t>(j)] = 0;
        if (std::abs(v) > m_droptol * rownorm) {
          uvals_.push_back(v);
          ucols_kept_.push_back(j);
        }
      }
      present_[i] = 0;
      const Index sizeu = static_cast<Index>(uvals_.size()) + 1;  // with the diagonal, as Eigen counts it
      len = std::min(sizeu, nnzU);
      {
        Eigen::Map<Eigen::VectorXd> uu(uvals_.data(), sizeu - 1);
        Eigen::Map<index_vector> juu(ucols_kept_.data(), sizeu - 1);
        Eigen::internal::QuickSplit(uu, juu, len);
      }
      for (Index k = 0; k + 1 < len; ++k)  // Eigen stores len − 1 of them (k = ii + 1 .. ii + len − 1)
        m_lu.insertBackByOuterInnerUnordered(ii, ucols_kept_[std::size_t(k)]) = uvals_[std::size_t(k)];
    }
    m_lu.finalize();
    m_lu.makeCompressed();
    m_factorizationIsOk = true;
    m_info = Eigen::Success;
    return *this;
  }
  /// z = (LU)⁻¹ b with Eigen's operations (IncompleteLUT::_solve_impl: the permutation, the unit-lower sweep
  /// summing each row's L entries in stored order, the upper sweep summing each row's U entries in stored
  /// order and dividing by the diagonal, the permutation back), each row's diagonal found by its kept
  /// position instead of a walk over its L part. The result is a buffer kept between calls (valid until the
  /// next call): no allocation per application once the buffers have grown.
  template <class R>
  const Eigen::VectorXd& solve(const Eigen::MatrixBase<R>& b) const {
    eigen_assert(m_factorizationIsOk && m_info == Eigen::Success && "incomplete_lut: no usable factors");
    eigen_assert(b.rows() == m_lu.rows() && b.cols() == 1);
    const std::ptrdiff_t n = m_lu.rows();
    t_ = m_Pinv * b;
    const std::ptrdiff_t* outer = m_lu.outerIndexPtr();
    const std::ptrdiff_t* col = m_lu.innerIndexPtr();
    const double* val = m_lu.valuePtr();
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      double tmp = t_[i];
      for (std::ptrdiff_t q = outer[i]; q < diag_[std::size_t(i)]; ++q) tmp -= val[q] * t_[col[q]];
      t_[i] = tmp;
    }
    for (std::ptrdiff_t i = n - 1; i >= 0; --i) {
      double tmp = t_[i];
      const std::ptrdiff_t d = diag_[std::size_t(i)];
      for (std::ptrdiff_t q = d + 1; q < outer[i + 1]; ++q) tmp -= val[q] * t_[col[q]];
      t_[i] = tmp / val[d];
    }
    z_ = m_P * t_;
    return z_;
  }

 private:
  using index_vector = Eigen::Matrix<std::ptrdiff_t, Eigen::Dynamic, 1>;
  // Work arrays, kept between factorisations (no allocation once they have grown), and the diagonal
  // positions.
  std::vector<double> w_;                     // the current row, dense by column
  std::vector<unsigned char> present_;        // whether column j is in the current row
  std::vector<std::ptrdiff_t> heap_;          // pending lower columns (min-heap)
  std::vector<std::ptrdiff_t> ucols_;         // upper columns in insertion order (Eigen's ju(ii + 1 ..))
  std::vector<double> lvals_, uvals_;         // multipliers; kept upper values
  std::vector<std::ptrdiff_t> lcols_, ucols_kept_;
  std::vector<std::ptrdiff_t> diag_;          // each row's diagonal position in m_lu's arrays
  mutable Eigen::VectorXd t_, z_;             // solve()'s work and result buffers
};

}  // namespace mpskit::ppe
