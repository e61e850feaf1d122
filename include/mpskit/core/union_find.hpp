#pragma once
/// \file core/union_find.hpp
/// \brief Disjoint sets over indices 0..n−1 with path halving, the smaller index always the root (so a set's
/// root is its lowest index: results do not depend on the order of the unions). Shared by the PPE's anchoring
/// check (ppe/floating_parts.hpp) and the largest connected body of the probes (io/probes.hpp).
#include <cstddef>
#include <vector>

#include "mpskit/core/dimension.hpp"

namespace mpskit {

class union_find {
 public:
  explicit union_find(index_t n) : root_(static_cast<std::size_t>(n)) {
    for (index_t i = 0; i < n; ++i) root_[static_cast<std::size_t>(i)] = i;
  }
  /// The root of i's set (path halving on the way).
  index_t find(index_t i) {
    while (root_[static_cast<std::size_t>(i)] != i) {
      root_[static_cast<std::size_t>(i)] =
          root_[static_cast<std::size_t>(root_[static_cast<std::size_t>(i)])];
      i = root_[static_cast<std::size_t>(i)];
    }
    return i;
  }
  /// Joins the sets of the roots a and b (both must be roots: find's results) and returns the joint root, the
  /// smaller of the two.
  index_t link(index_t a, index_t b) {
    if (a < b) root_[static_cast<std::size_t>(b)] = a;
    else if (b < a) root_[static_cast<std::size_t>(a)] = b;
    return a < b ? a : b;
  }
  /// Joins the sets of i and j; returns the joint root.
  index_t unite(index_t i, index_t j) { return link(find(i), find(j)); }

 private:
  std::vector<index_t> root_;
};

}  // namespace mpskit
