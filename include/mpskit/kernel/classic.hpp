#pragma once
/// \file kernel/classic.hpp
/// \brief Original MPS weight w = re/r − 1 (Koshizuka & Oka 1996; Mitsume 2015 eq. 3, erp.md §1.2).
#include <limits>
#include <string_view>

namespace mpskit::kernel {

/// w(r) = re/r − 1 for r < re, else 0; singular at r = 0 (returns +inf there).
struct classic final {
  static constexpr bool finite_at_zero = false;
  static constexpr std::string_view name = "classic";
  static double w(double r, double re) noexcept {
    if (r >= re) return 0.0;
    if (r <= 0.0) return std::numeric_limits<double>::infinity();
    return re / r - 1.0;
  }
};

}  // namespace mpskit::kernel
