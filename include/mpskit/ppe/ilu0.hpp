#pragma once
/// \file ppe/ilu0.hpp
/// \brief ILU(0): incomplete LU factorisation with no fill, an Eigen preconditioner (Saad, Iterative Methods
/// for Sparse Linear Systems, 2nd ed., 2003, §10.3.2, Algorithm 10.4, the IKJ variant). L (unit lower) and U
/// are kept on the pattern of A, and (LU)_ij = a_ij at every stored (i, j) (Saad §10.3.2; tested in
/// tests/test_flow.cpp). Ours: not in the MPS papers, which name no preconditioner. Factorising is one sweep
/// over the pattern (no sorting, no dropping: Eigen's IncompleteLUT spends most of its time there); applying
/// is two triangular sweeps, sequential (docs/performance.md, "ILU(0) for the LSMPS PPE": on the 2D dam-break
/// PPE 8 % less wall time than Jacobi at 1250 particles, 35 % at 5000, 49 % at 20 000).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/SparseCore>

#include "mpskit/core/error.hpp"

namespace mpskit::ppe {

/// ILU(0) of a square sparse matrix, in the interface Eigen's iterative solvers expect of a preconditioner
/// (compute, solve, info). A pivot that is zero after elimination (or whose inverse is not finite), or a row
/// without a stored diagonal, makes info() NumericalIssue: the factors are not used silently (the solver then
/// reports the failure). Eigen's IncompleteLUT instead replaces a zero pivot by a small value and goes on.
class incomplete_lu0 final {
 public:
  using StorageIndex = std::ptrdiff_t;
  incomplete_lu0() = default;
  template <class M>
  explicit incomplete_lu0(const M& A) {
    compute(A);
  }
  template <class M>
  incomplete_lu0& analyzePattern(const M&) {
    return *this;
  }
  /// Copies A (row-major) and factorises it in place.
  template <class M>
  incomplete_lu0& factorize(const M& A) {
    if constexpr ((M::Flags & Eigen::RowMajorBit) != 0 &&
                  requires { A.outerIndexPtr(); A.innerIndexPtr(); A.valuePtr(); A.isCompressed(); }) {
      if (A.isCompressed()) {  // the CSR arrays as they are (Eigen's sparse assignment asserts sorted rows)
        lu_.resize(A.rows(), A.cols());
        lu_.resizeNonZeros(A.nonZeros());
        std::copy(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1, lu_.outerIndexPtr());
        std::copy(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), lu_.innerIndexPtr());
        std::copy(A.valuePtr(), A.valuePtr() + A.nonZeros(), lu_.valuePtr());
        factor();
        return *this;
      }
    }
    lu_ = A;  // column-major or uncompressed input: a sorted row-major copy
    lu_.makeCompressed();
    factor();
    return *this;
  }
  template <class M>
  incomplete_lu0& compute(const M& A) {
    return factorize(A);
  }
  /// z = (LU)⁻¹ b: forward sweep with the unit lower factor, backward with the upper one. The result is a
  /// buffer kept between calls (valid until the next call): no allocation per application. Precondition:
  /// info() is Success (after a failed factorisation the factors are cleared and solve is the identity).
  template <class R>
  const Eigen::VectorXd& solve(const R& b) const {
    MPSKIT_ASSERT(info_ == Eigen::Success && "incomplete_lu0: solve after a failed factorisation");
    z_ = b;
    const std::ptrdiff_t* outer = lu_.outerIndexPtr();
    const std::ptrdiff_t* inner = lu_.innerIndexPtr();
    const double* a = lu_.valuePtr();
    const Eigen::Index n = lu_.rows();
    for (Eigen::Index i = 0; i < n; ++i) {
      double s = z_[i];
      for (std::ptrdiff_t p = outer[i]; p < diag_[static_cast<std::size_t>(i)]; ++p) s -= a[p] * z_[inner[p]];
      z_[i] = s;
    }
    for (Eigen::Index i = n - 1; i >= 0; --i) {
      double s = z_[i];
      for (std::ptrdiff_t p = diag_[static_cast<std::size_t>(i)] + 1; p < outer[i + 1]; ++p)
        s -= a[p] * z_[inner[p]];
      z_[i] = s * inv_diag_[static_cast<std::size_t>(i)];
    }
    return z_;
  }
  Eigen::ComputationInfo info() const { return info_; }
  /// The factors on A's pattern: strictly lower part L (unit diagonal not stored), diagonal and upper part U.
  const Eigen::SparseMatrix<double, Eigen::RowMajor, std::ptrdiff_t>& factors() const { return lu_; }

 private:
  void factor() {
    info_ = Eigen::Success;
    const Eigen::Index n = lu_.rows();
    if (lu_.cols() != n) {
      fail(Eigen::InvalidInput);
      return;
    }
    // Eigen keeps a compressed matrix's inner indices sorted in each row (the sweeps below rely on it); a
    // matrix built otherwise is sorted here.
    if (!rows_sorted()) sort_rows();
    const std::ptrdiff_t* outer = lu_.outerIndexPtr();
    const std::ptrdiff_t* inner = lu_.innerIndexPtr();
    double* a = lu_.valuePtr();
    diag_.assign(static_cast<std::size_t>(n), -1);
    for (Eigen::Index i = 0; i < n; ++i)
      for (std::ptrdiff_t p = outer[i]; p < outer[i + 1]; ++p)
        if (inner[p] == i) diag_[static_cast<std::size_t>(i)] = p;
    for (Eigen::Index i = 0; i < n; ++i)
      if (diag_[static_cast<std::size_t>(i)] < 0) {  // no stored diagonal: no pivot
        fail(Eigen::NumericalIssue);
        return;
      }
    // Saad Algorithm 10.4: for each row i, for each k < i in its pattern (in order), l_ik = a_ik / u_kk, then
    // a_ij -= l_ik u_kj for the j > k that row i stores (no fill). pos maps a column to its slot in row i.
    pos_.assign(static_cast<std::size_t>(n), -1);
    inv_diag_.resize(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) {
      const std::ptrdiff_t begin = outer[i], end = outer[i + 1], d = diag_[static_cast<std::size_t>(i)];
      for (std::ptrdiff_t p = begin; p < end; ++p) pos_[static_cast<std::size_t>(inner[p])] = p;
      for (std::ptrdiff_t p = begin; p < d; ++p) {
        const std::ptrdiff_t k = inner[p];
        const std::ptrdiff_t dk = diag_[static_cast<std::size_t>(k)];
        const double l = a[p] * inv_diag_[static_cast<std::size_t>(k)];
        a[p] = l;
        for (std::ptrdiff_t q = dk + 1; q < outer[k + 1]; ++q) {
          const std::ptrdiff_t slot = pos_[static_cast<std::size_t>(inner[q])];
          if (slot >= 0) a[slot] -= l * a[q];
        }
      }
      for (std::ptrdiff_t p = begin; p < end; ++p) pos_[static_cast<std::size_t>(inner[p])] = -1;
      const double inv = 1.0 / a[d];
      if (!std::isfinite(a[d]) || !std::isfinite(inv)) {  // zero (or subnormal) or not-finite pivot
        fail(Eigen::NumericalIssue);
        return;
      }
      inv_diag_[static_cast<std::size_t>(i)] = inv;
    }
  }
  /// A failed factorisation: info() says why, and the factors are cleared (solve is then the identity).
  void fail(Eigen::ComputationInfo why) {
    info_ = why;
    lu_.resize(0, 0);
    diag_.clear();
    inv_diag_.clear();
  }
  bool rows_sorted() const {
    const std::ptrdiff_t* outer = lu_.outerIndexPtr();
    const std::ptrdiff_t* inner = lu_.innerIndexPtr();
    for (Eigen::Index i = 0; i < lu_.rows(); ++i)
      for (std::ptrdiff_t p = outer[i] + 1; p < outer[i + 1]; ++p)
        if (inner[p] < inner[p - 1]) return false;
    return true;
  }
  void sort_rows() {
    // transposing copies sort the indices
    Eigen::SparseMatrix<double, Eigen::ColMajor, std::ptrdiff_t> t = lu_;
    lu_ = t;
    lu_.makeCompressed();
  }

  Eigen::SparseMatrix<double, Eigen::RowMajor, std::ptrdiff_t> lu_;
  std::vector<std::ptrdiff_t> diag_;  // slot of each row's diagonal
  std::vector<double> inv_diag_;      // 1 / u_ii
  std::vector<std::ptrdiff_t> pos_;   // column → slot in the current row (−1: not stored), kept between calls
  Eigen::ComputationInfo info_ = Eigen::Success;
  mutable Eigen::VectorXd z_;  // solve()'s result
};

}  // namespace mpskit::ppe
