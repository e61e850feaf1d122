#pragma once
/// \file geometry/detail/bvh.hpp
/// \brief Axis-aligned bounding-box hierarchy over elements: median-split build, bottom-up refit,
/// best-first pruning for closest-point queries and slab tests for segment queries.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "mpskit/core/dimension.hpp"

namespace mpskit::geometry::detail {

template <int D>
struct aabb {
  vec<D> lo = vec<D>::Constant(std::numeric_limits<double>::infinity());
  vec<D> hi = vec<D>::Constant(-std::numeric_limits<double>::infinity());
  void grow(const vec<D>& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  /// Squared distance from p to the box (0 inside).
  double distance2(const vec<D>& p) const {
    double d2 = 0.0;
    for (int k = 0; k < D; ++k) {
      const double e = std::max({lo[k] - p[k], 0.0, p[k] - hi[k]});
      d2 += e * e;
    }
    return d2;
  }
  /// Slab test: does segment p + t d, t in [0,1], touch the box (closed)?
  bool hit_by_segment(const vec<D>& p, const vec<D>& d) const {
    double t0 = 0.0, t1 = 1.0;
    for (int k = 0; k < D; ++k) {
      if (d[k] == 0.0) {
        if (p[k] < lo[k] || p[k] > hi[k]) return false;
        continue;
      }
      const double inv = 1.0 / d[k];
      double ta = (lo[k] - p[k]) * inv, tb = (hi[k] - p[k]) * inv;
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    return true;
  }
};

/// Node of the hierarchy: internal nodes have two children; leaves own [first, first + count) of
/// the permuted element order.
template <int D>
struct bvh_node {
  aabb<D> box;
  std::int32_t left = -1, right = -1;  // children (internal) or -1
  std::int32_t first = 0, count = 0;   // leaf range
  bool leaf() const { return left < 0; }
};

/// Bounding-volume hierarchy; `ElementBox(e)` returns the box of element e.
template <int D>
class bvh {
 public:
  static constexpr int leaf_size = 4;

  /// Builds the tree over n elements (median split on the longest axis of the centroid box).
  template <class ElementBox>
  void build(index_t n, ElementBox&& element_box) {
    nodes_.clear();
    order_.resize(static_cast<std::size_t>(n));
    std::iota(order_.begin(), order_.end(), index_t{0});
    if (n == 0) return;
    std::vector<aabb<D>> boxes(static_cast<std::size_t>(n));
    std::vector<vec<D>> centres(static_cast<std::size_t>(n));
    for (index_t e = 0; e < n; ++e) {
      boxes[e] = element_box(e);
      centres[e] = 0.5 * (boxes[e].lo + boxes[e].hi);
    }
    nodes_.reserve(static_cast<std::size_t>(2 * n / leaf_size + 2));
    build_node(0, static_cast<std::int32_t>(n), boxes, centres);
  }

  /// Recomputes every box bottom-up after vertices moved (topology unchanged).
  template <class ElementBox>
  void refit(ElementBox&& element_box) {
    // Children are created after their parent (pre-order), so a reverse sweep sees children first.
    for (std::size_t k = nodes_.size(); k-- > 0;) {
      bvh_node<D>& nd = nodes_[k];
      aabb<D> b;
      if (nd.leaf()) {
        for (std::int32_t i = nd.first; i < nd.first + nd.count; ++i) b.grow(element_box(order_[i]));
      } else {
        b = nodes_[nd.left].box;
        b.grow(nodes_[nd.right].box);
      }
      nd.box = b;
    }
  }

  /// Visits leaves whose box is within sqrt(bound2()) of p, nearer child first; `visit(e)` tests an
  /// element and may shrink the bound; `bound2()` returns the current squared pruning radius.
  template <class Visit, class Bound>
  void nearest(const vec<D>& p, Visit&& visit, Bound&& bound2) const {
    if (nodes_.empty()) return;
    std::int32_t stack[128];
    double stack_d2[128];  // box distance at push time: re-checked at pop against the shrunken bound
    int top = 0;
    const double d0 = nodes_[0].box.distance2(p);
    if (d0 > bound2()) return;
    stack[top] = 0;
    stack_d2[top++] = d0;
    while (top > 0) {
      --top;
      if (stack_d2[top] > bound2()) continue;
      const bvh_node<D>& nd = nodes_[stack[top]];
      if (nd.leaf()) {
        for (std::int32_t i = nd.first; i < nd.first + nd.count; ++i) visit(order_[i]);
        continue;
      }
      const double dl = nodes_[nd.left].box.distance2(p), dr = nodes_[nd.right].box.distance2(p);
      const double b = bound2();
      const bool left_first = dl <= dr;
      const std::int32_t near = left_first ? nd.left : nd.right, far = left_first ? nd.right : nd.left;
      const double dnear = left_first ? dl : dr, dfar = left_first ? dr : dl;
      if (dfar <= b) {
        stack[top] = far;
        stack_d2[top++] = dfar;
      }
      if (dnear <= b) {
        stack[top] = near;
        stack_d2[top++] = dnear;
      }
    }
  }

  /// Visits the elements of every leaf whose box the segment p→p+d touches; stops when visit returns true.
  template <class Visit>
  bool segment(const vec<D>& p, const vec<D>& d, Visit&& visit) const {
    if (nodes_.empty()) return false;
    std::int32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const bvh_node<D>& nd = nodes_[stack[--top]];
      if (!nd.box.hit_by_segment(p, d)) continue;
      if (nd.leaf()) {
        for (std::int32_t i = nd.first; i < nd.first + nd.count; ++i)
          if (visit(order_[i])) return true;
        continue;
      }
      stack[top++] = nd.right;
      stack[top++] = nd.left;
    }
    return false;
  }

  /// Number of nodes.
  std::size_t size() const { return nodes_.size(); }
  /// Box of the whole set.
  const aabb<D>& root_box() const { return nodes_.front().box; }

 private:
  std::int32_t build_node(std::int32_t first, std::int32_t count, const std::vector<aabb<D>>& boxes,
                          const std::vector<vec<D>>& centres) {
    const std::int32_t id = static_cast<std::int32_t>(nodes_.size());
    nodes_.emplace_back();
    aabb<D> b, cb;
    for (std::int32_t i = first; i < first + count; ++i) {
      b.grow(boxes[order_[i]]);
      cb.grow(centres[order_[i]]);
    }
    nodes_[id].box = b;
    if (count <= leaf_size) {
      nodes_[id].first = first;
      nodes_[id].count = count;
      return id;
    }
    int axis = 0;
    const vec<D> ext = cb.hi - cb.lo;
    for (int k = 1; k < D; ++k)
      if (ext[k] > ext[axis]) axis = k;
    const std::int32_t mid = first + count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + first + count,
                     [&](index_t x, index_t y) {
                       const double cx = centres[x][axis], cy = centres[y][axis];
                       return cx < cy || (cx == cy && x < y);
                     });
    const std::int32_t l = build_node(first, mid - first, boxes, centres);
    const std::int32_t r = build_node(mid, first + count - mid, boxes, centres);
    nodes_[id].left = l;
    nodes_[id].right = r;
    return id;
  }

  std::vector<bvh_node<D>> nodes_;
  std::vector<index_t> order_;
};

}  // namespace mpskit::geometry::detail
