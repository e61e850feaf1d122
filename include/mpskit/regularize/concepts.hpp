#pragma once
/// \file regularize/concepts.hpp
/// \brief Concepts of the regularisation area (docs/regularize.md): a collision model changes the
/// velocities of approaching close pairs (and the positions by Δu Δt); a shifting model displaces
/// particles towards a uniform distribution. Both compute every particle's change from the old state
/// into a buffer and then commit it, each particle writing only its own slot (thread-count independent).
#include <concepts>
#include <span>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::regularize {

/// Every particle qualifies (default predicate for `participates` and `movable`).
struct every_particle {
  constexpr bool operator()(index_t) const noexcept { return true; }
};

/// A collision model in D dimensions: `c.apply(exec, x, u, list, participates, movable, dt)` returns a
/// report with the number of colliding pairs and the largest velocity change.
template <class C, int D>
concept CollisionModel = requires(const C& c, points<D>& x, points<D>& u,
                                  const search::neighbour_list<D>& nl) {
  typename C::params_type;
  { c.apply(exec::seq{}, x, u, nl, every_particle{}, every_particle{}, 0.0).pairs }
      -> std::convertible_to<index_t>;
  { c.apply(exec::par{}, x, u, nl, every_particle{}, every_particle{}, 0.0).max_dv }
      -> std::convertible_to<double>;
};

/// A shifting model for operator Op: `s.apply(exec, x, list, op, participates, movable, flags)` displaces
/// particles and returns a report with the largest shift in units of l0.
template <class S, class Op>
concept ShiftingModel = requires(const S& s, points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl,
                                 const Op& op, std::span<const flag::type> flags) {
  typename S::params_type;
  { s.apply(exec::seq{}, x, nl, op, every_particle{}, every_particle{}, flags).max_shift_over_l0 }
      -> std::convertible_to<double>;
  { s.apply(exec::par{}, x, nl, op, every_particle{}, every_particle{}, flags).shifted }
      -> std::convertible_to<index_t>;
};

}  // namespace mpskit::regularize
