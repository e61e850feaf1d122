#pragma once
/// \file geometry/polygon_mesh.hpp
/// \brief Raw polygon data (vertices + elements), its quality report (degenerate and duplicate
/// elements, open, non-manifold and inconsistently oriented facets) and orientation repair.
///
/// Vocabulary, uniform over D: an *element* is a segment (2D) or triangle (3D) with D vertices; a
/// *facet* of an element is what it shares with a neighbour: a vertex in 2D, an edge in 3D. Facet k of
/// an element is local vertex k (2D) or the edge from local vertex k to (k+1)%3 (3D).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/geometry/detail/primitives.hpp"

namespace mpskit::geometry {

/// Element connectivity: column e holds the D vertex indices of element e.
template <int D>
using element_indices = Eigen::Matrix<index_t, D, Eigen::Dynamic>;

/// Vertices and elements as read or generated, before any acceleration structure.
/// Orientation convention: the winding normal (2D: left of a→b; 3D: (b−a)×(c−a)) points to the fluid.
template <int D>
requires Dimension<D>
struct polygon_mesh {
  points<D> vertices;           ///< vertex coordinates (m), vertex i is `.col(i)`
  element_indices<D> elements;  ///< connectivity, element e is `.col(e)`
  /// Number of elements.
  index_t size() const { return elements.cols(); }
  /// The D vertices of element e as the columns of a D×D matrix.
  mat<D> element(index_t e) const {
    mat<D> m;
    for (int k = 0; k < D; ++k) m.col(k) = vertices.col(elements(k, e));
    return m;
  }
  /// Reverses the orientation of element e (swaps its last two vertices).
  void flip(index_t e) { std::swap(elements(D - 2, e), elements(D - 1, e)); }
};

/// One facet use: element and local facet index.
struct facet_ref {
  index_t element = npos;  ///< element index
  int local = -1;          ///< local facet index (2D: vertex 0/1; 3D: edge 0..2)
  friend bool operator==(const facet_ref&, const facet_ref&) = default;
};

/// Defects of a polygon set (readers fill `merged_vertices` and `dropped_*`).
struct quality_report {
  index_t vertices = 0;    ///< number of vertices
  index_t elements = 0;    ///< number of elements
  index_t components = 0;  ///< connected components (through shared facets)
  /// elements of zero (or rounding-level) length/area, or repeated vertices
  std::vector<index_t> degenerate;
  /// (element, earlier element with the same vertex set)
  std::vector<std::pair<index_t, index_t>> duplicate;
  std::vector<facet_ref> open;          ///< facets used by one element only (open edges; 2D: polyline ends)
  std::vector<facet_ref> non_manifold;  ///< one use of each facet shared by more than two elements
  /// one use of each facet shared by two elements with the same direction
  std::vector<facet_ref> inconsistent;
  index_t unreferenced_vertices = 0;  ///< vertices no element uses
  index_t merged_vertices = 0;        ///< coincident vertices merged by a reader (STL)
  index_t dropped_degenerate = 0;     ///< degenerate elements removed on request
  index_t dropped_duplicate = 0;      ///< duplicate elements removed on request
  index_t flipped = 0;                ///< elements re-oriented (consistency and seed)
  /// No open and no non-manifold facets (a closed, manifold boundary).
  bool closed() const { return open.empty() && non_manifold.empty(); }
  /// No defect at all (open facets are not a defect for open tanks, but are counted here).
  bool clean() const {
    return degenerate.empty() && duplicate.empty() && open.empty() && non_manifold.empty() &&
           inconsistent.empty();
  }
  /// One-paragraph human-readable summary.
  std::string summary() const {
    std::ostringstream os;
    os << vertices << " vertices, " << elements << " elements, " << components << " component(s); "
       << degenerate.size() << " degenerate, " << duplicate.size() << " duplicate, " << open.size()
       << " open facet(s), " << non_manifold.size() << " non-manifold facet(s), " << inconsistent.size()
       << " inconsistently oriented facet(s), " << unreferenced_vertices << " unreferenced vertex(es), "
       << merged_vertices << " merged vertex(es), " << flipped << " flipped, " << dropped_degenerate
       << " degenerate and " << dropped_duplicate << " duplicate element(s) dropped";
    return os.str();
  }
};

namespace detail {

/// Element measure: length (2D) or area (3D).
template <int D>
inline double element_measure(const mat<D>& v) {
  return D == 2 ? winding_normal<D>(v).norm() : 0.5 * winding_normal<D>(v).norm();
}

/// True if the element has repeated vertices or a rounding-level measure relative to `scale`
/// (the bounding-box diagonal) and to its own longest edge.
template <int D>
inline bool is_degenerate(const polygon_mesh<D>& m, index_t e, double scale) {
  for (int a = 0; a < D; ++a)
    for (int b = a + 1; b < D; ++b)
      if (m.elements(a, e) == m.elements(b, e)) return true;
  const mat<D> v = m.element(e);
  const double n = winding_normal<D>(v).norm();
  if constexpr (D == 2) {
    return !(n > 1e-12 * scale);
  } else {
    double lmax = 0.0;
    for (int k = 0; k < 3; ++k) lmax = std::max(lmax, (v.col((k + 1) % 3) - v.col(k)).norm());
    return !(lmax > 1e-12 * scale) || !(n > 1e-12 * lmax * lmax);
  }
}

/// A sorted record of facet uses: key (vertex pair), element, local index, direction (+1/−1).
struct facet_use {
  index_t a, b;  // sorted key (2D: b = -1)
  index_t element;
  int local;
  int dir;
  bool operator<(const facet_use& o) const {
    return a != o.a               ? a < o.a
           : b != o.b             ? b < o.b
           : element != o.element ? element < o.element
                                  : local < o.local;
  }
};

/// All facet uses, sorted by key (groups of equal key share a facet).
template <int D>
inline std::vector<facet_use> facet_uses(const polygon_mesh<D>& m) {
  std::vector<facet_use> u;
  u.reserve(static_cast<std::size_t>(m.size() * D));
  for (index_t e = 0; e < m.size(); ++e) {
    for (int k = 0; k < D; ++k) {
      if constexpr (D == 2) {
        // a segment starts (k = 0, dir −1) or ends (k = 1, dir +1) at vertex k; consistent = one of each
        u.push_back({m.elements(k, e), -1, e, k, k == 0 ? -1 : 1});
      } else {
        const index_t p = m.elements(k, e), q = m.elements((k + 1) % 3, e);
        u.push_back({std::min(p, q), std::max(p, q), e, k, p < q ? 1 : -1});
      }
    }
  }
  std::sort(u.begin(), u.end());
  return u;
}

/// Calls f(first, last) for each group [first, last) of uses sharing a facet.
template <class F>
inline void for_each_facet(const std::vector<facet_use>& u, F&& f) {
  std::size_t i = 0;
  while (i < u.size()) {
    std::size_t j = i + 1;
    while (j < u.size() && u[j].a == u[i].a && u[j].b == u[i].b) ++j;
    f(i, j);
    i = j;
  }
}

/// Union–find with path halving.
struct disjoint_sets {
  std::vector<index_t> parent;
  explicit disjoint_sets(index_t n) : parent(static_cast<std::size_t>(n)) {
    std::iota(parent.begin(), parent.end(), index_t{0});
  }
  index_t find(index_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(index_t x, index_t y) {
    x = find(x);
    y = find(y);
    if (x != y) parent[std::max(x, y)] = std::min(x, y);
  }
};

template <int D>
inline double bbox_diagonal(const points<D>& v) {
  if (v.cols() == 0) return 0.0;
  return (v.rowwise().maxCoeff() - v.rowwise().minCoeff()).norm();
}

}  // namespace detail

/// Checks that coordinates are finite and indices in range; throws mpskit::error naming `what`
/// (a file or "polygon_set") and the vertex or element.
template <int D>
inline void validate(const polygon_mesh<D>& m, const std::string& what = "polygon_set") {
  for (index_t i = 0; i < m.vertices.cols(); ++i)
    if (!m.vertices.col(i).allFinite()) fail(what, ": vertex ", i, " has a non-finite coordinate");
  for (index_t e = 0; e < m.size(); ++e)
    for (int k = 0; k < D; ++k)
      if (m.elements(k, e) < 0 || m.elements(k, e) >= m.vertices.cols())
        fail(what, ": element ", e, " refers to vertex ", m.elements(k, e), ", accepted range [0, ",
             m.vertices.cols() - 1, "]");
}

/// Analyses the topology and geometry of a mesh (indices must be valid; see validate()).
template <int D>
inline quality_report analyse(const polygon_mesh<D>& m) {
  quality_report q;
  q.vertices = m.vertices.cols();
  q.elements = m.size();
  const double scale = detail::bbox_diagonal<D>(m.vertices);
  for (index_t e = 0; e < m.size(); ++e)
    if (detail::is_degenerate(m, e, scale)) q.degenerate.push_back(e);
  // duplicates: same sorted vertex set
  {
    std::vector<std::pair<std::array<index_t, D>, index_t>> keys(static_cast<std::size_t>(m.size()));
    for (index_t e = 0; e < m.size(); ++e) {
      std::array<index_t, D> k;
      for (int j = 0; j < D; ++j) k[j] = m.elements(j, e);
      std::sort(k.begin(), k.end());
      keys[e] = {k, e};
    }
    std::sort(keys.begin(), keys.end());
    for (std::size_t i = 1; i < keys.size(); ++i)
      if (keys[i].first == keys[i - 1].first) {
        std::size_t j = i - 1;
        while (j > 0 && keys[j - 1].first == keys[i].first) --j;
        q.duplicate.push_back({keys[i].second, keys[j].second});
      }
    std::sort(q.duplicate.begin(), q.duplicate.end());
  }
  const std::vector<detail::facet_use> uses = detail::facet_uses(m);
  detail::disjoint_sets comp(m.size());
  detail::for_each_facet(uses, [&](std::size_t i, std::size_t j) {
    const std::size_t n = j - i;
    for (std::size_t k = i + 1; k < j; ++k) comp.unite(uses[i].element, uses[k].element);
    if (n == 1) q.open.push_back({uses[i].element, uses[i].local});
    if (n > 2) q.non_manifold.push_back({uses[i].element, uses[i].local});
    if (n == 2 && uses[i].dir == uses[i + 1].dir)
      q.inconsistent.push_back({uses[i + 1].element, uses[i + 1].local});
  });
  for (index_t e = 0; e < m.size(); ++e)
    if (comp.find(e) == e) ++q.components;
  std::vector<char> used(static_cast<std::size_t>(m.vertices.cols()), 0);
  for (index_t e = 0; e < m.size(); ++e)
    for (int k = 0; k < D; ++k) used[m.elements(k, e)] = 1;
  q.unreferenced_vertices = static_cast<index_t>(std::count(used.begin(), used.end(), 0));
  return q;
}

/// Makes orientation consistent inside each connected component (across manifold facets), keeping
/// the orientation of the majority of each component's elements. Returns the number of flipped
/// elements. Components that cannot be oriented (Möbius-like) are left with their conflicts, which
/// analyse() then reports as inconsistent facets.
template <int D>
inline index_t orient_consistently(polygon_mesh<D>& m) {
  const std::vector<detail::facet_use> uses = detail::facet_uses(m);
  // adjacency across manifold facets: (neighbour, same_direction)
  std::vector<std::vector<std::pair<index_t, bool>>> adj(static_cast<std::size_t>(m.size()));
  detail::for_each_facet(uses, [&](std::size_t i, std::size_t j) {
    if (j - i != 2) return;
    const bool same = uses[i].dir == uses[i + 1].dir;
    adj[uses[i].element].push_back({uses[i + 1].element, same});
    adj[uses[i + 1].element].push_back({uses[i].element, same});
  });
  std::vector<int> flip(static_cast<std::size_t>(m.size()), -1);
  index_t flipped = 0;
  std::vector<index_t> stack, members;
  for (index_t s = 0; s < m.size(); ++s) {
    if (flip[s] >= 0) continue;
    members.clear();
    flip[s] = 0;
    stack.push_back(s);
    while (!stack.empty()) {
      const index_t e = stack.back();
      stack.pop_back();
      members.push_back(e);
      for (const auto& [nb, same] : adj[e]) {
        if (flip[nb] >= 0) continue;
        flip[nb] = same ? 1 - flip[e] : flip[e];
        stack.push_back(nb);
      }
    }
    index_t nflip = 0;
    for (index_t e : members) nflip += flip[e];
    const bool invert = 2 * nflip > static_cast<index_t>(members.size());
    for (index_t e : members)
      if ((flip[e] == 1) != invert) {
        m.flip(e);
        ++flipped;
      }
  }
  return flipped;
}

/// Connected components (through shared facets): component id per element, ids 0, 1, ...
template <int D>
inline std::vector<index_t> components(const polygon_mesh<D>& m) {
  const std::vector<detail::facet_use> uses = detail::facet_uses(m);
  detail::disjoint_sets c(m.size());
  detail::for_each_facet(uses, [&](std::size_t i, std::size_t j) {
    for (std::size_t k = i + 1; k < j; ++k) c.unite(uses[i].element, uses[k].element);
  });
  std::vector<index_t> id(static_cast<std::size_t>(m.size()), npos),
      root_id(static_cast<std::size_t>(m.size()), npos);
  index_t next = 0;
  for (index_t e = 0; e < m.size(); ++e) {
    const index_t r = c.find(e);
    if (root_id[r] == npos) root_id[r] = next++;
    id[e] = root_id[r];
  }
  return id;
}

namespace detail {
/// Interior angle of element v at local vertex k (3D); 1 in 2D (each incident segment counts once,
/// the 2D analogue of angle weighting: Bærentzen & Aanæs 2005).
template <int D>
inline double corner_weight(const mat<D>& v, int k) {
  if constexpr (D == 2) {
    (void)v;
    (void)k;
    return 1.0;
  } else {
    const vec<3> a = v.col((k + 1) % 3) - v.col(k), b = v.col((k + 2) % 3) - v.col(k);
    return std::atan2(cross3(a, b).norm(), a.dot(b));
  }
}

/// Weight of element v's unit normal in the corner normal at local vertex k (Max, "Weights for
/// computing vertex normals from facet normals", J. Graphics Tools 4(2) 1999): sin α/(|a||b|) in 3D,
/// 1/length in 2D. Both make vertex normals exact when the vertices lie on a sphere/circle, which the
/// curvature (Tanaka 2018 eq. 77) needs: angle weights leave O(h) errors on irregular tessellations.
template <int D>
inline double max_weight(const mat<D>& v, int k) {
  if constexpr (D == 2) {
    (void)k;
    return 1.0 / (v.col(1) - v.col(0)).norm();
  } else {
    const vec<3> a = v.col((k + 1) % 3) - v.col(k), b = v.col((k + 2) % 3) - v.col(k);
    return cross3(a, b).norm() / (a.squaredNorm() * b.squaredNorm());
  }
}
}  // namespace detail

/// Orients each connected component so that `seed` (a point in the fluid) lies on its fluid side,
/// judged by the angle-weighted pseudo-normal (Bærentzen & Aanæs 2005) at the component's closest
/// point to the seed. Call after orient_consistently(). Returns the number of flipped elements.
/// Throws if the seed lies on a component (distance below 1e-12 of the bounding-box diagonal).
template <int D>
inline index_t orient_towards(polygon_mesh<D>& m, const vec<D>& seed) {
  if (!seed.allFinite()) fail("geometry::orient_towards: fluid seed point must be finite");
  const std::vector<index_t> comp = components(m);
  const index_t ncomp = comp.empty() ? 0 : *std::max_element(comp.begin(), comp.end()) + 1;
  const double scale = detail::bbox_diagonal<D>(m.vertices);
  std::vector<double> best(static_cast<std::size_t>(ncomp), std::numeric_limits<double>::infinity());
  std::vector<index_t> best_e(static_cast<std::size_t>(ncomp), npos);
  std::vector<detail::element_closest<D>> best_c(static_cast<std::size_t>(ncomp));
  for (index_t e = 0; e < m.size(); ++e) {
    const detail::element_closest<D> c = detail::closest_on_element<D>(seed, m.element(e));
    const double d2 = (seed - c.point).squaredNorm();
    if (d2 < best[comp[e]]) {
      best[comp[e]] = d2;
      best_e[comp[e]] = e;
      best_c[comp[e]] = c;
    }
  }
  // pseudo-normal of the closest feature, summed over the component's elements sharing it
  std::vector<vec<D>> pn(static_cast<std::size_t>(ncomp), vec<D>::Zero());
  for (index_t e = 0; e < m.size(); ++e) {
    const index_t c = comp[e];
    const index_t be = best_e[c];
    const detail::element_closest<D>& bc = best_c[c];
    const mat<D> v = m.element(e);
    const vec<D> n = detail::winding_normal<D>(v).normalized();
    if (bc.kind == feature_kind::face) {
      if (e == be) pn[c] += n;
    } else if (bc.kind == feature_kind::vertex) {
      const index_t vid = m.elements(bc.local, be);
      for (int k = 0; k < D; ++k)
        if (m.elements(k, e) == vid) pn[c] += detail::corner_weight<D>(v, k) * n;
    } else {
      const index_t a = m.elements(bc.local, be), b = m.elements((bc.local + 1) % D, be);
      bool ha = false, hb = false;
      for (int k = 0; k < D; ++k) {
        ha = ha || m.elements(k, e) == a;
        hb = hb || m.elements(k, e) == b;
      }
      if (ha && hb) pn[c] += n;
    }
  }
  index_t flipped = 0;
  for (index_t c = 0; c < ncomp; ++c) {
    if (!(std::sqrt(best[c]) > 1e-12 * scale))
      fail("geometry::orient_towards: the fluid seed point lies on element ", best_e[c],
           "; choose a point inside the fluid, away from the walls");
    if ((seed - best_c[c].point).dot(pn[c]) < 0.0) {
      for (index_t e = 0; e < m.size(); ++e)
        if (comp[e] == c) {
          m.flip(e);
          ++flipped;
        }
    }
  }
  return flipped;
}

}  // namespace mpskit::geometry
