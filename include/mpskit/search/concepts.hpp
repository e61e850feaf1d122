#pragma once
/// \file search/concepts.hpp
/// \brief Concepts of the search area: radius models (radius.hpp) and pair-visibility predicates.
#include <concepts>

#include "mpskit/core/dimension.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::search {

/// A pair-visibility predicate: `v(i, j)` is false when i and j must not interact (a thin wall
/// between them); applied while lists are built.
template <class V>
concept VisibilityPredicate = requires(const V& v, index_t i, index_t j) {
  { v(i, j) } -> std::convertible_to<bool>;
};

}  // namespace mpskit::search
