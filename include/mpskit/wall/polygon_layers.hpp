#pragma once
/// \file wall/polygon_layers.hpp
/// \brief Wall + dummy layers and fluid fills from polygon sets (2D polylines, 3D triangle meshes), for
/// wall::dummy_layers: lattice points (origin + (k + ½) l0, the lattice of fill_box / box_walls) are
/// classified by their signed distance s to the walls (geometry::polygon_set, positive on the fluid side):
/// s > 0 → fluid; −l0 < s ≤ 0 → wall; −m l0 < s ≤ −(m − 1) l0 → dummy layer m (m = 2..layers).
/// Layers are Euclidean distance bands, so concave and convex corners, inclined and curved walls get
/// consistent layers; at a convex corner the outermost corner block of a Chebyshev layering (points
/// beyond layers·l0 of every wall, outside every support of a wall particle) is not generated.
#include <array>
#include <cmath>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/wall/dummy_layers.hpp"

namespace mpskit::wall {

namespace detail {
/// Calls f(p) for the lattice points origin + (k + ½) l0 inside [lo, hi].
template <int D, class F>
void for_each_lattice_point(const vec<D>& lo, const vec<D>& hi, double l0, const vec<D>& origin, F&& f) {
  if (!(std::isfinite(l0) && l0 > 0.0)) fail("polygon layers: l0 = ", l0, ": must be a finite number > 0");
  std::array<long, D> from{}, to{};
  for (int a = 0; a < D; ++a) {
    if (!(hi[a] > lo[a])) fail("polygon layers: hi[", a, "] = ", hi[a], " must exceed lo[", a, "] = ", lo[a]);
    from[a] = static_cast<long>(std::ceil((lo[a] - origin[a]) / l0 - 0.5));
    to[a] = static_cast<long>(std::floor((hi[a] - origin[a]) / l0 - 0.5));
    if (to[a] < from[a]) return;
  }
  std::array<long, D> k = from;
  while (true) {
    vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = origin[a] + (double(k[a]) + 0.5) * l0;
    f(p);
    int a = 0;
    while (a < D && ++k[a] > to[a]) {
      k[a] = from[a];
      ++a;
    }
    if (a == D) break;
  }
}
}  // namespace detail

/// Wall (first band) and dummy (further bands) particles within `layers`·l0 behind the walls, inside
/// the box [lo, hi] (the caller's bound, e.g. the open top of a tank).
template <int D>
particle_block<D> polygon_walls(const geometry::polygon_set<D>& walls, const vec<D>& lo, const vec<D>& hi,
                                double l0, int layers, const vec<D>& origin = vec<D>::Zero()) {
  if (layers < 1) fail("polygon_walls: layers = ", layers, ": must be >= 1");
  particle_block<D> b;
  detail::for_each_lattice_point<D>(lo, hi, l0, origin, [&](const vec<D>& p) {
    const double s = walls.signed_distance(p);
    if (!(s <= 0.0) || !(s > -layers * l0)) return;
    const int m = static_cast<int>(std::floor(-s / l0));  // 0: wall band
    b.x.push_back(p);
    b.kinds.push_back(m == 0 ? kind::wall : kind::dummy);
  });
  return b;
}

/// Fluid particles at the lattice points with signed distance > 0 (fluid side) inside [lo, hi].
template <int D>
particle_block<D> polygon_fill(const geometry::polygon_set<D>& walls, const vec<D>& lo, const vec<D>& hi,
                               double l0, const vec<D>& origin = vec<D>::Zero(), kind k = kind::fluid) {
  particle_block<D> b;
  detail::for_each_lattice_point<D>(lo, hi, l0, origin, [&](const vec<D>& p) {
    if (walls.signed_distance(p) > 0.0) {
      b.x.push_back(p);
      b.kinds.push_back(k);
    }
  });
  return b;
}

}  // namespace mpskit::wall
