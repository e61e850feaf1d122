#pragma once
// Archetypes: the least a type must offer to model each concept (STYLE.md "Concepts and errors").
// Each is checked by a static_assert in the area's test file.
#include <string_view>

#include "mpskit/core/dimension.hpp"

namespace mpskit::archetypes {

/// Models Kernel and nothing more.
struct kernel {
  static constexpr bool finite_at_zero = true;
  static constexpr std::string_view name = "archetype";
  static double w(double, double) { return 0.0; }
};

/// Models search::RadiusModel and nothing more.
struct radius_model {
  static constexpr bool uniform = true;
  double operator()(index_t) const { return 1.0; }
};

/// Models search::VisibilityPredicate and nothing more.
struct visibility {
  bool operator()(index_t, index_t) const { return true; }
};

}  // namespace mpskit::archetypes
