#pragma once
/// \file geometry/wall_collection.hpp
/// \brief Several polygon sets (a fixed tank, a rotating gear, ...) queried as one wall geometry: the
/// closest set wins, crossings are tested against every set, and each set keeps its own motion.
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/geometry/polygon_set.hpp"

namespace mpskit::geometry {

/// A wall_point that also names the polygon set it came from.
template <int D>
struct collection_point : wall_point<D> {
  index_t set = npos;  ///< index of the polygon set in the collection
};

/// A crossing that also names the polygon set.
template <int D>
struct collection_crossing : crossing<D> {
  index_t set = npos;  ///< index of the polygon set in the collection
};

/// Polygon sets queried together (models WallGeometry).
template <int D>
requires Dimension<D>
class wall_collection final {
 /// spatial dimension
 public: static constexpr int dimension = D;
  using vector_type = vec<D>;          ///< point type

  /// Adds a set; returns its index.
  index_t add(polygon_set<D> s) {
    sets_.push_back(std::move(s));
    return static_cast<index_t>(sets_.size()) - 1;
  }
  /// Number of sets.
  index_t size() const { return static_cast<index_t>(sets_.size()); }
  /// Set k.
  polygon_set<D>& operator[](index_t k) { return sets_.at(static_cast<std::size_t>(k)); }
  /// Set k.
  const polygon_set<D>& operator[](index_t k) const { return sets_.at(static_cast<std::size_t>(k)); }

  /// Closest wall point over all sets within max_distance (ties to the lower set index).
  collection_point<D> query(const vec<D>& x,
                            double max_distance = std::numeric_limits<double>::infinity()) const {
    collection_point<D> best;
    double bound = max_distance;
    for (index_t k = 0; k < size(); ++k) {
      const closest_point<D> c = sets_[k].closest(x, bound);
      if (c.found() && (!best.found() || c.distance < best.distance)) {
        static_cast<wall_point<D>&>(best) = sets_[k].query(x, c.distance * (1.0 + 1e-12) + 1e-300);
        best.set = k;
        bound = c.distance;
      }
    }
    return best;
  }
  /// Signed distance to the closest set (+ on the fluid side); +inf for an empty collection.
  double signed_distance(const vec<D>& x) const { return query(x).signed_distance; }
  /// Wall velocity of the closest set at x (zero for an empty collection).
  vec<D> velocity(const vec<D>& x) const {
    const collection_point<D> c = query(x);
    return c.found() ? sets_[c.set].velocity(x) : vec<D>::Zero();
  }
  /// True if segment a–b touches any set.
  bool crosses(const vec<D>& a, const vec<D>& b) const {
    for (const polygon_set<D>& s : sets_)
      if (s.crosses(a, b)) return true;
    return false;
  }
  /// First crossing of a move over all sets.
  std::optional<collection_crossing<D>> first_crossing(const vec<D>& a, const vec<D>& b) const {
    std::optional<collection_crossing<D>> best;
    for (index_t k = 0; k < size(); ++k) {
      const std::optional<crossing<D>> c = sets_[k].first_crossing(a, b);
      if (c && (!best || c->t < best->t)) {
        best.emplace();
        static_cast<crossing<D>&>(*best) = *c;
        best->set = k;
      }
    }
    return best;
  }
  /// Moves every set to time t (refits the moving ones).
  void move_to(double t) {
    for (polygon_set<D>& s : sets_) s.move_to(t);
  }

 private:
  std::vector<polygon_set<D>> sets_;
};

}  // namespace mpskit::geometry
