#pragma once
/// \file surface/asymmetry.hpp
/// \brief Asymmetry-vector detection (Zhang & Wan 2012 as written in Tang & Wan, seed 004 eqs. 14–15):
/// F_i = D/n0 Σ_{j≠i} (r_i − r_j)/|r_i − r_j| W(r_ij), and i is on the free surface when
/// |F_i| > α = α_F |F|⁰, with |F|⁰ "the initial value of the surface particle" read as |F| of a particle
/// in the top row of a flat surface of the reference lattice (`flat_surface_asymmetry`).
///
/// Readings (docs/surface.md): F is dimensionless (unit vectors times W, over n0); D/n0 uses n0 of the
/// same support. A particle with no participating neighbour (F = 0 by eq. 14) is a surface particle.
/// Optional PND clause n_i < β_n n0 → surface (default β_n = 0.8, Zhang & Wan 2012 [EXT], not printed
/// in seed 004; β_n = 0 leaves eq. 15 alone).
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/reference_lattice.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/concepts.hpp"
#include "mpskit/surface/detail/sweep.hpp"

namespace mpskit::surface {

/// |F|⁰ (seed 004 eq. 14) of a particle in the top row of a flat free surface of the square (2D) or
/// cubic (3D) reference lattice: the lattice points with last coordinate ≤ 0 around the particle at the
/// origin, 0 < r < re_ratio (spacing 1; F is scale-free), with n0 of the full lattice at the same ratio.
/// By symmetry F⁰ points along +e_{D−1} (outwards); same-row neighbours contribute nothing.
template <Kernel K, int D>
  requires Dimension<D>
double flat_surface_asymmetry(double re_ratio) {
  if (!(std::isfinite(re_ratio) && re_ratio > 0.0))
    fail("flat_surface_asymmetry: re_ratio = ", re_ratio, ": must be a finite number > 0");
  const double n0 = kernel::reference_lattice<K, D>(re_ratio).n0;
  const int m = static_cast<int>(std::ceil(re_ratio));
  vec<D> F = vec<D>::Zero();
  const int kz = D == 3 ? m : 0;
  for (int k = -kz; k <= kz; ++k)
    for (int j = -m; j <= m; ++j)
      for (int i = -m; i <= m; ++i) {
        vec<D> p;
        p[0] = i;
        p[1] = j;
        if constexpr (D == 3) p[2] = k;
        if (p[D - 1] > 0.0) continue;  // half-space below the top row
        const double r2 = p.squaredNorm();
        if (r2 == 0.0 || !(r2 < re_ratio * re_ratio)) continue;
        const double r = std::sqrt(r2);
        F -= (K::w(r, re_ratio) / r) * p;  // (r_i − r_j)/|r_ij| W, r_i = 0
      }
  return (double(D) / n0) * F.norm();
}

/// Numbers of the asymmetry-vector test.
struct asymmetry_params {
  double alpha_f = 0.9;    ///< α = α_F |F|⁰ (seed 004, below eq. 15: 0.9)
  double pnd_ratio = 0.8;  ///< β_n: n_i < β_n n0 is a surface particle regardless of F ([EXT], 0 = off)
  support_choice radius = support_choice::small;  ///< support of W, n0 and n_i
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("asymmetry_params");
    v.positive("alpha_f", alpha_f);
    v.in_range("pnd_ratio", pnd_ratio, 0.0, 1.0);
    v.throw_if_any();
  }
};

/// |F_i| > α_F |F|⁰ (seed 004 eqs. 14–15).
class asymmetry final {
 /// fields beyond the core: none (uses position, flags)
 public: using fields = field_list<>;
  using params_type = asymmetry_params;
  /// Validates p.
  explicit asymmetry(const params_type& p = {}) : p_(p) { p_.validate(); }
  const params_type& params() const { return p_; }  ///< the numbers

  /// F_i (seed 004 eq. 14), pointing away from the neighbours (outwards at a surface); `n` receives n_i
  /// and `count` the participating neighbours in the support.
  template <ClassicSupports Op, class Participates = all_participate>
  vec<Op::dim> vector(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
                      const Participates& participates, index_t i, double* n = nullptr,
                      index_t* count = nullptr) const {
    vec<Op::dim> s = vec<Op::dim>::Zero();
    double ni = 0.0;
    index_t c = 0;
    detail::for_each_weighted(x, nl, op, p_.radius, participates, i,
                              [&](index_t, const vec<Op::dim>& d, double r, double w) {
                                s -= (w / r) * d;  // (r_i − r_j)/|r_i − r_j| W(r_ij), d = r_j − r_i
                                ni += w;
                                ++c;
                              });
    if (n) *n = ni;
    if (count) *count = c;
    return ((double(Op::dim) / detail::n0_of(op, p_.radius)) * s).eval();
  }
  /// |F_i|.
  template <ClassicSupports Op, class Participates = all_participate>
  double value(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
               const Participates& participates, index_t i) const {
    return vector(x, nl, op, participates, i).norm();
  }
  /// |F|⁰ of the operator's kernel and the chosen radius ratio.
  template <ClassicSupports Op>
  double reference(const Op& op) const {
    return flat_surface_asymmetry<typename Op::kernel_type, Op::dim>(detail::ratio_of(op, p_.radius));
  }
  /// α = α_F |F|⁰.
  template <ClassicSupports Op>
  double threshold(const Op& op) const {
    return p_.alpha_f * reference(op);
  }

  /// Sets flag::surface on candidates with |F_i| > α (or n_i < β_n n0, or no neighbour), clears it on the
  /// other candidates; `values` (optional) receives |F_i| (NaN for non-candidates).
  template <Execution E, ClassicSupports Op, class Participates>
  void detect(E e, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
              const Participates& participates, std::span<const std::uint8_t> candidate,
              std::vector<flag::type>& flags, Eigen::VectorXd* values = nullptr) const {
    detail::check_sizes("asymmetry", x, nl, candidate, flags);
    const double alpha = threshold(op);
    const double n_low = p_.pnd_ratio * detail::n0_of(op, p_.radius);
    detail::sweep(e, x.cols(), candidate, flags, values, [&](index_t i) {
      double n = 0.0;
      index_t c = 0;
      const double F = vector(x, nl, op, participates, i, &n, &c).norm();
      return detail::decision{F > alpha || n < n_low || c == 0, F};  // seed 004 eq. 15 (+ readings)
    });
  }

 private:
  params_type p_;
};

}  // namespace mpskit::surface
