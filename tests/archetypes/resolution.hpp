#pragma once
// Archetypes of the resolution area (STYLE.md "Concepts and errors"), checked in tests/test_split_merge.cpp.
#include "mpskit/resolution/concepts.hpp"

namespace mpskit::archetypes {

/// Models resolution::Trigger and nothing more: never asks for an event.
struct trigger {
  template <int D>
  static resolution::want decide(double, double) {
    return resolution::want::none;
  }
};

/// Models resolution::SplitPattern and nothing more.
struct split_pattern {
  static constexpr int children = 2;
  template <int D>
  static constexpr double child_ratio() {
    return 0.5;
  }
};

}  // namespace mpskit::archetypes
