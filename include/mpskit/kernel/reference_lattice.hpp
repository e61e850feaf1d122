#pragma once
/// \file kernel/reference_lattice.hpp
/// \brief n0 and λ0 of an interior particle of the square (2D) or cubic (3D) reference lattice
/// (Koshizuka & Oka 1996; bmmr.md §2.3: n_i = Σ_{j≠i} W_ij, λ0 = Σ W r² / Σ W), with mpskit's inclusion
/// rule r < re (a lattice point exactly at re has zero weight for every kernel here anyway).
#include <cmath>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/kernel/concepts.hpp"

namespace mpskit::kernel {

/// Reference constants of a full lattice: n0 (dimensionless) and λ0 in units of l0².
struct lattice_constants {
  double n0 = 0.0;             ///< Σ_{j≠i} w(|x_ij|, re)
  double lambda0_over_l02 = 0.0;  ///< λ0 / l0² = Σ w r² / (Σ w l0²)
  int neighbours = 0;          ///< lattice points with 0 < r < re
  /// λ0 for spacing l0 (λ0 scales with l0², bmmr.md §2.2).
  double lambda0(double l0) const { return lambda0_over_l02 * l0 * l0; }
};

/// n0, λ0 for kernel K on the D-dimensional square/cubic lattice with re = re_ratio · l0.
template <Kernel K, int D>
  requires Dimension<D>
lattice_constants reference_lattice(double re_ratio) {
  if (!(std::isfinite(re_ratio) && re_ratio > 0.0))
    fail("reference_lattice: re_ratio = ", re_ratio, ": must be a finite number > 0");
  const int m = static_cast<int>(std::ceil(re_ratio));
  lattice_constants c;
  double sum_w = 0.0, sum_wr2 = 0.0;
  const int kz = D == 3 ? m : 0;
  for (int k = -kz; k <= kz; ++k)
    for (int j = -m; j <= m; ++j)
      for (int i = -m; i <= m; ++i) {
        const double r2 = double(i) * i + double(j) * j + double(k) * k;
        if (r2 == 0.0 || !(r2 < re_ratio * re_ratio)) continue;
        const double r = std::sqrt(r2);
        const double w = K::w(r, re_ratio);
        ++c.neighbours;
        sum_w += w;
        sum_wr2 += w * r2;
      }
  c.n0 = sum_w;
  c.lambda0_over_l02 = sum_w > 0.0 ? sum_wr2 / sum_w : 0.0;
  return c;
}

}  // namespace mpskit::kernel
