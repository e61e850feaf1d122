#pragma once
/// \file search/kdtree.hpp
/// \brief kd-tree over a points<D> matrix through nanoflann 1.4.3 (the only file that includes
/// <nanoflann.hpp>). nanoflann's SearchParams, pair results and squared radius are hidden here; the
/// inclusion rule is mpskit's r < R (search/radius.hpp), which nanoflann 1.4's RadiusResultSet also
/// applies (`dist < radius` on squared distances).
#include <nanoflann.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::search {

/// Static kd-tree over the columns of a positions matrix (which must outlive the tree and not move).
template <int D>
  requires Dimension<D>
class kdtree {
 public:
  /// Builds the tree over the columns of x; leaf size as nanoflann's (10 by default).
  explicit kdtree(const points<D>& x, int leaf_size = 10) : adaptor_{&x} {
    if (x.cols() == 0) fail("kdtree: the point set is empty");
    if (leaf_size < 1) fail("kdtree: leaf_size = ", leaf_size, ": must be >= 1");
    for (index_t i = 0; i < x.cols(); ++i)
      if (!x.col(i).allFinite()) fail("kdtree: point ", i, " is not finite (NaN or inf)");
    tree_ = std::make_unique<tree_t>(
        D, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<size_t>(leaf_size)));
    tree_->buildIndex();
  }

  /// Indices of the points with |p − q| < R, ascending.
  void radius_query(const vec<D>& q, double R, std::vector<index_t>& out) const {
    if (!(std::isfinite(R) && R > 0.0)) fail("kdtree: radius R = ", R, ": must be a finite number > 0");
    std::vector<std::pair<index_t, double>> hits;
    nanoflann::SearchParams params(32, 0.0f, false);
    tree_->radiusSearch(q.data(), R * R, hits, params);
    out.clear();
    out.reserve(hits.size());
    // mpskit's rule, stated again here
    for (const auto& h : hits) if (within(h.second, R * R)) out.push_back(h.first);
    std::sort(out.begin(), out.end());
  }

  /// The k nearest points (ascending distance; ties by nanoflann's order).
  std::vector<index_t> nearest(const vec<D>& q, index_t k) const {
    if (k < 1) fail("kdtree: k = ", k, ": must be >= 1");
    std::vector<index_t> idx(static_cast<std::size_t>(k));
    std::vector<double> d2(static_cast<std::size_t>(k));
    const std::size_t found = tree_->knnSearch(q.data(), static_cast<std::size_t>(k), idx.data(), d2.data());
    idx.resize(found);
    return idx;
  }

 private:
  struct adaptor {
    const points<D>* x;
    std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(x->cols()); }
    double kdtree_get_pt(index_t i, std::size_t a) const { return (*x)(static_cast<Eigen::Index>(a), i); }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const { return false; }
  };
  using tree_t =
      nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, adaptor>, adaptor, D, index_t>;
  adaptor adaptor_;
  std::unique_ptr<tree_t> tree_;
};

}  // namespace mpskit::search
