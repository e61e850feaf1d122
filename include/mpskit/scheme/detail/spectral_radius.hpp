#pragma once
/// \file scheme/detail/spectral_radius.hpp
/// \brief Spectral radius of a real 2×2 or 3×3 matrix in closed form (the own-loop guard's ρ(B_i),
/// own_loop_guard_params): from the characteristic polynomial, without Eigen's general eigensolver, whose
/// instantiation in every scene's stepper added ≈ 60 % to a test translation unit's compile time (measured:
/// tests/test_lsmps_flow.cpp 81 s → 132 s).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "mpskit/core/dimension.hpp"

namespace mpskit::scheme::detail {

/// Largest |root| of λ² − s λ + q (real coefficients): the larger real root modulus, or √q for a complex
/// pair.
inline double quadratic_root_radius(double s, double q) {
  const double h = 0.5 * s, disc = h * h - q;
  if (disc >= 0.0) return std::abs(h) + std::sqrt(disc);
  return std::sqrt(q);  // complex pair: |λ|² = q > 0
}

/// ρ(B) = max |λ| of a real D×D matrix, D = 2 or 3.
template <int D>
double spectral_radius(const mat<D>& B) {
  static_assert(D == 2 || D == 3, "spectral_radius: 2×2 or 3×3");
  if constexpr (D == 2) {
    return quadratic_root_radius(B.trace(), B.determinant());
  } else {
    // λ³ + a λ² + b λ + c with a = −tr B, b = sum of the principal 2×2 minors, c = −det B.
    const double a = -B.trace();
    const double b = B(0, 0) * B(1, 1) - B(0, 1) * B(1, 0) + B(0, 0) * B(2, 2) - B(0, 2) * B(2, 0) +
                     B(1, 1) * B(2, 2) - B(1, 2) * B(2, 1);
    const double c = -B.determinant();
    // Depressed cubic t³ + p t + q = 0, λ = t − a/3.
    const double p = b - a * a / 3.0, q = 2.0 * a * a * a / 27.0 - a * b / 3.0 + c;
    const double disc = 0.25 * q * q + p * p * p / 27.0;
    double r;  // a real root
    if (disc > 0.0) {
      const double s = std::sqrt(disc);
      r = std::cbrt(-0.5 * q + s) + std::cbrt(-0.5 * q - s) - a / 3.0;
    } else {
      // three real roots (trigonometric form); p ≤ 0 here
      const double m = 2.0 * std::sqrt(std::max(0.0, -p / 3.0));
      const double arg = m > 0.0 ? std::clamp(3.0 * q / (p * m), -1.0, 1.0) : 0.0;
      const double phi = std::acos(arg) / 3.0;
      double rho = 0.0;
      for (int k = 0; k < 3; ++k)
        rho = std::max(rho, std::abs(m * std::cos(phi - 2.0 * std::numbers::pi * k / 3.0) - a / 3.0));
      return rho;
    }
    // the other two: λ² + (a + r) λ + (b + (a + r) r) = 0 (synthetic division by λ − r)
    return std::max(std::abs(r), quadratic_root_radius(-(a + r), b + (a + r) * r));
  }
}

}  // namespace mpskit::scheme::detail
