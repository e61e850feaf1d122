#pragma once
/// \file kernel/quadratic.hpp
/// \brief Non-singular quadratic weight w = (1 − r/re)² (Tanaka 2018 eq. 29; Kondo & Koshizuka 2011,
/// BMMR eq. 3 written as (r/re − 1)², the same function).
#include <string_view>

namespace mpskit::kernel {

/// w(r) = (1 − r/re)² for r < re, else 0; w(0) = 1.
struct quadratic final {
  static constexpr bool finite_at_zero = true;
  static constexpr std::string_view name = "quadratic";
  static double w(double r, double re) noexcept {
    if (r >= re) return 0.0;
    const double q = 1.0 - r / re;
    return q * q;
  }
};

}  // namespace mpskit::kernel
