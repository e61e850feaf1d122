#pragma once
/// \file search/cell_list.hpp
/// \brief Uniform-grid cell list, particles sorted by cell with a stable counting sort (ARCHITECTURE.md
/// §4). `order()` is the permutation that puts a state in cell order (state.reorder(order())).
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/search/domain.hpp"

namespace mpskit::search {

/// Cells of edge >= h (exactly P/floor(P/h) on periodic axes, h elsewhere) over the particles'
/// bounding box (the period box on periodic axes); cell index = cx + nx·(cy + ny·cz).
template <int D>
  requires Dimension<D>
class cell_list {
 public:
  /// Most cells allowed per particle beyond a fixed 2^22 allowance: a sparse cloud (one particle far
  /// away) is refused with a message rather than allocating a huge grid.
  static constexpr double max_cells_per_particle = 64.0;

  /// Bins the n columns of x (positions; wrapped into the period box on periodic axes) into cells of
  /// edge >= h. Throws mpskit::error on an empty set, a non-finite position (naming the particle), a
  /// non-positive h or a grid too large for the cloud.
  template <Execution E>
  void build(E e, const points<D>& x, double h, const domain<D>& dom = {}) {
    const index_t n = x.cols();
    if (n == 0) fail("cell_list: the particle set is empty");
    if (!(std::isfinite(h) && h > 0.0)) fail("cell_list: cell size h = ", h, ": must be a finite number > 0");
    dom.validate();
    dom_ = dom;
    for (index_t i = 0; i < n; ++i)
      if (!x.col(i).allFinite()) fail("cell_list: position of particle ", i, " is not finite (NaN or inf)");
    vec<D> lo = x.rowwise().minCoeff(), hi = x.rowwise().maxCoeff();
    double cells = 1.0;
    for (int a = 0; a < D; ++a) {
      const double extent = dom.periodic[a] ? dom.period(a) : hi[a] - lo[a];
      const double na =
          dom.periodic[a] ? std::max(1.0, std::floor(extent / h)) : std::floor(extent / h) + 1.0;
      cells *= na;
      if (cells > max_cells_per_particle * double(n) + double(1 << 22)) break;  // refused below
      dims_[a] = static_cast<int>(na);
      lo_[a] = dom.periodic[a] ? dom.lo[a] : lo[a];
      h_[a] = dom.periodic[a] ? extent / na : h;
    }
    if (cells > max_cells_per_particle * double(n) + double(1 << 22))
      fail("cell_list: the particles span ", cells, " cells of size ", h, " for ", n,
           " particles (bounding box too large: a particle far from the others?)");
    ncells_ = static_cast<index_t>(cells);
    cell_of_.resize(static_cast<std::size_t>(n));
    for_each_particle(e, n, [&](index_t i) {
      cell_of_[static_cast<std::size_t>(i)] = linear(coords_of(x.col(i)));
    });
    // Stable counting sort: deterministic, slots of a cell in ascending particle index.
    start_.assign(static_cast<std::size_t>(ncells_ + 1), 0);
    for (index_t i = 0; i < n; ++i)
      ++start_[static_cast<std::size_t>(cell_of_[static_cast<std::size_t>(i)] + 1)];
    for (index_t c = 0; c < ncells_; ++c)
      start_[static_cast<std::size_t>(c + 1)] += start_[static_cast<std::size_t>(c)];
    order_.resize(static_cast<std::size_t>(n));
    slot_of_.resize(static_cast<std::size_t>(n));
    std::vector<index_t> fill(start_.begin(), start_.end() - 1);
    for (index_t i = 0; i < n; ++i) {
      const index_t s = fill[static_cast<std::size_t>(cell_of_[static_cast<std::size_t>(i)])]++;
      order_[static_cast<std::size_t>(s)] = i;
      slot_of_[static_cast<std::size_t>(i)] = s;
    }
  }

  /// Integer cell coordinates of a point (wrapped on periodic axes).
  std::array<int, D> coords_of(const Eigen::Ref<const vec<D>>& p) const {
    std::array<int, D> c{};
    for (int a = 0; a < D; ++a) {
      double v = p[a];
      if (dom_.periodic[a]) {
        const double P = dom_.period(a);
        v -= P * std::floor((v - dom_.lo[a]) / P);
      }
      int k = static_cast<int>(std::floor((v - lo_[a]) / h_[a]));
      // Only rounding at the upper edge of the box can reach dims (a point at max or at hi−ulp).
      c[a] = k < 0 ? 0 : (k >= dims_[a] ? dims_[a] - 1 : k);
    }
    return c;
  }
  /// Linear cell index of integer coordinates.
  index_t linear(const std::array<int, D>& c) const {
    index_t l = c[D - 1];
    for (int a = D - 2; a >= 0; --a) l = l * dims_[a] + c[a];
    return l;
  }
  /// Integer coordinates of a linear cell index.
  std::array<int, D> coords(index_t l) const {
    std::array<int, D> c{};
    for (int a = 0; a < D; ++a) {
      c[a] = static_cast<int>(l % dims_[a]);
      l /= dims_[a];
    }
    return c;
  }

  index_t cells() const { return ncells_; }                 ///< number of cells
  const std::array<int, D>& dims() const { return dims_; }  ///< cells per axis
  const vec<D>& cell_size() const { return h_; }            ///< cell edge per axis
  const vec<D>& origin() const { return lo_; }              ///< lower corner of the grid
  const domain<D>& dom() const { return dom_; }             ///< periodic axes
  /// first slot of cell c
  index_t cell_begin(index_t c) const { return start_[static_cast<std::size_t>(c)]; }
  /// one past its last slot
  index_t cell_end(index_t c) const { return start_[static_cast<std::size_t>(c + 1)]; }
  index_t cell_of(index_t i) const { return cell_of_[static_cast<std::size_t>(i)]; }  ///< cell of particle i
  /// sorted slot of particle i
  index_t slot_of(index_t i) const { return slot_of_[static_cast<std::size_t>(i)]; }
  /// Sorted slot → particle index: the permutation that puts a state in cell order.
  const std::vector<index_t>& order() const { return order_; }

 private:
  domain<D> dom_{};
  vec<D> lo_ = vec<D>::Zero();
  vec<D> h_ = vec<D>::Ones();
  std::array<int, D> dims_{};
  index_t ncells_ = 0;
  std::vector<index_t> cell_of_, start_, order_, slot_of_;
};

}  // namespace mpskit::search
