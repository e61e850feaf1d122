#pragma once
/// \file kernel/wendland_c2.hpp
/// \brief Wendland C2 (Wendland 1995; the 2D/3D form) with support re, unnormalised so w(0) = 1.
#include <string_view>

namespace mpskit::kernel {

/// q = r/re: w = (1 − q)⁴ (1 + 4q) for q < 1, else 0.
struct wendland_c2 final {
  static constexpr bool finite_at_zero = true;
  static constexpr std::string_view name = "wendland_c2";
  static double w(double r, double re) noexcept {
    if (r >= re) return 0.0;
    const double q = r / re;
    const double t = 1.0 - q;
    return t * t * t * t * (1.0 + 4.0 * q);
  }
};

}  // namespace mpskit::kernel
