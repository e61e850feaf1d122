#pragma once
/// \file kernel/cubic_spline.hpp
/// \brief Cubic B-spline (Monaghan & Lattanzio 1985) with support re = 2h, unnormalised so that
/// w(0) = 1: MPS operators divide by n0 (or by moments), so the SPH normalisation constant cancels.
#include <string_view>

namespace mpskit::kernel {

/// q = 2r/re: w = 1 − 1.5 q² + 0.75 q³ (q < 1), 0.25 (2 − q)³ (1 <= q < 2), 0 beyond.
struct cubic_spline final {
  static constexpr bool finite_at_zero = true;
  static constexpr std::string_view name = "cubic_spline";
  static double w(double r, double re) noexcept {
    if (r >= re) return 0.0;
    const double q = 2.0 * r / re;
    if (q < 1.0) return 1.0 - 1.5 * q * q + 0.75 * q * q * q;
    const double t = 2.0 - q;
    return 0.25 * t * t * t;
  }
};

}  // namespace mpskit::kernel
