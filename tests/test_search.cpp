// search/: cell list, CSR neighbour lists against a brute-force oracle, periodic axes, mixed radii,
// visibility predicates, thread independence, kd-tree.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "archetypes/archetypes.hpp"
#include "support/support.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/search/concepts.hpp"
#include "mpskit/search/kdtree.hpp"
#include "mpskit/search/neighbour_list.hpp"

using namespace mpskit;
using namespace mpskit::search;

static_assert(RadiusModel<uniform_radius> && RadiusModel<per_particle_radius> &&
              RadiusModel<archetypes::radius_model> && !RadiusModel<int>);
static_assert(VisibilityPredicate<always_visible> && VisibilityPredicate<archetypes::visibility> &&
              !VisibilityPredicate<int>);

namespace {
constexpr std::uint64_t seed = 7331;

template <int D>
points<D> lattice(int m, double l0, double jitter, std::mt19937_64& rng) {
  return mpskit::test::jittered_lattice<D>(m, l0, jitter, rng);
}

template <int D>
points<D> random_cloud(index_t n, double box, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0.0, box);
  points<D> x(D, n);
  for (index_t i = 0; i < n; ++i)
    for (int a = 0; a < D; ++a) x(a, i) = U(rng);
  return x;
}

// The oracle: all j ≠ i with |x_ij| < R_ij (minimum image on periodic axes), by mpskit's rule.
template <int D, class R>
std::vector<std::vector<index_t>> brute(const points<D>& x, const R& radius, radius_rule rule,
                                        const domain<D>& dom, double grow = 1.0) {
  const index_t n = x.cols();
  std::vector<std::vector<index_t>> out(static_cast<std::size_t>(n));
  for (index_t i = 0; i < n; ++i)
    for (index_t j = 0; j < n; ++j) {
      if (i == j) continue;
      vec<D> d = x.col(j) - x.col(i);
      dom.minimum_image(d);
      if (within(d.squaredNorm(), pair_radius2(rule, grow * radius(i), grow * radius(j))))
        out[static_cast<std::size_t>(i)].push_back(j);
    }
  return out;
}

template <int D, class R>
std::vector<std::vector<index_t>> from_list(const neighbour_list<D>& list, const points<D>& x,
                                            const R& radius, radius_rule rule) {
  std::vector<std::vector<index_t>> out(static_cast<std::size_t>(x.cols()));
  for (index_t i = 0; i < x.cols(); ++i) {
    auto& row = out[static_cast<std::size_t>(i)];
    index_t bad_r2 = 0;
    list.for_each_neighbour(x, i, support<R>{radius, rule}, [&](index_t j, const vec<D>& d, double r2) {
      row.push_back(j);
      bad_r2 += d.squaredNorm() != r2;
    });
    CHECK(bad_r2 == 0);
    std::sort(row.begin(), row.end());
  }
  return out;
}

template <int D>
std::vector<std::vector<index_t>> stored(const neighbour_list<D>& list) {
  std::vector<std::vector<index_t>> out(static_cast<std::size_t>(list.rows()));
  for (index_t i = 0; i < list.rows(); ++i) {
    for (auto j : list.neighbours(i)) out[static_cast<std::size_t>(i)].push_back(j);
    std::sort(out[static_cast<std::size_t>(i)].begin(), out[static_cast<std::size_t>(i)].end());
  }
  return out;
}

index_t mismatches(const std::vector<std::vector<index_t>>& a, const std::vector<std::vector<index_t>>& b) {
  index_t bad = 0;
  for (std::size_t i = 0; i < a.size(); ++i) bad += a[i] != b[i];
  return bad;
}

// Runs all three rules against brute force for one cloud, radius model and domain.
template <int D, class R>
void check_all_rules(const points<D>& x, const R& radius, const domain<D>& dom, double skin) {
  neighbour_list<D> list;
  list.build(exec::seq{}, x, radius, build_options<D>{skin, dom});
  // Stored rows: exactly the max rule at the grown radius.
  CHECK(mismatches(stored(list), brute(x, radius, radius_rule::max, dom, 1.0 + skin)) == 0);
  for (radius_rule rule : {radius_rule::own, radius_rule::pair_mean, radius_rule::max}) {
    CAPTURE(name(rule));
    CHECK(mismatches(from_list(list, x, radius, rule), brute(x, radius, rule, dom)) == 0);
  }
}
}  // namespace

TEST_SUITE("search") {
  TEST_CASE_TEMPLATE("search: lists equal brute force on lattices and random clouds, uniform radius", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    MESSAGE("RNG seed " << seed);
    std::mt19937_64 rng(seed);
    const double l0 = 0.01;
    for (double skin : {0.0, 0.2}) {
      CAPTURE(skin);
      check_all_rules<D>(lattice<D>(D == 2 ? 30 : 10, l0, 0.0, rng), uniform_radius{3.1 * l0}, {}, skin);
      check_all_rules<D>(lattice<D>(D == 2 ? 30 : 10, l0, 0.1, rng), uniform_radius{2.1 * l0}, {}, skin);
      check_all_rules<D>(random_cloud<D>(D == 2 ? 900 : 1000, D == 2 ? 0.3 : 0.1, rng),
                         uniform_radius{3.1 * l0}, {}, skin);
    }
  }

  TEST_CASE_TEMPLATE("search: mixed radii with ratios 1 to 5, every rule", Dim, dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    MESSAGE("RNG seed " << seed);
    std::mt19937_64 rng(seed + 1);
    const double l0 = 0.01;
    for (double ratio : {1.0, 2.0, 3.0, 5.0}) {
      CAPTURE(ratio);
      const points<D> x = lattice<D>(D == 2 ? 36 : 11, l0, 0.2, rng);
      Eigen::VectorXd L(x.cols());
      std::uniform_real_distribution<double> U(1.0, ratio);
      for (index_t i = 0; i < x.cols(); ++i) L[i] = l0 * U(rng);
      // A block of large particles next to small ones (the hard case of window sizing).
      for (index_t i = 0; i < x.cols(); ++i)
        if (x(0, i) < 0.1 * l0 * (D == 2 ? 36 : 11)) L[i] = ratio * l0;
      check_all_rules<D>(x, per_particle_radius{&L, 3.1}, {}, 0.1);
    }
  }

  TEST_CASE_TEMPLATE("search: periodic axes use the minimum image and record shift ids", Dim, dim<2>,
                     dim<3>) {
    constexpr int D = Dim::value;
    std::mt19937_64 rng(seed + 2);
    const double l0 = 0.01;
    const int m = D == 2 ? 24 : 9;
    points<D> x = lattice<D>(m, l0, 0.15, rng);
    domain<D> dom;
    dom.lo.setConstant(-0.5 * l0);
    dom.hi.setConstant((m - 0.5) * l0);
    for (int mask = 1; mask < (1 << D); ++mask) {
      for (int a = 0; a < D; ++a) dom.periodic[a] = (mask >> a) & 1;
      CAPTURE(mask);
      check_all_rules<D>(x, uniform_radius{3.1 * l0}, dom, 0.0);
      Eigen::VectorXd L = Eigen::VectorXd::Constant(x.cols(), l0);
      for (index_t i = 0; i < x.cols(); i += 3) L[i] = 1.5 * l0;
      check_all_rules<D>(x, per_particle_radius{&L, 2.1}, dom, 0.1);
    }
    // Positions outside the period box (not yet wrapped) give the same pairs.
    for (int a = 0; a < D; ++a) dom.periodic[a] = true;
    points<D> y = x;
    for (index_t i = 0; i < y.cols(); i += 2) y(0, i) += 2.0 * dom.period(0);
    neighbour_list<D> lx, ly;
    lx.build(exec::seq{}, x, uniform_radius{3.1 * l0}, {0.0, dom});
    ly.build(exec::seq{}, y, uniform_radius{3.1 * l0}, {0.0, dom});
    CHECK(mismatches(stored(lx), stored(ly)) == 0);
    // Shift ids: the wrapped displacement plus k·P is the minimum image.
    index_t checked = 0, bad = 0;
    for (index_t i = 0; i < x.cols(); ++i) {
      const auto row = lx.neighbours(i);
      for (std::size_t q = 0; q < row.size(); ++q) {
        const index_t k = lx.offsets()[static_cast<std::size_t>(i)] + static_cast<index_t>(q);
        const auto img = neighbour_list<D>::decode_shift(lx.shift_id(k));
        vec<D> d = dom.wrap(x.col(row[q])) - dom.wrap(x.col(i));
        for (int a = 0; a < D; ++a) d[a] += img[a] * dom.period(a);
        bad += !((d - lx.displacement(x, i, row[q])).norm() < 1e-12);  // rounding of the wrap only
        checked += img != std::array<int, D>{};
      }
    }
    CHECK(bad == 0);
    CHECK(checked > 0);  // some pairs do cross the boundary
  }

  TEST_CASE("search: a visibility predicate removes pairs across a thin wall") {
    std::mt19937_64 rng(seed + 3);
    const double l0 = 0.01;
    const points<2> x = lattice<2>(20, l0, 0.1, rng);
    const double wall_x = 9.5 * l0;  // a wall of zero thickness at x = 9.5 l0
    auto vis = [&](index_t i, index_t j) { return (x(0, i) < wall_x) == (x(0, j) < wall_x); };
    neighbour_list<2> list;
    list.build(exec::seq{}, x, uniform_radius{3.1 * l0}, {}, vis);
    auto ref = brute<2>(x, uniform_radius{3.1 * l0}, radius_rule::max, {});
    index_t removed = 0;
    for (index_t i = 0; i < x.cols(); ++i) {
      auto& r = ref[static_cast<std::size_t>(i)];
      const auto before = r.size();
      std::erase_if(r, [&](index_t j) { return !vis(i, j); });
      removed += static_cast<index_t>(before - r.size());
    }
    CHECK(removed > 0);
    CHECK(mismatches(stored(list), ref) == 0);
  }

  TEST_CASE("search: rows are ascending once the state is in cell order, and reorder keeps ids") {
    std::mt19937_64 rng(seed + 4);
    particle_state<2> s(500);
    s.x() = random_cloud<2>(500, 0.2, rng);
    neighbour_list<2> list;
    list.build(exec::seq{}, s.x(), uniform_radius{0.03});
    const points<2> before = s.x();
    const std::vector<index_t> order = list.cells().order();
    s.reorder(order);
    bool moved_with_ids = true;
    for (index_t k = 0; k < s.n_real(); ++k)
      moved_with_ids &= s.x().col(k) == before.col(order[static_cast<std::size_t>(k)]) &&
                        s.ids()[static_cast<std::size_t>(k)] ==
                            static_cast<particle_id>(order[static_cast<std::size_t>(k)]);
    CHECK(moved_with_ids);
    list.build(exec::seq{}, s.x(), uniform_radius{0.03});
    index_t unsorted = 0;
    for (index_t i = 0; i < s.n_real(); ++i) {
      const auto row = list.neighbours(i);
      unsorted += !std::is_sorted(row.begin(), row.end());
    }
    CHECK(unsorted == 0);
  }

  TEST_CASE_TEMPLATE("search: kd-tree radius queries equal brute force", Dim, dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    std::mt19937_64 rng(seed + 5);
    const points<D> x = random_cloud<D>(2000, 1.0, rng);
    const kdtree<D> tree(x);
    std::vector<index_t> got;
    for (int q = 0; q < 50; ++q) {
      const vec<D> p = random_cloud<D>(1, 1.0, rng).col(0);
      const double R = 0.05 + 0.002 * q;
      tree.radius_query(p, R, got);
      std::vector<index_t> want;
      for (index_t j = 0; j < x.cols(); ++j)
        if (within((x.col(j) - p).squaredNorm(), R * R)) want.push_back(j);
      CHECK(got == want);
    }
    // A query point exactly on a data point at distance R from another: strict rule r < R.
    points<D> y = points<D>::Zero(D, 2);
    y(0, 1) = 0.5;
    const kdtree<D> t2(y);
    t2.radius_query(y.col(0), 0.5, got);
    CHECK(got == std::vector<index_t>{0});
    CHECK(t2.nearest(y.col(1), 1) == std::vector<index_t>{1});
  }
}

TEST_SUITE("bad_input") {
  TEST_CASE("search: bad input is refused with a message naming the problem") {
    points<2> x = points<2>::Zero(2, 3);
    x(0, 1) = 1.0;
    x(0, 2) = 2.0;
    neighbour_list<2> list;
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, points<2>(2, 0), uniform_radius{1.0}),
                         doctest::Contains("empty"), mpskit::error);
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, uniform_radius{0.0}), doctest::Contains("radius R = 0"),
                         mpskit::error);
    CHECK_THROWS_AS(list.build(exec::seq{}, x, uniform_radius{-1.0}), mpskit::error);
    Eigen::VectorXd L(3);
    L << 1.0, -2.0, 1.0;
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, per_particle_radius{&L, 1.0}),
                         doctest::Contains("radius of particle 1"), mpskit::error);
    Eigen::VectorXd L2(2);
    L2 << 1.0, 1.0;
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, per_particle_radius{&L2, 1.0}),
                         doctest::Contains("2 entries"), mpskit::error);
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, uniform_radius{1.0}, {-0.1, {}}),
                         doctest::Contains("skin"), mpskit::error);
    x(1, 2) = std::nan("");
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, uniform_radius{1.0}), doctest::Contains("particle 2"),
                         mpskit::error);
    x(1, 2) = 0.0;
    domain<2> dom;
    dom.periodic = {true, false};
    dom.lo << 0.0, 0.0;
    dom.hi << 1.5, 0.0;
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, uniform_radius{1.0}, {0.0, dom}),
                         doctest::Contains("period"), mpskit::error);
    dom.hi << -1.0, 0.0;
    CHECK_THROWS_AS(list.build(exec::seq{}, x, uniform_radius{0.1}, {0.0, dom}), mpskit::error);
    // One particle very far away: refused rather than a huge grid.
    x(0, 2) = 1e12;
    CHECK_THROWS_WITH_AS(list.build(exec::seq{}, x, uniform_radius{1.0}), doctest::Contains("cells"),
                         mpskit::error);
    CHECK_THROWS_AS(kdtree<2>(points<2>(2, 0)), mpskit::error);
  }
}

TEST_SUITE("search_threads") {
  TEST_CASE("search: lists are identical for 1 and 2 threads") {
#ifdef _OPENMP
    std::mt19937_64 rng(seed + 6);
    const points<2> x = lattice<2>(120, 0.01, 0.2, rng);
    Eigen::VectorXd L(x.cols());
    std::uniform_real_distribution<double> U(1.0, 3.0);
    for (index_t i = 0; i < x.cols(); ++i) L[i] = 0.01 * U(rng);
    domain<2> dom;
    dom.periodic = {true, false};
    dom.lo << -0.005, 0.0;
    dom.hi << 1.195, 0.0;
    neighbour_list<2> a, b;
    omp_set_num_threads(1);
    a.build(exec::par{}, x, per_particle_radius{&L, 3.1}, {0.1, dom});
    omp_set_num_threads(2);
    b.build(exec::par{}, x, per_particle_radius{&L, 3.1}, {0.1, dom});
    CHECK(a.offsets() == b.offsets());
    CHECK(a.indices() == b.indices());
    bool same_shift = true;
    for (index_t k = 0; k < a.pairs(); ++k) same_shift &= a.shift_id(k) == b.shift_id(k);
    CHECK(same_shift);
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
}
