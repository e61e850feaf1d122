#pragma once
/// \file op/detail/lsmps_basis.hpp
/// \brief Scaled monomial bases of LSMPS (Tanaka 2018 eqs. 42–46 and 48–52; Tamai & Koshizuka 2014):
/// p(x) = [x^α]_{1 ≤ |α| ≤ p} in graded order (2D order 2: x, y, x², xy, y², eq. 46; 3D order 2:
/// x, y, z, x², xy, xz, y², yz, z²), with H = diag(α!/L^|α|) so that ∂^α f = α!/L^|α| a_α for the
/// coefficient a_α of (x/L)^α. (The extraction's L⁻¹ on the second-derivative rows of eqs. 43 and 49 is a
/// typo: a Taylor expansion in x/L gives L⁻², docs/operators.md §LSMPS.) Also a fixed-size LDLᵀ with a
/// relative-pivot test, shared by type A and type B.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"

/// Full unrolling of the short fixed-trip loops of moments and factors (GCC at -O2 leaves them rolled and
/// keeps the accumulators in memory: measured 1.9× more instructions for the 2D order-2 moments).
#if defined(__clang__)
#define MPSKIT_UNROLL _Pragma("unroll")
#elif defined(__GNUC__)
#define MPSKIT_UNROLL _Pragma("GCC unroll 32")
#else
#define MPSKIT_UNROLL
#endif

namespace mpskit::op::detail {

/// Number of monomials with 1 ≤ |α| ≤ p in D dimensions: C(D + p, p) − 1 (2D: 2/5/9, 3D: 3/9/19).
constexpr int basis_size(int D, int p) {
  int n = 1, d = 1;
  for (int k = 1; k <= p; ++k) {
    n *= D + k;
    d *= k;
  }
  return n / d - 1;
}

/// Monomial table of order p in D dimensions (graded, within a degree lexicographic with x first).
template <int D, int P>
struct monomials {
  static constexpr int size = basis_size(D, P);
  std::array<std::array<int, 3>, size> alpha{};  ///< exponents (z exponent 0 in 2D)
  std::array<int, size> degree{};                ///< |α|
  std::array<double, size> factorial{};          ///< α! = Π α_a!
  constexpr monomials() {
    int k = 0;
    for (int deg = 1; deg <= P; ++deg) {
      if constexpr (D == 2) {
        for (int ax = deg; ax >= 0; --ax) set(k++, ax, deg - ax, 0);
      } else {
        for (int ax = deg; ax >= 0; --ax)
          for (int ay = deg - ax; ay >= 0; --ay) set(k++, ax, ay, deg - ax - ay);
      }
    }
  }

 private:
  static constexpr double fact(int n) { return n <= 1 ? 1.0 : n * fact(n - 1); }
  constexpr void set(int k, int ax, int ay, int az) {
    alpha[k] = {ax, ay, az};
    degree[k] = ax + ay + az;
    factorial[k] = fact(ax) * fact(ay) * fact(az);
  }
};

/// Basis of order P in D dimensions: evaluation of p(s) (s = x/L, already scaled), H and selectors.
template <int D, int P>
requires Dimension<D> &&(P >= 1 && P <= 3) struct lsmps_basis {
  static constexpr int dim = D;  ///< spatial dimension
  static constexpr monomials<D, P> table{};
  static constexpr int size = monomials<D, P>::size;                ///< m
  static constexpr int size_at(int p) { return basis_size(D, p); }  ///< m of a lower order p
  using vector = Eigen::Matrix<double, size, 1>;

  /// p(s) for a scaled displacement s (Tanaka eq. 46 and its 3D / order-1 and order-3 analogues), written
  /// out per (D, P) — the inner loop of every moment and row — with the generic table loop as reference.
  static void eval(const vec<D>& s, vector& out) {
    const double x = s[0], y = s[1];
    if constexpr (D == 2) {
      out[0] = x;
      out[1] = y;
      if constexpr (P >= 2) {
        const double xx = x * x, xy = x * y, yy = y * y;
        out[2] = xx;
        out[3] = xy;
        out[4] = yy;
        if constexpr (P >= 3) {
          out[5] = xx * x;
          out[6] = xx * y;
          out[7] = x * yy;
          out[8] = yy * y;
        }
      }
    } else {
      const double z = s[2];
      out[0] = x;
      out[1] = y;
      out[2] = z;
      if constexpr (P >= 2) {
        const double xx = x * x, xy = x * y, xz = x * z, yy = y * y, yz = y * z, zz = z * z;
        out[3] = xx;
        out[4] = xy;
        out[5] = xz;
        out[6] = yy;
        out[7] = yz;
        out[8] = zz;
        if constexpr (P >= 3) {
          out[9] = xx * x;
          out[10] = xx * y;
          out[11] = xx * z;
          out[12] = xy * y;
          out[13] = xy * z;
          out[14] = xz * z;
          out[15] = yy * y;
          out[16] = yy * z;
          out[17] = yz * z;
          out[18] = zz * z;
        }
      }
    }
  }

  /// s_a^e for every coordinate a and 0 ≤ e ≤ P (the table evaluations below).
  static std::array<std::array<double, P + 1>, D> powers(const vec<D>& s) {
    std::array<std::array<double, P + 1>, D> pw{};
    for (int a = 0; a < D; ++a) {
      pw[a][0] = 1.0;
      for (int e = 1; e <= P; ++e) pw[a][e] = pw[a][e - 1] * s[a];
    }
    return pw;
  }

  /// p(s) from the monomial table (reference for `eval`, used by the tests).
  static void eval_table(const vec<D>& s, vector& out) {
    const auto pw = powers(s);
    for (int k = 0; k < size; ++k) {
      double v = pw[0][table.alpha[k][0]] * pw[1][table.alpha[k][1]];
      if constexpr (D == 3) v *= pw[2][table.alpha[k][2]];
      out[k] = v;
    }
  }

  /// diag(H) for diameter L: α!/L^|α| (Tanaka eq. 43 read with L^−|α|, see file comment).
  static vector h_diag(double L) {
    vector h;
    const double Linv = 1.0 / L;
    for (int k = 0; k < size; ++k) {
      double s = 1.0;
      for (int e = 0; e < table.degree[k]; ++e) s *= Linv;
      h[k] = table.factorial[k] * s;
    }
    return h;
  }

  /// Index of the monomial with exponents (ax, ay, az) (−1 if absent).
  static constexpr int index_of(int ax, int ay, int az = 0) {
    for (int k = 0; k < size; ++k)
      if (table.alpha[k][0] == ax && table.alpha[k][1] == ay && table.alpha[k][2] == az) return k;
    return -1;
  }
  /// Selector of ∂/∂x_a (row over D_x).
  static vector gradient_selector(int a) {
    vector s = vector::Zero();
    s[a] = 1.0;
    return s;
  }
  /// Selector of the Laplacian Σ_a ∂²/∂x_a² (zero for P = 1: the order-1 basis has no second derivatives).
  static vector laplacian_selector() {
    vector s = vector::Zero();
    if constexpr (P >= 2)
      for (int a = 0; a < D; ++a) {
        std::array<int, 3> e{0, 0, 0};
        e[a] = 2;
        s[index_of(e[0], e[1], e[2])] = 1.0;
      }
    return s;
  }
  /// Selector of the directional derivative n·∇.
  static vector directional_selector(const vec<D>& n) {
    vector s = vector::Zero();
    for (int a = 0; a < D; ++a) s[a] = n[a];
    return s;
  }

  /// n·∇_s p(s): the directional derivative of every monomial at the scaled point s (a Neumann equation's
  /// row in the least squares: n·∇f(x) L = Σ_α a_α n·∂_s p_α(s) for f = Σ_α a_α p_α).
  static void eval_directional(const vec<D>& s, const vec<D>& n, vector& out) {
    const auto pw = powers(s);
    for (int k = 0; k < size; ++k) {
      double v = 0.0;
      for (int b = 0; b < D; ++b) {
        const int eb = table.alpha[k][b];
        if (eb == 0) continue;
        double t = eb * n[b];
        for (int a = 0; a < D; ++a) t *= pw[a][table.alpha[k][a] - (a == b ? 1 : 0)];
        v += t;
      }
      out[k] = v;
    }
  }
};

/// Result of a factorisation with the relative-pivot test.
struct pivot_result {
  int passed = 0;          ///< leading columns whose pivots passed (the order-k block is usable if ≥ m_k)
  double min_ratio = 1.0;  ///< smallest d_k / max_{s≤k} M_ss among the passed columns
};

/// In-place LDLᵀ of the leading n×n block of a symmetric matrix A (lower triangle read), stopping at
/// the first column k whose pivot fails d_k > tol · max_{s≤k} A_ss (or is not finite). Since the largest
/// diagonal entry bounds λ_max from below and every pivot of a leading block bounds λ_min of that block
/// from above, a failed column means cond₂ of the leading (k+1) block is ≥ 1/tol. The test catches
/// linear dependence (collinear or coplanar points, too few neighbours, an isolated particle: A = 0) and
/// neighbourhoods that are thin relative to L. On return the strictly lower part holds L and the
/// diagonal holds D for the leading `passed` columns.
/// N > 0: the size is the compile-time N (loops unrolled), n is ignored.
template <int N = 0, class Mat>
pivot_result ldlt_pivoted(Mat& A, int n, double tol) {
  if constexpr (N > 0) n = N;
  pivot_result r;
  double amax = 0.0;
  MPSKIT_UNROLL
  for (int k = 0; k < n; ++k) {
    const double akk = A(k, k);
    amax = std::max(amax, akk);
    double d = akk;
    MPSKIT_UNROLL
    for (int s = 0; s < k; ++s) d -= A(k, s) * A(k, s) * A(s, s);
    if (!(d > tol * amax) || !std::isfinite(d)) return r;
    A(k, k) = d;
    r.min_ratio = std::min(r.min_ratio, d / amax);
    const double dinv = 1.0 / d;
    MPSKIT_UNROLL
    for (int i = k + 1; i < n; ++i) {
      double v = A(i, k);
      MPSKIT_UNROLL
      for (int s = 0; s < k; ++s) v -= A(i, s) * A(k, s) * A(s, s);
      A(i, k) = v * dinv;
    }
    r.passed = k + 1;
  }
  return r;
}

/// Inverse of the leading n×n block from its LDLᵀ factor (as left by ldlt_pivoted), written to the
/// leading block of `out` (rest zero): M⁻¹ = L⁻ᵀ D⁻¹ L⁻¹.
template <int N = 0, class Mat, class Out>
void ldlt_inverse(const Mat& F, int n, Out& out) {
  if constexpr (N > 0) n = N;
  // n ≤ 19 (the largest basis, 3D order 3); the bound is stated for the optimiser: without it GCC 12 at
  // -O2 -DNDEBUG warns (-Warray-bounds) that y[20] may be indexed past its end.
  MPSKIT_ASSERT(n <= 20);
  if (n > 20) n = 20;
  out.setZero();
  // Column by column: solve L y = e_c, then D z = y, then Lᵀ x = z.
  MPSKIT_UNROLL
  for (int c = 0; c < n; ++c) {
    std::array<double, 20> y{};
    MPSKIT_UNROLL
    for (int i = 0; i < n; ++i) {
      double v = i == c ? 1.0 : 0.0;
      MPSKIT_UNROLL
      for (int s = c; s < i; ++s) v -= F(i, s) * y[s];
      y[i] = i < c ? 0.0 : v;
    }
    MPSKIT_UNROLL
    for (int i = c; i < n; ++i) y[i] /= F(i, i);
    MPSKIT_UNROLL
    for (int i = n - 1; i >= 0; --i) {
      double v = y[i];
      MPSKIT_UNROLL
      for (int s = i + 1; s < n; ++s) v -= F(s, i) * y[s];
      y[i] = v;
    }
    MPSKIT_UNROLL
    for (int i = 0; i < n; ++i) out(i, c) = y[i];
  }
}

/// 1-norm condition number ‖A‖₁‖A⁻¹‖₁ of the leading n×n block (A: symmetric, lower triangle read;
/// Ainv: full inverse of that block).
template <int N = 0, class Mat, class Inv>
double cond1(const Mat& A, const Inv& Ainv, int n) {
  if constexpr (N > 0) n = N;
  double na = 0.0, ni = 0.0;
  MPSKIT_UNROLL
  for (int c = 0; c < n; ++c) {
    double sa = 0.0, si = 0.0;
    MPSKIT_UNROLL
    for (int r = 0; r < n; ++r) {
      sa += std::abs(r >= c ? A(r, c) : A(c, r));
      si += std::abs(Ainv(r, c));
    }
    na = std::max(na, sa);
    ni = std::max(ni, si);
  }
  return na * ni;
}

/// Relative pivot guard of the LDLᵀ: a column whose pivot is ≤ 1e-14 · max_{s≤k} M_ss is singular to
/// working precision (exactly dependent monomials, too few neighbours, an isolated particle).
inline constexpr double singular_pivot = 1e-14;

/// Outcome of `factorise`.
struct factor_result {
  int order = 0;            ///< exact order achieved (0: regularised or zero)
  bool degenerate = false;  ///< the full order was not used
  double condition = 0.0;   ///< cond₁ of the matrix actually inverted (0 for a zero factor)
};

/// The degenerate test and fallback shared by LSMPS type A and B (docs/operators.md "Degenerate
/// neighbourhoods"). M: lower triangle of the moment matrix over a basis whose leading `size_at(p)`
/// columns are the order-p basis (p = 0..P). Test: the full order passes when its LDLᵀ has no singular
/// pivot and cond₁(M) = ‖M‖₁‖M⁻¹‖₁ ≤ max_condition. Fallback `lower_order`: the highest lower order p ≥
/// p_min whose leading block passes the same test; else (or with `regularise`) (M_n + δ I)⁻¹ on the
/// leading n = regular_size block with δ = regularisation · max_k M_kk, or zero when M has no weight.
/// `out` receives the inverse zero-padded to the full size.
template <class Mat, class SizeAt>
factor_result factorise(const Mat& M, int P, SizeAt size_at, int p_min, bool lower_order,
                        double max_condition, double regularisation, int regular_size, Mat& out) {
  constexpr int m = Mat::RowsAtCompileTime;  // the full basis (size_at(P))
  factor_result res;
  Mat F = M;
  const pivot_result r = ldlt_pivoted<m>(F, m, singular_pivot);
  if (r.passed == m) {  // the common case, at compile-time size
    ldlt_inverse<m>(F, m, out);
    const double c = cond1<m>(M, out, m);
    if (c <= max_condition) {
      res.order = P;
      res.condition = c;
      return res;
    }
  }
  for (int p = P; p >= p_min; --p) {
    if (p == P && r.passed == m) continue;  // tried above
    if (p < P && !lower_order) break;
    const int k = size_at(p);
    if (r.passed < k) continue;
    ldlt_inverse(F, k, out);
    const double c = cond1(M, out, k);
    if (c <= max_condition) {
      res.order = p;
      res.degenerate = p < P;
      res.condition = c;
      return res;
    }
  }
  res.degenerate = true;
  out.setZero();
  double mx = 0.0;
  for (int k = 0; k < regular_size; ++k) mx = std::max(mx, M(k, k));
  if (!(mx > 0.0) || !std::isfinite(mx)) return res;
  F = M;
  for (int k = 0; k < regular_size; ++k) F(k, k) += regularisation * mx;
  if (ldlt_pivoted(F, regular_size, 0.0).passed == regular_size) {
    ldlt_inverse(F, regular_size, out);
    // of the unshifted block against the shifted inverse: indicative
    res.condition = cond1(M, out, regular_size);
  } else {
    out.setZero();
  }
  return res;
}

}  // namespace mpskit::op::detail
