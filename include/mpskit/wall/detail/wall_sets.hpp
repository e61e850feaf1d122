#pragma once
/// \file wall/detail/wall_sets.hpp
/// \brief A view over one polygon set or a wall collection, so that the polygon wall models
/// (imaginary copies, crossing guard, visibility) loop over sets with one code path.
#include "mpskit/core/dimension.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/wall_collection.hpp"

namespace mpskit::wall::detail {

/// Non-owning view: exactly one of `one` and `many` is set.
template <int D>
struct set_view {
  const geometry::polygon_set<D>* one = nullptr;
  const geometry::wall_collection<D>* many = nullptr;
  index_t size() const { return one ? 1 : many->size(); }
  const geometry::polygon_set<D>& operator[](index_t k) const { return one ? *one : (*many)[k]; }
};

template <int D>
set_view<D> view_of(const geometry::polygon_set<D>& s) {
  return {&s, nullptr};
}
template <int D>
set_view<D> view_of(const geometry::wall_collection<D>& c) {
  return {nullptr, &c};
}

}  // namespace mpskit::wall::detail
