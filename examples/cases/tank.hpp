#pragma once
// Case set-up shared by examples, tests and benchmarks: fluid blocks in open-top tanks with wall +
// dummy layers (wall/dummy_layers.hpp), as a semi-implicit state.
#include <cmath>

#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// A state with fluid filling [0, fluid_hi] inside an open tank [0, tank_hi] (walls on every face but
/// the top), spacing l0, `layers` solid layers.
template <int D>
scheme::semi_implicit_state<D> tank_state(const vec<D>& fluid_hi, const vec<D>& tank_hi, double l0,
                                          int layers = 3) {
  auto blk = wall::fill_box<D>(vec<D>::Zero(), fluid_hi, l0);
  blk.append(wall::box_walls<D>(vec<D>::Zero(), tank_hi, l0, layers));
  scheme::semi_implicit_state<D> s(static_cast<index_t>(blk.size()));
  for (std::size_t k = 0; k < blk.size(); ++k) {
    s.x().col(static_cast<index_t>(k)) = blk.x[k];
    s.kinds()[k] = blk.kinds[k];
  }
  return s;
}

/// Number of particles of each kind.
template <class State>
index_t count_kind(const State& s, kind k) {
  index_t n = 0;
  for (index_t i = 0; i < s.n_real(); ++i) n += s.kinds()[static_cast<std::size_t>(i)] == k;
  return n;
}

}  // namespace mpskit::cases
