#pragma once
/// \file wall/visibility.hpp
/// \brief Thin walls: a pair-visibility predicate for search::neighbour_list::build (issue #7 item 8).
/// Particles i and j see each other unless the segment between them touches a wall element
/// (polygon_set::crosses, a closed test). An imaginary copy lies ON its wall, so the closed segment would
/// always touch its own element: a copy's end is pulled off the wall by `pull`·L′ along its normal toward
/// the fluid, so it sees its own side and not the other side of a thin wall. See docs/walls.md.
#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/wall_collection.hpp"
#include "mpskit/search/domain.hpp"
#include "mpskit/wall/imaginary.hpp"

namespace mpskit::wall {

/// Pair visibility across walls for the neighbour search: `visible(i, j)` over the columns of x (real
/// particles [0, n_real), then the imaginary copies in the order of `copies`). Symmetric in (i, j).
/// Aggregate: `wall_visibility<D>{&walls, &x, n_real, &copies}`; call prepare() once the positions are
/// final (it checks the sizes and stores per-particle wall clearances that skip the segment test for
/// pairs that cannot reach a wall, and, for a convex polygon_set, which columns lie strictly inside it).
template <int D, class Walls = geometry::polygon_set<D>>
struct wall_visibility {
  const Walls* walls = nullptr;  ///< polygon_set<D> or wall_collection<D>
  const points<D>* x = nullptr;  ///< positions: real particles, then ghosts
  index_t n_real = 0;            ///< number of real particles (columns before the ghost range)
  const std::vector<imaginary_copy<D>>* copies = nullptr;  ///< ghost k = column n_real + k (normals, L′)
  const search::domain<D>* dom = nullptr;  ///< periodic axes (minimum image of x_j − x_i), optional
  double pull = 1e-6;  ///< a copy's end is moved pull·L′ along its normal (range (0, 0.01])
  /// ghosts after the copies, tested at their own positions (pressure-boundary particles)
  index_t other_ghosts = 0;
  std::vector<double> clearance{};  ///< lower bounds of the wall distance per column (prepare())
  /// Convex shortcut (prepare(), polygon_set only): when the set is convex (polygon_set::convex(): the fluid
  /// side K = ∩ {y : (y − v_e)·n_e ≥ 0} holds every element on its boundary), a segment whose ends are both
  /// strictly inside K touches no element. inside[c] != 0 marks such columns (for a copy: its pulled end).
  /// Empty when the set is not convex (or has more than convex_max_elements elements, where the per-column
  /// half-space test would cost more than it saves): the segment test decides. Same answers as the test,
  /// cheaper (tanks, ducts: most pairs are within reach of a wall, so the clearances do not prune them).
  std::vector<unsigned char> inside{};
  static constexpr index_t convex_max_elements = 256;  ///< larger sets are not checked for convexity

  /// Checks the sizes (copies must match the ghost range) and computes clearances: the distance of each
  /// real particle to the walls, capped at max_distance (any value is correct; the largest pair distance
  /// of the build prunes best), and 0 for ghosts.
  template <Execution E>
  void prepare(E e, double max_distance) {
    if (!walls || !x) fail("wall::wall_visibility: walls and x must be set");
    if (n_real < 0 || n_real > x->cols())
      fail("wall::wall_visibility: n_real = ", n_real, ", accepted range [0, ", x->cols(), "]");
    const index_t ghosts = x->cols() - n_real;
    if (ghosts > 0 &&
        (other_ghosts < 0 || (copies ? static_cast<index_t>(copies->size()) : 0) + other_ghosts != ghosts))
      fail("wall::wall_visibility: ", ghosts, " ghost columns but ", copies ? copies->size() : 0,
           " imaginary copies and ", other_ghosts, " other ghosts (they must describe the ghost range)");
    if (!(pull > 0.0 && pull <= 0.01))
      fail("wall::wall_visibility: pull = ", pull, ", accepted range (0, 0.01]");
    if (!(max_distance >= 0.0))
      fail("wall::wall_visibility: max_distance = ", max_distance, ", accepted range [0, inf]");
    clearance.assign(static_cast<std::size_t>(x->cols()), 0.0);
    for_each_particle(e, n_real, [&](index_t i) {
      const vec<D> xi = x->col(i);
      double d;
      if constexpr (std::is_same_v<Walls, geometry::polygon_set<D>>)
        d = walls->closest(xi, max_distance).distance;
      else
        d = walls->query(xi, max_distance).distance;
      clearance[static_cast<std::size_t>(i)] = std::isfinite(d) ? d : max_distance;
    });
    inside.clear();
    if constexpr (std::is_same_v<Walls, geometry::polygon_set<D>>) {
      const index_t ne = walls->size();
      if (!walls->convex() || ne > convex_max_elements) return;
      // The element planes in the current pose (a point and the fluid-side normal), once per prepare.
      const double tol = 1e-12 * walls->scale();
      std::vector<std::pair<vec<D>, vec<D>>> planes(static_cast<std::size_t>(ne));
      for (index_t f = 0; f < ne; ++f)
        planes[static_cast<std::size_t>(f)] = {walls->element(f).col(0), walls->element_normal(f)};
      inside.assign(static_cast<std::size_t>(x->cols()), 0);
      for_each_particle(e, x->cols(), [&](index_t c) {
        const vec<D> y = end_point(c, x->col(c));
        bool in = y.allFinite();
        for (std::size_t f = 0; in && f < planes.size(); ++f)
          in = (y - planes[f].first).dot(planes[f].second) > tol;
        inside[static_cast<std::size_t>(c)] = in ? 1 : 0;
      });
    }
  }

  /// True unless the segment between the two particles (a copy's end pulled off its wall) touches a wall.
  bool operator()(index_t i, index_t j) const {
    if (j < i) std::swap(i, j);  // symmetric: the same segment is tested for (i, j) and (j, i)
    const vec<D> raw = x->col(j) - x->col(i);
    vec<D> d = raw;
    if (dom) dom->minimum_image(d);
    const bool shifted = d != raw;
    // Clearance shortcut (unshifted pairs only: the clearances belong to the particles' own positions,
    // not to their periodic images): a segment touching a wall at p has r = |x_i − p| + |p − x_j| ≥ d_i
    // + d_j.
    if (!shifted && clearance.size() == static_cast<std::size_t>(x->cols())) {
      const double c = clearance[static_cast<std::size_t>(i)] + clearance[static_cast<std::size_t>(j)];
      if (c * c > d.squaredNorm()) return true;
    }
    // Convex shortcut (unshifted pairs only, as above): both ends strictly inside the convex fluid side.
    if (!shifted && inside.size() == static_cast<std::size_t>(x->cols()) &&
        inside[static_cast<std::size_t>(i)] && inside[static_cast<std::size_t>(j)])
      return true;
    const vec<D> a = end_point(i, x->col(i));
    const vec<D> b = end_point(j, (x->col(i) + d).eval());
    if (walls->crosses(a, b)) return false;
    // Through a periodic seam the image segment is also tested from j's side, so a wall near either
    // end (within one period of the particle's own position) is seen.
    if (shifted) {
      const vec<D> a2 = end_point(i, (x->col(j) - d).eval());
      const vec<D> b2 = end_point(j, x->col(j));
      if (walls->crosses(a2, b2)) return false;
    }
    return true;
  }

 private:
  vec<D> end_point(index_t i, const vec<D>& xi) const {
    if (i < n_real || !copies || i - n_real >= static_cast<index_t>(copies->size())) return xi;
    const imaginary_copy<D>& c = (*copies)[static_cast<std::size_t>(i - n_real)];
    return xi + pull * c.L * c.normal;
  }
};

}  // namespace mpskit::wall
