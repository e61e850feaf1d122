#pragma once
/// \file geometry/concepts.hpp
/// \brief Concepts of the geometry area: what polygon wall models (imaginary particles, ERP), the
/// neighbour search (pair visibility) and the wall-crossing guard ask of a wall description.
#include <concepts>
#include <optional>

#include "mpskit/core/dimension.hpp"

namespace mpskit::geometry {

/// A wall geometry: per-particle wall query (closest point, element, weights, signed distance,
/// normal toward the fluid, curvature, wall velocity), segment visibility, first crossing of a move,
/// and motion in time. Modelled by polygon_set<2> and polygon_set<3>.
template <class G>
concept WallGeometry = requires(G& g, const G& cg, const typename G::vector_type& x, double r) {
  requires Dimension<G::dimension>;
  requires std::same_as<typename G::vector_type, vec<G::dimension>>;
  { cg.query(x, r).found() } -> std::convertible_to<bool>;
  { cg.query(x, r).point } -> std::convertible_to<vec<G::dimension>>;
  { cg.query(x, r).normal } -> std::convertible_to<vec<G::dimension>>;
  { cg.query(x, r).velocity } -> std::convertible_to<vec<G::dimension>>;
  { cg.query(x, r).signed_distance } -> std::convertible_to<double>;
  { cg.query(x, r).curvature } -> std::convertible_to<double>;
  { cg.query(x, r).element } -> std::convertible_to<index_t>;
  { cg.crosses(x, x) } -> std::same_as<bool>;
  { cg.first_crossing(x, x).has_value() } -> std::convertible_to<bool>;
  { cg.signed_distance(x) } -> std::convertible_to<double>;
  { cg.velocity(x) } -> std::convertible_to<vec<G::dimension>>;
  g.move_to(r);
};

}  // namespace mpskit::geometry
