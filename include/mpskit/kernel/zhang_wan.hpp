#pragma once
/// \file kernel/zhang_wan.hpp
/// \brief Zhang–Wan weight w = re/(0.85 r + 0.15 re) − 1 (Tang & Wan, seed 004 eq. 3): the classic
/// weight with the singularity removed; w(0) = 1/0.15 − 1 = 17/3.
#include <string_view>

namespace mpskit::kernel {

/// w(r) = re/(0.85 r + 0.15 re) − 1 for r < re, else 0 (zero at r = re, continuous there).
struct zhang_wan final {
  static constexpr bool finite_at_zero = true;
  static constexpr std::string_view name = "zhang_wan";
  static double w(double r, double re) noexcept {
    if (r >= re) return 0.0;
    return re / (0.85 * r + 0.15 * re) - 1.0;
  }
};

}  // namespace mpskit::kernel
