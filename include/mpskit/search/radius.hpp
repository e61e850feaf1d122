#pragma once
/// \file search/radius.hpp
/// \brief mpskit's inclusion rule (r < R, defined once here), radius models (uniform or per particle)
/// and radius rules by which each consumer reads pairs from a neighbour list (ARCHITECTURE.md §4).
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <string_view>

#include "mpskit/core/dimension.hpp"

namespace mpskit::search {

/// THE inclusion rule: j is a neighbour of i at radius R iff |x_ij| < R, i.e. r² < R² (strict, as
/// nanoflann 1.4's RadiusResultSet; a point exactly at R is out, where every kernel is zero anyway).
constexpr bool within(double r2, double R2) noexcept { return r2 < R2; }

/// How a consumer forms the radius of a pair (i, j) from per-particle radii.
enum class radius_rule : std::uint8_t {
  own,        ///< R_i (asymmetric: j may see i at a different radius)
  pair_mean,  ///< R_ij = (R_i + R_j)/2 (symmetric; Tang & Wan's averaged cut-off)
  max,        ///< max(R_i, R_j) (symmetric; the rule the stored lists are built with)
};

/// Name of a rule, for messages and reports.
constexpr std::string_view name(radius_rule r) {
  switch (r) {
    case radius_rule::own: return "own";
    case radius_rule::pair_mean: return "pair_mean";
    case radius_rule::max: return "max";
  }
  return "unknown";
}

/// One radius for every particle.
struct uniform_radius {
  static constexpr bool uniform = true;
  double R = 0.0;  ///< the radius (a length)
  double operator()(index_t) const noexcept { return R; }
};

/// R_i = ratio · L_i from a per-particle length (a diameter or spacing); the array must outlive it.
struct per_particle_radius {
  static constexpr bool uniform = false;
  const Eigen::VectorXd* L = nullptr;  ///< per-particle length
  double ratio = 1.0;                  ///< R_i = ratio · L_i (e.g. 3.1)
  double operator()(index_t i) const noexcept { return ratio * (*L)[i]; }
};

/// A radius model.
template <class R>
concept RadiusModel = requires(const R& r, index_t i) {
  { r(i) } -> std::convertible_to<double>;
  { R::uniform } -> std::convertible_to<bool>;
};

/// The squared radius of pair (i, j) under `rule` (Ri, Rj given).
constexpr double pair_radius2(radius_rule rule, double Ri, double Rj) noexcept {
  switch (rule) {
    case radius_rule::own: return Ri * Ri;
    case radius_rule::pair_mean: {
      const double m = 0.5 * (Ri + Rj);
      return m * m;
    }
    case radius_rule::max: {
      const double m = std::max(Ri, Rj);
      return m * m;
    }
  }
  return 0.0;
}

/// What a consumer reads a list with: a radius model and a rule (several supports, e.g. 2.1 l0 and
/// 3.1 l0, may read one list built at the largest).
template <RadiusModel R>
struct support {
  R radius;                             ///< per-particle radius
  radius_rule rule = radius_rule::own;  ///< pair rule
};
template <RadiusModel R>
support(R, radius_rule) -> support<R>;

}  // namespace mpskit::search
