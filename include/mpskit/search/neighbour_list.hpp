#pragma once
/// \file search/neighbour_list.hpp
/// \brief Full CSR neighbour lists (ARCHITECTURE.md §4): built once per step at the largest radius a
/// scene needs × (1 + skin) under the `max` rule (a superset of every rule and every smaller ratio),
/// read by each consumer through its own support (radius model + rule) and the minimum-image
/// displacement accessor. Mixed radii: cell windows sized by the local maximum radius.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <type_traits>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/search/cell_list.hpp"
#include "mpskit/search/domain.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::search {

/// Default pair-visibility predicate: every pair is visible.
struct always_visible {
  constexpr bool operator()(index_t, index_t) const noexcept { return true; }
};

/// Options of a list build.
template <int D>
struct build_options {
  double skin = 0.0;    ///< lists hold pairs with r < max(R_i, R_j)·(1 + skin): room for motion in a step
  domain<D> dom{};      ///< periodic axes
};

/// Rows of stored neighbours per particle (j ≠ i), in cell-scan order: deterministic, independent of
/// the thread count, and ascending in j when the state is in cell order (`cells().order()`).
template <int D>
  requires Dimension<D>
class neighbour_list {
 /// stored index type (halves memory traffic of sweeps)
 public: using neighbour_t = std::int32_t;

  /// Builds rows for all columns of x (real and ghost) with build radius R_i·(1 + skin) per particle
  /// and pair rule max; `visible(i, j)` may reject pairs (walls thinner than the support).
  template <Execution E, RadiusModel R, class Visible = always_visible>
  void build(E e, const points<D>& x, const R& radius, const build_options<D>& opt = {},
             const Visible& visible = {}) {
    const index_t n = x.cols();
    if (n == 0) fail("neighbour_list: the particle set is empty");
    if (n > std::numeric_limits<neighbour_t>::max())
      fail("neighbour_list: ", n, " particles exceed the 32-bit neighbour index");
    if (!(std::isfinite(opt.skin) && opt.skin >= 0.0))
      fail("neighbour_list: skin = ", opt.skin, ": must be a finite number >= 0");
    dom_ = opt.dom;
    dom_.validate();
    periodic_ = dom_.any_periodic();
    for (int a = 0; a < D; ++a) {
      period_[a] = dom_.periodic[a] ? dom_.period(a) : 0.0;
      half_period_[a] = 0.5 * period_[a];
    }
    const double grow = 1.0 + opt.skin;

    // Build radii, validated per particle.
    double rmin = std::numeric_limits<double>::infinity(), rmax = 0.0;
    if constexpr (R::uniform) {
      const double r0 = radius(0);
      if (!(std::isfinite(r0) && r0 > 0.0))
        fail("neighbour_list: radius R = ", r0, ": must be a finite number > 0");
      rmin = rmax = r0 * grow;
    } else {
      rb_.resize(static_cast<std::size_t>(n));
      if (radius.L && radius.L->size() != n)
        fail("neighbour_list: the per-particle length array has ", radius.L->size(), " entries for ", n,
             " particles");
      for (index_t i = 0; i < n; ++i) {
        const double ri = radius(i);
        if (!(std::isfinite(ri) && ri > 0.0))
          fail("neighbour_list: radius of particle ", i, " = ", ri, ": must be a finite number > 0");
        rb_[static_cast<std::size_t>(i)] = ri * grow;
        rmin = std::min(rmin, ri * grow);
        rmax = std::max(rmax, ri * grow);
      }
    }
    for (int a = 0; a < D; ++a)
      if (dom_.periodic[a] && !(2.0 * rmax < dom_.period(a)))
        fail("neighbour_list: periodic axis ", a, " has period ", dom_.period(a), " but the build radius is ",
             rmax, ": the minimum image needs period > 2 R");

    ur2_ = rmax * rmax;
    cells_.build(e, x, rmin, dom_);
    window_for_cells<R>(rmax);

    // Sorted copy of positions for contiguous scans. Pair tests use the raw positions with the minimum
    // image (bitwise the arithmetic of displacement()); shift ids come from wrapped copies.
    const std::vector<index_t>& order = cells_.order();
    xs_.resize(D, n);
    xw_.resize(D, periodic_ ? n : 0);
    if constexpr (!R::uniform) rbs_.resize(static_cast<std::size_t>(n));
    for_each_particle(e, n, [&](index_t s) {
      const index_t i = order[static_cast<std::size_t>(s)];
      xs_.col(s) = x.col(i);
      if (periodic_) xw_.col(s) = dom_.wrap(xs_.col(s));
      if constexpr (!R::uniform) rbs_[static_cast<std::size_t>(s)] = rb_[static_cast<std::size_t>(i)];
    });

    // Rows in fixed blocks (deterministic for any thread count), then one concatenation.
    constexpr index_t block = 1024;
    const index_t nb = (n + block - 1) / block;
    std::vector<std::vector<neighbour_t>>& bj = scratch_j_;
    std::vector<std::vector<std::uint8_t>>& bs = scratch_s_;
    bj.resize(static_cast<std::size_t>(nb));
    bs.resize(static_cast<std::size_t>(nb));
    offsets_.assign(static_cast<std::size_t>(n + 1), 0);
    // Room per row: the previous build's mean row length + 25 % (lists change little between steps),
    // else 40; a block that outgrows it reallocates (mixed radii hold 5–6× more pairs per row).
    const double per_row = rows_ > 0 ? 1.25 * double(nbr_.size()) / double(rows_) + 4.0 : 40.0;
    for_each_block(e, n, block, [&](index_t b, index_t lo, index_t hi) {
      auto& J = bj[static_cast<std::size_t>(b)];
      auto& S = bs[static_cast<std::size_t>(b)];
      J.clear();
      S.clear();
      J.reserve(static_cast<std::size_t>(double(hi - lo) * per_row));
      for (index_t i = lo; i < hi; ++i) {
        const std::size_t before = J.size();
        scan_row<R>(i, visible, J, S);
        offsets_[static_cast<std::size_t>(i + 1)] = static_cast<index_t>(J.size() - before);
      }
    });
    for (index_t i = 0; i < n; ++i)
      offsets_[static_cast<std::size_t>(i + 1)] += offsets_[static_cast<std::size_t>(i)];
    nbr_.resize(static_cast<std::size_t>(offsets_.back()));
    shift_.resize(periodic_ ? nbr_.size() : 0);
    for_each_particle(e, nb, [&](index_t b) {
      const std::size_t at = static_cast<std::size_t>(offsets_[static_cast<std::size_t>(b * block)]);
      const auto& J = bj[static_cast<std::size_t>(b)];
      std::copy(J.begin(), J.end(), nbr_.begin() + static_cast<std::ptrdiff_t>(at));
      if (periodic_) {
        const auto& S = bs[static_cast<std::size_t>(b)];
        std::copy(S.begin(), S.end(), shift_.begin() + static_cast<std::ptrdiff_t>(at));
      }
    });
    rows_ = n;
  }

  /// Frees the per-block scratch rows kept between builds (as many entries as the list; keeping them
  /// spares each build the page faults of fresh memory, and does not raise the peak, which a build
  /// reaches anyway). The next build allocates them again.
  void release_scratch() {
    std::vector<std::vector<neighbour_t>>().swap(scratch_j_);
    std::vector<std::vector<std::uint8_t>>().swap(scratch_s_);
  }

  index_t rows() const { return rows_; }  ///< particles the list was built for
  index_t pairs() const { return static_cast<index_t>(nbr_.size()); }  ///< stored (directed) pairs
  /// Stored neighbours of i.
  index_t count(index_t i) const {
    return offsets_[static_cast<std::size_t>(i + 1)] - offsets_[static_cast<std::size_t>(i)];
  }
  /// Stored neighbours of i (indices).
  std::span<const neighbour_t> neighbours(index_t i) const {
    return {nbr_.data() + offsets_[static_cast<std::size_t>(i)], static_cast<std::size_t>(count(i))};
  }
  /// CSR offsets (rows()+1 entries) and neighbour indices.
  const std::vector<index_t>& offsets() const { return offsets_; }
  const std::vector<neighbour_t>& indices() const { return nbr_; }
  /// Shift id of stored pair k (periodic axes only): Σ_a (k_a + 1)·3^a where the displacement is
  /// x_j − x_i + Σ_a k_a P_a e_a with both positions wrapped into the period box; 13 (2D: 4) = no shift.
  int shift_id(index_t k) const {
    return periodic_ ? shift_[static_cast<std::size_t>(k)] : (D == 2 ? 4 : 13);
  }
  /// Image offsets k_a ∈ {−1, 0, 1} of a shift id.
  static std::array<int, D> decode_shift(int id) {
    std::array<int, D> k{};
    for (int a = 0; a < D; ++a) {
      k[a] = id % 3 - 1;
      id /= 3;
    }
    return k;
  }
  const domain<D>& dom() const { return dom_; }       ///< periodic axes of the last build
  const cell_list<D>& cells() const { return cells_; }  ///< the cell list of the last build

  /// x_j − x_i with the minimum image on periodic axes (every operator reads displacements here).
  vec<D> displacement(const points<D>& x, index_t i, index_t j) const {
    vec<D> d = x.col(j) - x.col(i);
    if (periodic_) minimum_image(d);
    return d;
  }

  /// Calls f(j, x_ij, r²) for the stored neighbours j of i inside support s (its radius model and
  /// rule; r² < R_ij² with mpskit's inclusion rule), in stored order. x must be the positions the
  /// consumer works on (they may have moved within the skin since the build); f must not modify them.
  template <RadiusModel R, class F>
  void for_each_neighbour(const points<D>& x, index_t i, const support<R>& s, F&& f) const {
    // Branch-free compaction: the support test of a chunk of stored pairs writes every candidate into
    // a small buffer and advances the fill count by (r² < R²); f then runs over the kept entries. The
    // inclusion test of jittered shells near R is data-dependent, and as a branch it was mispredicted
    // often enough to cost more than the pair arithmetic (docs/performance.md). Order of the calls,
    // displacements and r² are exactly those of a plain loop, so results are bitwise unchanged.
    constexpr index_t chunk = 64;
    index_t b = offsets_[static_cast<std::size_t>(i)];
    const index_t end = offsets_[static_cast<std::size_t>(i + 1)];
    const vec<D> xi = x.col(i);
    [[maybe_unused]] double Ri = 0.0, R2u = 0.0;
    if constexpr (R::uniform) {
      const double R0 = s.radius(i);
      R2u = R0 * R0;
    } else {
      Ri = s.radius(i);
    }
    neighbour_t bj[chunk];
    double bd[chunk][D];
    double br2[chunk];
    while (b < end) {
      const index_t e = std::min(end, b + chunk);
      int m = 0;
      for (index_t k = b; k < e; ++k) {
        const neighbour_t j = nbr_[static_cast<std::size_t>(k)];
        vec<D> d = x.col(j) - xi;
        if (periodic_) minimum_image(d);
        const double r2 = d.squaredNorm();
        double R2;
        if constexpr (R::uniform) {
          R2 = R2u;
        } else {
          R2 = pair_radius2(s.rule, Ri, s.radius(j));
        }
        bj[m] = j;
        for (int a = 0; a < D; ++a) bd[m][a] = d[a];
        br2[m] = r2;
        m += within(r2, R2) ? 1 : 0;
      }
      for (int q = 0; q < m; ++q) {
        vec<D> d;
        for (int a = 0; a < D; ++a) d[a] = bd[q][a];
        f(static_cast<index_t>(bj[q]), static_cast<const vec<D>&>(d), br2[q]);
      }
      b = e;
    }
  }

 private:
  /// Per-cell scan window (cells per axis): ceil(R_need / h) where R_need is the largest build radius
  /// among particles whose own window reaches the cell (a max-dilation of per-cell maxima), so a
  /// small particle next to a large one still finds it.
  template <RadiusModel R>
  void window_for_cells(double rmax) {
    const index_t nc = cells_.cells();
    const vec<D>& h = cells_.cell_size();
    if constexpr (R::uniform) {
      uniform_window_ = true;
      for (int a = 0; a < D; ++a) w_[a] = static_cast<int>(std::ceil(rmax / h[a]));
      return;
    }
    uniform_window_ = false;
    std::vector<double> cmax(static_cast<std::size_t>(nc), 0.0);
    for (index_t s = 0; s < static_cast<index_t>(cells_.order().size()); ++s) {
      const index_t i = cells_.order()[static_cast<std::size_t>(s)];
      double& m = cmax[static_cast<std::size_t>(cells_.cell_of(i))];
      m = std::max(m, rb_[static_cast<std::size_t>(i)]);
    }
    need_.assign(static_cast<std::size_t>(nc), 0.0);
    for (index_t c = 0; c < nc; ++c) {
      const double m = cmax[static_cast<std::size_t>(c)];
      if (m == 0.0) continue;
      std::array<int, D> w{};
      for (int a = 0; a < D; ++a) w[a] = static_cast<int>(std::ceil(m / h[a]));
      visit_box(cells_.coords(c), w, [&](index_t c2, const std::array<int, D>&) {
        double& t = need_[static_cast<std::size_t>(c2)];
        t = std::max(t, m);
      });
    }
  }

  /// Calls f(cell, image) for each cell in the box of half-width w around c (wrapping on periodic
  /// axes; image[a] = −1/0/+1 period crossed). Each cell is visited once.
  template <class F>
  void visit_box(const std::array<int, D>& c, const std::array<int, D>& w, F&& f) const {
    const auto& dims = cells_.dims();
    std::array<int, D> lo{}, hi{};
    for (int a = 0; a < D; ++a) {
      if (dom_.periodic[a]) {
        const int span = std::min(2 * w[a] + 1, dims[a]);
        lo[a] = c[a] - w[a];
        hi[a] = lo[a] + span - 1;
      } else {
        lo[a] = std::max(0, c[a] - w[a]);
        hi[a] = std::min(dims[a] - 1, c[a] + w[a]);
      }
    }
    std::array<int, D> k = lo, cc{}, img{};
    while (true) {
      for (int a = 0; a < D; ++a) {
        int v = k[a];
        img[a] = 0;
        if (v < 0) { v += dims[a]; img[a] = -1; }
        else if (v >= dims[a]) { v -= dims[a]; img[a] = 1; }
        cc[a] = v;
      }
      f(cells_.linear(cc), img);
      int a = 0;
      while (a < D && ++k[a] > hi[a]) {
        k[a] = lo[a];
        ++a;
      }
      if (a == D) break;
    }
  }

  /// Appends row i: scans x-rows of cells as contiguous slot ranges.
  template <RadiusModel R, class Visible>
  void scan_row(index_t i, const Visible& visible, std::vector<neighbour_t>& J,
                std::vector<std::uint8_t>& S) const {
    const index_t si = cells_.slot_of(i);
    const vec<D> xi = xs_.col(si);
    const std::array<int, D> c = cells_.coords(cells_.cell_of(i));
    std::array<int, D> w = w_;
    double ri = 0.0;
    if constexpr (!R::uniform) {
      ri = rb_[static_cast<std::size_t>(i)];
      const double need = need_[static_cast<std::size_t>(cells_.cell_of(i))];
      for (int a = 0; a < D; ++a) w[a] = static_cast<int>(std::ceil(need / cells_.cell_size()[a]));
    }
    const double R2u = uniform_window_ ? uniform_r2() : 0.0;
    const auto& dims = cells_.dims();
    const auto& order = cells_.order();
    // Outer axes (1..D-1) visited cell by cell; axis 0 as one or two contiguous ranges.
    std::array<int, D> lo{}, hi{};
    for (int a = 1; a < D; ++a) {
      if (dom_.periodic[a]) {
        lo[a] = c[a] - w[a];
        hi[a] = lo[a] + std::min(2 * w[a] + 1, dims[a]) - 1;
      } else {
        lo[a] = std::max(0, c[a] - w[a]);
        hi[a] = std::min(dims[a] - 1, c[a] + w[a]);
      }
    }
    constexpr index_t chunk = 64;
    index_t kept[chunk];
    // x-range segments.
    struct seg { int a, b; };
    std::array<seg, 3> segs{};
    int nseg = 0;
    if (dom_.periodic[0]) {
      const int span = std::min(2 * w[0] + 1, dims[0]);
      int a0 = c[0] - w[0], b0 = a0 + span - 1;
      if (a0 < 0) { segs[nseg++] = {a0 + dims[0], dims[0] - 1}; a0 = 0; }
      if (b0 >= dims[0]) { segs[nseg++] = {0, b0 - dims[0]}; b0 = dims[0] - 1; }
      segs[nseg++] = {a0, b0};
    } else {
      segs[nseg++] = {std::max(0, c[0] - w[0]), std::min(dims[0] - 1, c[0] + w[0])};
    }
    std::array<int, D> k = lo;
    k[0] = 0;
    std::array<int, D> cc{};
    while (true) {
      for (int a = 1; a < D; ++a) {
        int v = k[a];
        if (v < 0) v += dims[a];
        else if (v >= dims[a]) v -= dims[a];
        cc[a] = v;
      }
      for (int q = 0; q < nseg; ++q) {
        cc[0] = segs[q].a;
        const index_t t0 = cells_.cell_begin(cells_.linear(cc));
        cc[0] = segs[q].b;
        const index_t t1 = cells_.cell_end(cells_.linear(cc));
        // Branch-free compaction of the slot range (as in for_each_neighbour): the r < R test of
        // jittered shells is data-dependent and cost more as a mispredicted branch than the test.
        for (index_t t = t0; t < t1; t += chunk) {
          const index_t te = std::min(t1, t + chunk);
          int m = 0;
          for (index_t u = t; u < te; ++u) {
            vec<D> d = xs_.col(u) - xi;
            if (periodic_) minimum_image(d);
            const double r2 = d.squaredNorm();
            double R2;
            if constexpr (R::uniform) {
              R2 = R2u;
            } else {
              const double mr = std::max(ri, rbs_[static_cast<std::size_t>(u)]);
              R2 = mr * mr;
            }
            kept[m] = u;
            m += static_cast<int>(within(r2, R2)) & static_cast<int>(u != si);
          }
          for (int q = 0; q < m; ++q) {
            const index_t u = kept[q];
            const index_t j = order[static_cast<std::size_t>(u)];
            if constexpr (!std::is_same_v<Visible, always_visible>)
              if (!visible(i, j)) continue;
            J.push_back(static_cast<neighbour_t>(j));
            if (periodic_) S.push_back(shift_code(xw_.col(u) - xw_.col(si)));
          }
        }
      }
      int a = 1;
      while (a < D && ++k[a] > hi[a]) {
        k[a] = lo[a];
        ++a;
      }
      if (a >= D) break;
    }
  }

  double uniform_r2() const { return ur2_; }

  /// domain::minimum_image with a fast path, bitwise the same: for |d_a| < P/2, nearbyint(d_a/P) is ±0
  /// and d_a − P·(±0) = d_a + 0 (which maps −0 to +0, as the full formula does); only the rare
  /// components beyond half a period pay for the division and the libm nearbyint call.
  void minimum_image(vec<D>& d) const {
    for (int a = 0; a < D; ++a)
      if (dom_.periodic[a]) {
        if (std::abs(d[a]) < half_period_[a]) {
          d[a] += 0.0;
        } else {
          const double P = period_[a];
          d[a] -= P * std::nearbyint(d[a] / P);
        }
      }
  }

  /// Shift id of a displacement between wrapped positions (each periodic component in (−P, P)).
  std::uint8_t shift_code(const vec<D>& dw) const {
    int code = 0, mul = 1;
    for (int a = 0; a < D; ++a, mul *= 3) {
      const int k = dom_.periodic[a] ? -static_cast<int>(std::nearbyint(dw[a] / dom_.period(a))) : 0;
      code += (k + 1) * mul;
    }
    return static_cast<std::uint8_t>(code);
  }

  cell_list<D> cells_;
  domain<D> dom_{};
  bool periodic_ = false;
  bool uniform_window_ = true;
  std::array<int, D> w_{};
  std::array<double, D> period_{}, half_period_{};  // periods (0 on open axes) and halves
  double ur2_ = 0.0;
  std::vector<double> rb_, rbs_, need_;  // build radii by particle, by sorted slot; window radius per cell
  points<D> xs_, xw_;
  std::vector<index_t> offsets_{0};
  std::vector<neighbour_t> nbr_;
  std::vector<std::uint8_t> shift_;
  std::vector<std::vector<neighbour_t>> scratch_j_;  // per-block rows of the last build (capacity kept)
  std::vector<std::vector<std::uint8_t>> scratch_s_;
  index_t rows_ = 0;
};

}  // namespace mpskit::search
