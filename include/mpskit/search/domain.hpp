#pragma once
/// \file search/domain.hpp
/// \brief Periodic axes and the minimum-image displacement: periodicity is a property of the search,
/// not of ghost particles (ARCHITECTURE.md §4).
#include <array>
#include <cmath>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"

namespace mpskit::search {

/// Axes that are periodic, with the period box [lo, hi) on those axes (other axes ignore lo/hi).
template <int D>
struct domain {
  std::array<bool, D> periodic{};     ///< periodic[a]: axis a wraps with period hi[a] − lo[a]
  vec<D> lo = vec<D>::Zero();          ///< lower corner of the period box
  vec<D> hi = vec<D>::Zero();          ///< upper corner of the period box

  /// True when any axis is periodic.
  bool any_periodic() const {
    for (bool p : periodic)
      if (p) return true;
    return false;
  }
  /// Period of axis a.
  double period(int a) const { return hi[a] - lo[a]; }
  /// Throws mpskit::error when a periodic axis has a non-positive or non-finite period.
  void validate() const {
    for (int a = 0; a < D; ++a)
      if (periodic[a] && !(std::isfinite(lo[a]) && std::isfinite(hi[a]) && hi[a] > lo[a]))
        fail("domain: periodic axis ", a, " has lo = ", lo[a], ", hi = ", hi[a], ": need finite lo < hi");
  }
  /// Minimum image of a displacement d on the periodic axes (each component in [−P/2, P/2]).
  void minimum_image(vec<D>& d) const {
    for (int a = 0; a < D; ++a)
      if (periodic[a]) {
        const double P = hi[a] - lo[a];
        d[a] -= P * std::nearbyint(d[a] / P);
      }
  }
  /// x wrapped into [lo, hi) on the periodic axes.
  vec<D> wrap(const vec<D>& x) const {
    vec<D> y = x;
    for (int a = 0; a < D; ++a)
      if (periodic[a]) {
        const double P = hi[a] - lo[a];
        y[a] -= P * std::floor((y[a] - lo[a]) / P);
        if (y[a] >= hi[a]) y[a] = lo[a];  // rounding of x just below lo
      }
    return y;
  }
};

}  // namespace mpskit::search
