// resolution/: Tanaka 2018 §4.4 particle splitting and merging (eqs. 65–74) and the conservation ledger.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "archetypes/resolution.hpp"
#include "cases/gears_options.hpp"
#include "cases/multires_dam_break_options.hpp"
#include "cases/polygon_tank.hpp"
#include "cases/run_measures.hpp"
#include "cases/tanaka_dam_break_run.hpp"
#include "cases/tanaka_obstacle_multires.hpp"
#include "cases/taylor_green.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/io/lsmps_checkpoint.hpp"
#include "mpskit/resolution/concepts.hpp"
#include "mpskit/resolution/graded_lattice.hpp"
#include "mpskit/resolution/ledger.hpp"
#include "mpskit/resolution/split_merge.hpp"
#include "mpskit/scene.hpp"
#include "speed_up.hpp"
#include "support/support.hpp"
#include "mpskit/scheme/lsmps_semi_implicit.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/wall/dummy_layers.hpp"
#include "mpskit/wall/imaginary.hpp"

using namespace mpskit;
namespace res = mpskit::resolution;

// Wall models: dummy layers are refused at compile time (Tanaka §4.5.1), polygon walls accepted.
static_assert(!res::ResolutionCompatibleWalls<wall::dummy_layers>);
static_assert(res::ResolutionCompatibleWalls<wall::imaginary>);
static_assert(res::ResolutionCompatibleWalls<scheme::no_walls>);
static_assert(res::Trigger<res::tanaka_thresholds> && !res::Trigger<double>);
static_assert(res::SplitPattern<res::two_way> && !res::SplitPattern<double>);
static_assert(res::Trigger<archetypes::trigger> && res::SplitPattern<archetypes::split_pattern>);
static_assert(std::same_as<res::split_merge<>::fields, field_list<field::volume>>);

namespace {

/// Tanaka's LSMPS scene (polygon walls, free surface, shifting) with split/merge.
template <int D>
struct tank_multires : lsmps_defaults<D> {
  using resolution = mpskit::resolution::split_merge<>;
};

/// The tank at rest that the stepper tests refine on its right part: W = 0.1 m, H = 0.05 m, 60° incline
/// (B = 0.04 m), L = 0.01 m.
cases::polygon_tank_config refined_tank_config() {
  cases::polygon_tank_config tc;
  tc.W = 0.1;
  tc.H = 0.05;
  tc.tank_height = 0.1;
  tc.L = 0.01;
  tc.B = 0.04;
  return tc;
}

/// The Taylor–Green scene with split/merge as its resolution policy.
struct tg_multires : cases::taylor_green_scene {
  using resolution = mpskit::resolution::split_merge<>;
};
static_assert(simulation<tg_multires>::has_resolution &&
              !simulation<cases::taylor_green_scene>::has_resolution);

template <int D>
using sm_state = particle_state<D, field_list<field::pressure, field::volume>>;

constexpr double l0 = 0.01;

std::uint64_t seed_used() {
  const std::uint64_t seed = 20261124;
  MESSAGE("RNG seed " << seed);
  return seed;
}

/// A state plus what split/merge reads (diameters from volumes, a list at R_e = 3.1, normals, flags).
template <int D>
struct world {
  sm_state<D> s;
  Eigen::VectorXd L;
  search::neighbour_list<D> nl;
  points<D> normals;
  std::vector<flag::type> flags;
  search::domain<D> dom{};
  const geometry::polygon_set<D>* walls = nullptr;

  void refresh() {
    const index_t n = s.size();
    const auto& V = s.template get<field::volume>();
    L.resize(n);
    for (index_t i = 0; i < n; ++i) L[i] = D == 2 ? std::sqrt(V[i]) : std::cbrt(V[i]);
    nl.build(exec::par{}, s.x(), search::per_particle_radius{&L, 3.1}, {0.2, dom});
    if (normals.cols() != n) normals = points<D>::Zero(D, n);
    if (static_cast<index_t>(flags.size()) != n) flags.assign(static_cast<std::size_t>(n), 0);
  }
  res::split_merge_inputs<D> inputs() const { return {&nl, &L, &normals, &flags, walls}; }

  template <class GradU>
  res::split_merge_report<D> run(const res::split_merge_params<D>& p, GradU&& g,
                                 res::conservation_ledger<D>* led = nullptr) {
    refresh();
    return res::split_merge<>::apply(exec::par{}, s, inputs(), p, std::forward<GradU>(g), led);
  }
};

/// Fills a state from positions, one volume each (velocities zero).
template <int D>
sm_state<D> make_state(const points<D>& x, double V) {
  sm_state<D> s(x.cols());
  s.x() = x;
  s.template get<field::volume>().setConstant(V);
  return s;
}

/// Lattice with spacing (h_0, h_1[, h_2]) and m_a points per axis.
template <int D>
points<D> lattice(const std::array<int, D>& m, const vec<D>& h) {
  index_t n = 1;
  for (int a = 0; a < D; ++a) n *= m[static_cast<std::size_t>(a)];
  points<D> x(D, n);
  for (index_t k = 0; k < n; ++k) {
    index_t r = k;
    for (int a = 0; a < D; ++a) {
      x(a, k) = static_cast<double>(r % m[static_cast<std::size_t>(a)]) * h[a];
      r /= m[static_cast<std::size_t>(a)];
    }
  }
  return x;
}

template <int D>
index_t nearest(const points<D>& x, const vec<D>& p) {
  index_t best = 0;
  for (index_t i = 1; i < x.cols(); ++i)
    if ((x.col(i) - p).squaredNorm() < (x.col(best) - p).squaredNorm()) best = i;
  return best;
}

/// L* = small within r of c, else l0 (nobody else wants an event).
template <int D>
res::split_merge_params<D> split_at(const vec<D>& c, double r) {
  res::split_merge_params<D> p;
  p.target_diameter = [c, r](const vec<D>& x) { return (x - c).norm() < r ? 0.5 * l0 : l0; };
  return p;
}

template <int D>
mat<D> zero_grad(index_t) {
  return mat<D>::Zero();
}

/// Sorted (x, u, V, p) of every real particle: an order-free picture of a state, compared bitwise.
template <int D>
std::vector<std::vector<double>> picture(const sm_state<D>& s) {
  std::vector<std::vector<double>> rows;
  for (index_t i = 0; i < s.n_real(); ++i) {
    std::vector<double> r;
    for (int a = 0; a < D; ++a) r.push_back(s.x()(a, i));
    for (int a = 0; a < D; ++a) r.push_back(s.u()(a, i));
    r.push_back(s.template get<field::volume>()[i]);
    r.push_back(s.template get<field::pressure>()[i]);
    rows.push_back(std::move(r));
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}
template <class T>
bool bitwise_equal(const std::vector<std::vector<T>>& a, const std::vector<std::vector<T>>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].size() != b[i].size() || std::memcmp(a[i].data(), b[i].data(), a[i].size() * sizeof(T)) != 0)
      return false;
  return true;
}

/// A deterministic velocity gradient per particle id (so it follows a particle through a permutation).
template <int D>
mat<D> grad_of_id(particle_id id) {
  std::mt19937_64 r(id * 7919u + 17u);
  std::uniform_real_distribution<double> U(-50.0, 50.0);
  mat<D> G;
  for (int a = 0; a < D; ++a)
    for (int b = 0; b < D; ++b) G(a, b) = U(r);
  return G;
}

/// Random state: jittered lattice, volumes V ∈ [0.6, 1.6] l0^D, velocities of magnitudes 10^[-3, 2] m/s,
/// pressures; L* alternates split / keep / merge regions (period 6 l0 along x).
template <int D>
world<D> random_world(int m, std::mt19937_64& rng) {
  world<D> w;
  std::uniform_real_distribution<double> J(-0.15, 0.15), Vr(0.6, 1.6), E(-3.0, 2.0), N(-1.0, 1.0),
      P(0.0, 1e4);
  const int mz = D == 3 ? m : 1;
  const index_t n = static_cast<index_t>(m) * m * mz;
  w.s = sm_state<D>(n);
  auto& V = w.s.template get<field::volume>();
  auto& pr = w.s.template get<field::pressure>();
  index_t k = 0;
  for (int c = 0; c < mz; ++c)
    for (int b = 0; b < m; ++b)
      for (int a = 0; a < m; ++a, ++k) {
        w.s.x()(0, k) = (a + J(rng)) * l0;
        w.s.x()(1, k) = (b + J(rng)) * l0;
        if constexpr (D == 3) w.s.x()(2, k) = (c + J(rng)) * l0;
        V[k] = Vr(rng) * std::pow(l0, D);
        vec<D> dir;
        for (int q = 0; q < D; ++q) dir[q] = N(rng);
        w.s.u().col(k) = std::pow(10.0, E(rng)) * dir;
        pr[k] = P(rng);
      }
  return w;
}
template <int D>
res::split_merge_params<D> banded_target() {
  res::split_merge_params<D> p;
  p.target_diameter = [](const vec<D>& x) {
    const double phase = std::fmod(x[0] / (6.0 * l0) + 100.0, 1.0);
    return phase < 1.0 / 3 ? 0.4 * l0 : phase < 2.0 / 3 ? l0 : 3.0 * l0;
  };
  return p;
}

}  // namespace

TEST_SUITE("split_merge") {
  TEST_CASE("cases: min_pair_ratios reads the clustering measure with and without isolated particles") {
    // Issue #9's clustering measure r_ij / L_ij (L_ij the mean diameter): a pair 0.8 L apart, a pair 0.2 L
    // apart of which one is flagged isolated, and a lone particle; diameters 2 mm and 4 mm in the second pair
    // (L_ij = 3 mm).
    const double l = 2e-3;
    points<2> x(2, 5);
    x << 0.0, 0.8 * l, 0.1, 0.1 + 0.2 * 1.5 * l, 0.5,  //
        0.0, 0.0, 0.0, 0.0, 0.5;
    auto s = make_state<2>(x, l * l);
    s.get<field::volume>()[3] = 4.0 * l * l;
    const search::domain<2> dom{};
    cases::pair_ratios q = cases::min_pair_ratios(s, dom);
    CHECK(q.all == doctest::Approx(0.2).epsilon(1e-12));
    CHECK(q.non_isolated == doctest::Approx(0.2).epsilon(1e-12));
    s.flags()[3] = flag::isolated;
    q = cases::min_pair_ratios(s, dom);
    CHECK(q.all == doctest::Approx(0.2).epsilon(1e-12));       // every pair: the isolated one counts
    CHECK(q.non_isolated == doctest::Approx(0.8).epsilon(1e-12));  // spray left out
    CHECK(cases::min_pair_ratio(s, dom) == q.all);
    s.x().col(1) = vec<2>(0.3, 0.3);  // no non-isolated pair within 1.5 L_ij
    CHECK(cases::min_pair_ratios(s, dom).non_isolated == 1e300);
  }


  TEST_CASE("speed-up at equal error (issue #9 reporter): power-law interpolation, bounds, bad input") {
    using bench::cost_point;
    using kind = bench::speed_up_result::kind;
    // A convergent single-resolution curve e = 0.3 t^(-1/2): log-log interpolation reproduces it exactly, so
    // a multi-resolution run with e = 0.3 / sqrt(30) taking 5 s is worth 30 s of single resolution: speed-up
    // 6.
    const auto e = [](double t) { return 0.3 / std::sqrt(t); };
    const std::vector<cost_point> curve{{100.0, e(100.0)}, {1.0, e(1.0)}, {10.0, e(10.0)}};  // any order
    const auto r = bench::speed_up(curve, {5.0, e(30.0)});
    CHECK(r.how == kind::interpolated);
    CHECK(r.single_seconds == doctest::Approx(30.0).epsilon(1e-12));
    CHECK(r.speed_up == doctest::Approx(6.0).epsilon(1e-12));
    // On a measured point: that point's time.
    CHECK(bench::speed_up(curve, {2.0, e(10.0)}).speed_up == doctest::Approx(5.0).epsilon(1e-14));
    // Worse than the cheapest single run: single needs at most 1 s, speed-up <= 1/5 (a bound, not
    // extrapolated).
    const auto worse = bench::speed_up(curve, {5.0, 1.0});
    CHECK(worse.how == kind::at_most);
    CHECK(worse.speed_up == doctest::Approx(0.2).epsilon(1e-14));
    // Better than the dearest single run: single needs at least 100 s, speed-up >= 20.
    const auto better = bench::speed_up(curve, {5.0, 1e-3});
    CHECK(better.how == kind::at_least);
    CHECK(better.speed_up == doctest::Approx(20.0).epsilon(1e-14));
    // The names the reporter writes: the CSV's kind column and the printed bound.
    CHECK(std::string(r.kind_name()) == "interpolated");
    CHECK(std::string(r.bound_prefix()).empty());
    CHECK(std::string(worse.kind_name()) == "at_most");
    CHECK(std::string(worse.bound_prefix()) == "<= ");
    CHECK(std::string(better.kind_name()) == "at_least");
    CHECK(std::string(better.bound_prefix()) == ">= ");
    CHECK(r.dominated == 0);
    // A curve that rises somewhere (the obstacle study's 5 mm outlier, docs/validation.md): the 4 s run is no
    // better than the 1 s run, so it is dropped and the lower envelope (1 s, 0.05), (16 s, 0.04) is read. An
    // error of 0.055 is then above every kept run: single resolution needs at most 1 s (the whole curve's
    // first crossing, on the rising 1–4 s segment, said 2.3 s).
    const std::vector<cost_point> rising{{1.0, 0.05}, {4.0, 0.06}, {16.0, 0.04}};
    const auto x = bench::speed_up(rising, {2.0, 0.055});
    CHECK(x.how == kind::at_most);
    CHECK(x.dominated == 1);
    CHECK(x.single_seconds == 1.0);
    CHECK(x.speed_up == 0.5);
    // 0.045 lies on the envelope's segment from 1 s to 16 s (not on the 4–16 s segment of the whole curve).
    const auto y = bench::speed_up(rising, {2.0, 0.045});
    CHECK(y.how == kind::interpolated);
    CHECK(y.single_seconds ==
          doctest::Approx(std::exp(std::log(16.0) * std::log(0.9) / std::log(0.8))).epsilon(1e-12));
    // An equal error at a higher cost is dominated too.
    CHECK(bench::speed_up({{1.0, 0.05}, {2.0, 0.05}, {4.0, 0.02}}, {1.0, 0.03}).dominated == 1);
    CHECK_THROWS_WITH_AS(bench::speed_up({}, {1.0, 0.1}), doctest::Contains("no single-resolution run"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(bench::speed_up(curve, {0.0, 0.1}), doctest::Contains("multi-resolution run"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(bench::speed_up({{1.0, std::nan("")}}, {1.0, 0.1}),
                         doctest::Contains("single-resolution run"), mpskit::error);
  }
  TEST_CASE("split_merge: thresholds β_s (eq. 66) and β_m (eq. 71) from the paper's formulas") {
    using T = res::tanaka_thresholds;
    const double bs2 = T::beta_s<2>(), bs3 = T::beta_s<3>(), bm2 = T::beta_m<2>(), bm3 = T::beta_m<3>();
    MESSAGE("beta_s 2D = " << bs2 << ", 3D = " << bs3 << "; beta_m 2D = " << bm2 << ", 3D = " << bm3);
    CHECK(bs2 == doctest::Approx(0.5 * (std::pow(0.5, 1.0 / 2) + 1.0)).epsilon(1e-15));
    CHECK(bs3 == doctest::Approx(0.5 * (std::pow(0.5, 1.0 / 3) + 1.0)).epsilon(1e-15));
    CHECK(bm2 == doctest::Approx(std::pow(2.0, 1.0 / 2)).epsilon(1e-15));
    CHECK(bm3 == doctest::Approx(std::pow(2.0, 1.0 / 3)).epsilon(1e-15));
    // The issue's five-digit values.
    CHECK(std::abs(bs2 - 0.85355) < 5e-6);
    CHECK(std::abs(bs3 - 0.89685) < 5e-6);
    CHECK(std::abs(bm2 - 1.41421) < 5e-6);
    CHECK(std::abs(bm3 - 1.25992) < 5e-6);
    CHECK(res::two_way::child_ratio<2>() == doctest::Approx(std::sqrt(0.5)).epsilon(1e-15));
    CHECK(res::two_way::child_ratio<3>() == doctest::Approx(std::cbrt(0.5)).epsilon(1e-15));
    // Strict inequalities at the thresholds; hysteresis: children do not merge, merged particles do not
    // split.
    CHECK(T::decide<2>(0.85 * l0, l0) == res::want::split);
    CHECK(T::decide<2>(bs2 * l0, l0) == res::want::none);
    CHECK(T::decide<2>(bm2 * l0, l0) == res::want::none);
    CHECK(T::decide<2>(1.42 * l0, l0) == res::want::merge);
    for (int d : {2, 3}) {
      const double bs = d == 2 ? bs2 : bs3, bm = d == 2 ? bm2 : bm3, child = std::pow(0.5, 1.0 / d);
      // L* < β_s L ⇒ L* < β_m L′ = L: a child never merges at once
      CHECK(bs * l0 <= bm * (child * l0) + 1e-18);
      CHECK(bm * l0 >= bs * (bm * l0));  // L* > β_m L = L′ ⇒ L* > β_s L′: a merged pair never splits
    }
  }

  // min r_ij/L_ij of a graded lattice over pairs closer than L in x (a sweep over the particles sorted by x;
  // every pair farther apart has r_ij ≥ L ≥ L_ij), L_ij the mean of the two diameters V^(1/D).
  template <int D>
  double graded_min_ratio(const res::graded_points<D>& g, double L) {
    const auto diameter = [&](std::size_t i) {
      return D == 2 ? std::sqrt(g.volume[i]) : std::cbrt(g.volume[i]);
    };
    std::vector<std::size_t> by_x(g.size());
    std::iota(by_x.begin(), by_x.end(), std::size_t{0});
    std::sort(by_x.begin(), by_x.end(),
              [&](std::size_t a, std::size_t b) { return g.x[a].x() < g.x[b].x(); });
    double rmin = 1e300;
    for (std::size_t a = 0; a < by_x.size(); ++a)
      for (std::size_t b = a + 1; b < by_x.size() && g.x[by_x[b]].x() - g.x[by_x[a]].x() < L; ++b) {
        const std::size_t i = by_x[a], j = by_x[b];
        rmin = std::min(rmin, (g.x[i] - g.x[j]).norm() / (0.5 * (diameter(i) + diameter(j))));
      }
    return rmin;
  }

  TEST_CASE(
      "graded_lattice: lattices kept, volumes halved exactly, a fixed point of the trigger, no clustering") {
    using T = res::tanaka_thresholds;
    // a power of two: positions, volumes L²/2^k and their sums are exact
    const double L = std::ldexp(1.0, -10);
    const auto all = [](const vec<2>&, double) { return true; };
    const auto sorted = [](std::vector<vec<2>> v) {
      std::sort(v.begin(), v.end(), [](const vec<2>& a, const vec<2>& b) {
        return std::tie(a.y(), a.x()) < std::tie(b.y(), b.x());
      });
      return v;
    };
    SUBCASE("a uniform target L/2: two splits per cell give the cell-centred square lattice of spacing L/2") {
      const auto g = res::graded_lattice(
          vec<2>(0, 0), vec<2>(7 * L, 5 * L), L, [&](const vec<2>&) { return 0.5 * L; }, all);
      REQUIRE(g.size() == 4u * 35u);
      std::vector<vec<2>> want;
      for (int i = 0; i < 14; ++i)
        for (int j = 0; j < 10; ++j) want.emplace_back((i + 0.5) * 0.5 * L, (j + 0.5) * 0.5 * L);
      CHECK(sorted(g.x) == sorted(want));  // bitwise: dyadic numbers
      for (std::size_t q = 0; q < g.size(); ++q) {
        CHECK(g.generation[q] == 2);
        CHECK(g.volume[q] == 0.25 * L * L);
      }
    }
    SUBCASE("a uniform target 0.7 L: one split per cell gives the 45°-rotated lattice of spacing L/√2") {
      const auto g = res::graded_lattice(
          vec<2>(0, 0), vec<2>(6 * L, 6 * L), L, [&](const vec<2>&) { return 0.7 * L; }, all);
      REQUIRE(g.size() == 72u);
      // An interior particle has exactly four neighbours at L/√2, along the diagonals.
      const vec<2> c(3.25 * L, 3.25 * L);
      int at = 0;
      for (const auto& x : g.x) {
        const vec<2> d = x - c;
        if (d.norm() > 1e-9 * L && d.norm() < 0.75 * L) {
          CHECK(d.norm() == doctest::Approx(L / std::numbers::sqrt2).epsilon(1e-13));
          CHECK(std::abs(d.x()) == std::abs(d.y()));
          ++at;
        }
      }
      CHECK(at == 4);
    }
    SUBCASE("ramps and steps from L to L/R: ΣV exact, every leaf asks for nothing, min r_ij/L_ij bounded") {
      for (const double R : {2.0, 3.0, 5.0, 8.0})
        for (const bool step : {false, true}) {
          CAPTURE(R);
          CAPTURE(step);
          // L/R within 10 L of x = 30 L (a step at 10.3 L, or a ramp back to L at 25 L), L at the box's ends.
          const auto target = [&](const vec<2>& x) {
            const double d = std::abs(x.x() - 30 * L);
            if (step) return d < 10.3 * L ? L / R : L;
            return L * (1.0 - std::clamp((25 * L - d) / (15 * L), 0.0, 1.0) * (1.0 - 1.0 / R));
          };
          const auto g = res::graded_lattice(vec<2>(0, 0), vec<2>(60 * L, 20 * L), L, target, all);
          double V = 0.0;
          int kmax = 0, outside = 0, asking = 0;
          for (std::size_t a = 0; a < g.size(); ++a) {
            V += g.volume[a];
            kmax = std::max(kmax, g.generation[a]);
            const vec<2>& x = g.x[a];
            const double h = std::sqrt(g.volume[a]);
            outside += !(x.x() > 0.0 && x.x() < 60 * L && x.y() > 0.0 && x.y() < 20 * L);
            // Fixed point: split_merge's trigger neither splits nor merges the particle at its own position
            // (squares by construction; diagonal pairs were decided at their cell's centre, see the header).
            asking += T::decide<2>(target(x), h) != res::want::none;
          }
          const double rmin = graded_min_ratio(g, L);
          CHECK(outside == 0);  // strictly inside the box
          CHECK(asking == 0);
          CHECK(V == 1200.0 * L * L);  // the 60 × 20 start cells' area, bitwise (powers of two)
          // Generations: the smallest k with L* ≥ β_s L/√2^k at the finest target L/R.
          int k = 0;
          while (L / R < T::beta_s<2>() * L / std::pow(std::numbers::sqrt2, k)) ++k;
          CHECK(kmax == k);
          // Measured 0.828 (2√2 − 2) on the ramps and 0.94–1 on the steps; 0.8 is far above the issue's 0.5.
          MESSAGE("R = " << R << (step ? " step" : " ramp") << ": " << g.size()
                         << " particles, min r_ij/L_ij = " << rmin);
          CHECK(rmin >= 0.8);
        }
    }
    SUBCASE("keep filters the particles, not the start cells; bad input is refused") {
      // A wall at y = 0.3 L: the bottom start cells' centres (y = L/2, 0.2 L from it) would not be kept at L,
      // but their upper children (y = 0.75 L, 0.45 L ≥ h/2 = 0.354 L from it) are; their lower ones (y = L/4)
      // are not.
      const auto g = res::graded_lattice(
          vec<2>(0, 0), vec<2>(4 * L, 4 * L), L, [&](const vec<2>&) { return 0.7 * L; },
          [&](const vec<2>& x, double h) { return x.y() - 0.3 * L >= 0.5 * h; });
      for (const auto& x : g.x) CHECK(x.y() >= 0.75 * L);
      CHECK(g.size() == 28u);  // 16 cells × 2 particles, the 4 lower ones of the bottom row dropped
      CHECK(g.dropped_volume == 2.0 * L * L);  // their volume, L²/2 each, reported (bitwise: powers of two)
      const auto t = [&](const vec<2>&) { return L; };
      CHECK_THROWS_WITH_AS(res::graded_lattice(vec<2>(0, 0), vec<2>(L, L), 0.0, t, all),
                           doctest::Contains("start spacing"), mpskit::error);
      CHECK_THROWS_WITH_AS(res::graded_lattice(vec<2>(0, 0), vec<2>(0, L), L, t, all),
                           doctest::Contains("is empty"), mpskit::error);
      CHECK_THROWS_WITH_AS(
          res::graded_lattice(vec<2>(0, 0), vec<2>(L, L), L, [](const vec<2>&) { return std::nan(""); }, all),
          doctest::Contains("target diameter is nan"), mpskit::error);
      CHECK_THROWS_WITH_AS(
          res::graded_lattice(vec<2>(0, 0), vec<2>(L, L), L, [&](const vec<2>&) { return 1e-9 * L; }, all),
          doctest::Contains("still asks to split after 20 generations"), mpskit::error);
    }
  }

  TEST_CASE(
      "graded_lattice 3D: cubic, BCC and FCC lattices, volumes halved exactly, a fixed point of the "
      "trigger") {
    using T = res::tanaka_thresholds;
    // a power of two: positions, volumes L³/2^k and their sums are exact
    const double L = std::ldexp(1.0, -10);
    const auto all = [](const vec<3>&, double) { return true; };
    // Nearest-neighbour distances of the particle closest to c (interior) and how many are at that distance.
    const auto shell = [](const res::graded_points<3>& g, const vec<3>& c) {
      std::size_t me = 0;
      for (std::size_t a = 1; a < g.size(); ++a)
        if ((g.x[a] - c).norm() < (g.x[me] - c).norm()) me = a;
      double dmin = 1e300;
      for (std::size_t a = 0; a < g.size(); ++a)
        if (a != me) dmin = std::min(dmin, (g.x[a] - g.x[me]).norm());
      int n = 0;
      for (std::size_t a = 0; a < g.size(); ++a)
        if (a != me && (g.x[a] - g.x[me]).norm() < dmin * (1.0 + 1e-12)) ++n;
      return std::pair<double, int>(dmin, n);
    };
    SUBCASE(
        "a uniform target L/2: three splits per cell give the cell-centred cubic lattice of spacing L/2") {
      const auto g = res::graded_lattice(vec<3>(0, 0, 0), vec<3>(3 * L, 2 * L, 2 * L), L,
                                         [&](const vec<3>&) { return 0.5 * L; }, all);
      REQUIRE(g.size() == 8u * 12u);
      CHECK(g.dropped_volume == 0.0);
      std::set<std::tuple<double, double, double>> got, want;
      for (const auto& x : g.x) got.emplace(x.x(), x.y(), x.z());
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 4; ++j)
          for (int l = 0; l < 4; ++l)
            want.emplace((i + 0.5) * 0.5 * L, (j + 0.5) * 0.5 * L, (l + 0.5) * 0.5 * L);
      CHECK(got == want);  // bitwise: dyadic numbers
      for (std::size_t q = 0; q < g.size(); ++q) {
        CHECK(g.generation[q] == 3);
        CHECK(g.volume[q] == 0.125 * L * L * L);
      }
    }
    SUBCASE("one split per cell (L* = 0.8 L): body-centred cubic, 8 neighbours at (√3/2) L") {
      const auto g = res::graded_lattice(vec<3>(0, 0, 0), vec<3>(4 * L, 4 * L, 4 * L), L,
                                         [&](const vec<3>&) { return 0.8 * L; }, all);
      REQUIRE(g.size() == 128u);
      for (int k : g.generation) CHECK(k == 1);
      const auto [d, n] = shell(g, vec<3>(2 * L, 2 * L, 2 * L));
      CHECK(d == doctest::Approx(0.5 * std::sqrt(3.0) * L).epsilon(1e-13));
      CHECK(n == 8);
    }
    SUBCASE("two splits per cell (L* = 0.65 L): face-centred cubic, 12 neighbours at L/√2") {
      const auto g = res::graded_lattice(vec<3>(0, 0, 0), vec<3>(4 * L, 4 * L, 4 * L), L,
                                         [&](const vec<3>&) { return 0.65 * L; }, all);
      REQUIRE(g.size() == 256u);
      for (int k : g.generation) CHECK(k == 2);
      const auto [d, n] = shell(g, vec<3>(2 * L, 2 * L, 2 * L));
      CHECK(d == doctest::Approx(L / std::numbers::sqrt2).epsilon(1e-13));
      CHECK(n == 12);
    }
    SUBCASE(
        "ramps and steps from L to L/R: ΣV exact, no particle asking at its own position, min r_ij/L_ij "
        "bounded") {
      for (const double R : {2.0, 3.0, 4.0})
        for (const bool step : {false, true}) {
          CAPTURE(R);
          CAPTURE(step);
          // L/R within 2 L of x = 8 L (a step at 2.3 L, or a ramp back to L at 6 L), L at the box's ends.
          const auto target = [&](const vec<3>& x) {
            const double d = std::abs(x.x() - 8 * L);
            if (step) return d < 2.3 * L ? L / R : L;
            return L * (1.0 - std::clamp((6 * L - d) / (4 * L), 0.0, 1.0) * (1.0 - 1.0 / R));
          };
          const auto g = res::graded_lattice(vec<3>(0, 0, 0), vec<3>(16 * L, 4 * L, 4 * L), L, target, all);
          double V = 0.0;
          int kmax = 0, outside = 0, asking = 0;
          for (std::size_t a = 0; a < g.size(); ++a) {
            V += g.volume[a];
            kmax = std::max(kmax, g.generation[a]);
            const vec<3>& x = g.x[a];
            outside += !((x.array() > 0.0).all() && x.x() < 16 * L && x.y() < 4 * L && x.z() < 4 * L);
            asking += T::decide<3>(target(x), std::cbrt(g.volume[a])) != res::want::none;
          }
          const double rmin = graded_min_ratio(g, L);
          CHECK(outside == 0);
          CHECK(V == 256.0 * L * L * L);  // the 16 × 4 × 4 start cells' volume, bitwise (powers of two)
          int k = 0;
          while (L / R < T::beta_s<3>() * L * std::pow(0.5, k / 3.0)) ++k;
          CHECK(kmax == k);
          MESSAGE("3D R = " << R << (step ? " step" : " ramp") << ": " << g.size()
                            << " particles, min r_ij/L_ij = " << rmin << ", asking " << asking);
          // Steps: every particle is a fixed point (measured 0). Ramps: a pattern's particles lie (h/4)√3
          // from the cell centre where it was decided, and a 3D generation changes the diameter by 2^(1/3)
          // only, so some ask for an event at their own position (measured 0, 224 and 288 particles, at most
          // 8.2 %); split_merge then acts on them in the first step.
          if (step) CHECK(asking == 0);
          else CHECK(asking <= 0.1 * static_cast<double>(g.size()));
          // Measured 1, 0.99 and 1 on the steps; 0.702 on the ramps: a body-centred pair (0.79 h) beside a
          // cell three generations deeper (its pair of 0.40 h) across a face. 2D ramps give 0.828. Far above
          // the issue's 0.5.
          CHECK(rmin >= (step ? 0.95 : 0.68));
        }
    }
  }

  TEST_CASE("split_merge: particle_state::gather is one resize (born particles get new ids)") {
    sm_state<2> s(4);
    for (index_t i = 0; i < 4; ++i) {
      s.x()(0, i) = static_cast<double>(i);
      s.template get<field::pressure>()[i] = 10.0 * static_cast<double>(i);
    }
    const particle_id next = s.next_id();
    // Keep 0, split 1 into two born copies, drop 2, keep 3.
    const auto rep = s.gather({0, 1, 1, 3}, {0, 1, 1, 0});
    CHECK(s.n_real() == 4);
    CHECK(rep.appended == 2);
    CHECK(rep.removed == 2);
    CHECK(rep.old_to_new == std::vector<index_t>{0, npos, npos, 3});
    CHECK(s.ids()[0] == 0);
    CHECK(s.ids()[3] == 3);
    CHECK(s.ids()[1] == next);
    CHECK(s.ids()[2] == next + 1);
    CHECK(s.template get<field::pressure>()[2] == 10.0);
    CHECK(s.x()(0, 1) == 1.0);
    s.validate();
    CHECK_THROWS_AS(s.gather({0, 0}, {0, 0}), mpskit::error);  // one old particle kept twice
    CHECK_THROWS_AS(s.gather({0, 7}, {0, 1}), mpskit::error);  // not a particle
  }

  TEST_CASE("split_merge: the trigger is a policy (a later method replaces only it)") {
    world<2> w;
    w.s = make_state<2>(lattice<2>({5, 5}, vec<2>(l0, l0)), l0 * l0);
    res::split_merge_params<2> p;
    p.target_diameter = [](const vec<2>&) { return 0.1 * l0; };  // Tanaka's trigger would split everything
    w.refresh();
    const auto rep = res::split_merge<archetypes::trigger, archetypes::split_pattern>::apply(
        exec::seq{}, w.s, w.inputs(), p, zero_grad<2>);
    CHECK(rep.wanted_split == 0);
    CHECK(rep.splits == 0);
    CHECK(w.s.n_real() == 25);
  }

  TEST_CASE("split_merge: 2D square lattice splits along the diagonal with e_i computed by hand") {
    world<2> w;
    w.s = make_state<2>(lattice<2>({7, 7}, vec<2>(l0, l0)), l0 * l0);
    const index_t c = nearest<2>(w.s.x(), vec<2>(3 * l0, 3 * l0));
    const particle_id cid = w.s.ids()[static_cast<std::size_t>(c)];
    auto p = split_at<2>(vec<2>(3 * l0, 3 * l0), 0.2 * l0);
    const auto rep = w.run(p, zero_grad<2>);
    REQUIRE(rep.splits == 1);
    CHECK(rep.wanted_split == 1);
    CHECK(rep.merges == 0);
    const auto& ev = rep.split_events[0];
    CHECK(ev.parent_id == cid);
    // By hand: L′ = l0/√2 (eq. 65), δ = (α_t/2) L′ = 0.35 l0/√2 (eq. 67). Along an axis the child comes δ
    // closer to the nearest neighbour: e = δ/l0 = 0.247487. Along the diagonal it sits at (c, c) with
    // c = δ/√2 = 0.175 l0 and the nearest neighbours at (l0, 0), (0, l0): e = 1 − √((1 − 0.175)² + 0.175²)
    // = 0.156644 (diagonal neighbours stay beyond L_ij). The diagonal minimises e_i; 45° and 135° tie and
    // the lower candidate index (45°) wins.
    const double cc = 0.35 / std::sqrt(2.0) / std::sqrt(2.0);
    const double e_diag = 1.0 - std::sqrt((1.0 - cc) * (1.0 - cc) + cc * cc);
    const double e_axis = 0.35 / std::sqrt(2.0);
    MESSAGE("square lattice: e_i diagonal = " << e_diag << " (chosen " << ev.e << "), axis = " << e_axis);
    CHECK(ev.e == doctest::Approx(e_diag).epsilon(1e-12));
    CHECK(ev.t[0] == doctest::Approx(std::sqrt(0.5)).epsilon(1e-14));
    CHECK(ev.t[1] == doctest::Approx(std::sqrt(0.5)).epsilon(1e-14));
    CHECK(e_diag < e_axis);
    // Children: half the volume each, at x ± δ t, new ids, marked, fluid.
    const auto& V = w.s.template get<field::volume>();
    for (int k = 0; k < 2; ++k) {
      const index_t ci = ev.child[static_cast<std::size_t>(k)];
      CHECK(V[ci] == 0.5 * l0 * l0);
      CHECK(w.s.ids()[static_cast<std::size_t>(ci)] == ev.child_id[static_cast<std::size_t>(k)]);
      CHECK(ev.child_id[static_cast<std::size_t>(k)] >= 49);
      CHECK((w.s.flags()[static_cast<std::size_t>(ci)] & flag::split_marked) != 0);
      CHECK(w.s.kinds()[static_cast<std::size_t>(ci)] == kind::fluid);
    }
    const vec<2> d = w.s.x().col(ev.child[0]) - w.s.x().col(ev.child[1]);
    CHECK(d.norm() == doctest::Approx(0.7 * l0 / std::sqrt(2.0)).epsilon(1e-12));
    CHECK(w.s.n_real() == 50);
    CHECK(rep.resize.appended == 2);
    CHECK(rep.resize.removed == 1);
  }

  TEST_CASE("split_merge: 2D rectangular lattice splits along the open axis (e_i = 0, clearance tie-break)") {
    // Spacing l0 along x and 2 l0 along y: along y the children stay beyond L_ij of every neighbour
    // (e_i = 0, like every direction within 7.1° of y); the largest clearance picks y itself.
    world<2> w;
    w.s = make_state<2>(lattice<2>({7, 7}, vec<2>(l0, 2 * l0)), l0 * l0);
    auto p = split_at<2>(vec<2>(3 * l0, 6 * l0), 0.2 * l0);
    const auto rep = w.run(p, zero_grad<2>);
    REQUIRE(rep.splits == 1);
    const auto& ev = rep.split_events[0];
    CHECK(ev.e == 0.0);
    CHECK(std::abs(ev.t[0]) < 1e-15);
    CHECK(ev.t[1] == doctest::Approx(1.0).epsilon(1e-15));
  }

  TEST_CASE("split_merge: 3D cubic lattice splits near the body diagonal (the minimiser by hand)") {
    world<3> w;
    w.s = make_state<3>(lattice<3>({5, 5, 5}, vec<3>(l0, l0, l0)), l0 * l0 * l0);
    auto p = split_at<3>(vec<3>(2 * l0, 2 * l0, 2 * l0), 0.2 * l0);
    const auto rep = w.run(p, zero_grad<3>);
    REQUIRE(rep.splits == 1);
    const auto& ev = rep.split_events[0];
    // By hand: δ = 0.35 · 2^(−1/3) l0; a child at δ t approaches the axis neighbour ±e_a to
    // √(1 − 2δ|t_a| + δ²) l0, so e_i is smallest when max_a |t_a| is: the body diagonal, |t_a| = 1/√3.
    const double delta = 0.35 * std::cbrt(0.5);
    const double e_diag = 1.0 - std::sqrt(1.0 - 2.0 * delta / std::sqrt(3.0) + delta * delta);
    const double e_axis = delta;
    MESSAGE("cubic lattice: e_i body diagonal = " << e_diag << ", chosen (Fibonacci, 256) = " << ev.e
                                                  << ", axis = " << e_axis << ", t = " << ev.t.transpose());
    CHECK(ev.e >= e_diag - 1e-12);
    CHECK(ev.e < e_diag + 0.01);
    CHECK(ev.t.cwiseAbs().maxCoeff() < 1.0 / std::sqrt(3.0) + 0.06);
    CHECK(ev.t.norm() == doctest::Approx(1.0).epsilon(1e-14));
  }

  TEST_CASE("split_merge: surface particles split perpendicular to the normal (t·n = 0)") {
    SUBCASE("2D") {
      world<2> w;
      w.s = make_state<2>(lattice<2>({7, 4}, vec<2>(l0, l0)), l0 * l0);
      w.refresh();
      const index_t c = nearest<2>(w.s.x(), vec<2>(3 * l0, 3 * l0));
      const double th = 20.0 * std::numbers::pi / 180.0;
      w.normals.col(c) = vec<2>(std::sin(th), std::cos(th));
      for (index_t i = 0; i < w.s.n_real(); ++i)
        if (w.s.x()(1, i) > 2.5 * l0) w.flags[static_cast<std::size_t>(i)] |= flag::surface;
      const auto rep = w.run(split_at<2>(vec<2>(3 * l0, 3 * l0), 0.2 * l0), zero_grad<2>);
      REQUIRE(rep.splits == 1);
      const vec<2> n(std::sin(th), std::cos(th));
      CHECK(rep.split_events[0].t.dot(n) == 0.0);  // exactly: t = (−n_y, n_x)
      CHECK(rep.split_events[0].t.norm() == doctest::Approx(1.0).epsilon(1e-15));
    }
    SUBCASE("3D") {
      world<3> w;
      w.s = make_state<3>(lattice<3>({5, 5, 3}, vec<3>(l0, l0, l0)), l0 * l0 * l0);
      w.refresh();
      const index_t c = nearest<3>(w.s.x(), vec<3>(2 * l0, 2 * l0, 2 * l0));
      const vec<3> n = vec<3>(0.2, -0.1, 1.0).normalized();
      w.normals.col(c) = n;
      for (index_t i = 0; i < w.s.n_real(); ++i)
        if (w.s.x()(2, i) > 1.5 * l0) w.flags[static_cast<std::size_t>(i)] |= flag::surface;
      const auto rep = w.run(split_at<3>(vec<3>(2 * l0, 2 * l0, 2 * l0), 0.2 * l0), zero_grad<3>);
      REQUIRE(rep.splits == 1);
      MESSAGE("3D surface split: t·n = " << rep.split_events[0].t.dot(n));
      CHECK(std::abs(rep.split_events[0].t.dot(n)) < 1e-15);
    }
    SUBCASE("a surface particle without a normal is refused") {
      world<2> w;
      w.s = make_state<2>(lattice<2>({7, 4}, vec<2>(l0, l0)), l0 * l0);
      w.refresh();
      for (index_t i = 0; i < w.s.n_real(); ++i)
        if (w.s.x()(1, i) > 2.5 * l0) w.flags[static_cast<std::size_t>(i)] |= flag::surface;
      const auto rep = w.run(split_at<2>(vec<2>(3 * l0, 3 * l0), 0.2 * l0), zero_grad<2>);
      CHECK(rep.splits == 0);
      CHECK(rep.refused_for(res::refusal::degenerate_normal) == 1);
      CHECK(w.s.n_real() == 28);
    }
  }

  TEST_CASE("split_merge: children must keep L′/2 from the walls") {
    // A tank [0, 0.2]² (fluid inside); particle i at height h above the floor with two neighbours 0.9 l0 to
    // its left and right (so without walls the best split is vertical). L′ = l0/√2, L′/2 = 0.354 l0,
    // δ = 0.247 l0.
    const geometry::polygon_set<2> tank(geometry::tank(vec<2>(0, 0), vec<2>(0.2, 0.2)));
    const auto setup = [](double h) {
      world<2> w;
      points<2> x(2, 3);
      x.col(0) = vec<2>(0.1, h);
      x.col(1) = vec<2>(0.1 - 0.9 * l0, h);
      x.col(2) = vec<2>(0.1 + 0.9 * l0, h);
      w.s = make_state<2>(x, l0 * l0);
      return w;
    };
    const auto p = split_at<2>(vec<2>(0.1, 0.0), 0.5 * l0);
    SUBCASE("without walls the split is vertical") {
      auto w = setup(0.4 * l0);
      const auto rep = w.run(p, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      CHECK(std::abs(rep.split_events[0].t[0]) < 1e-15);
    }
    SUBCASE("h = 0.40 l0: only near-horizontal directions keep the lower child L′/2 from the floor") {
      auto w = setup(0.4 * l0);
      w.walls = &tank;
      const auto rep = w.run(p, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      const auto& ev = rep.split_events[0];
      MESSAGE("wall-constrained direction t = " << ev.t.transpose() << ", e_i = " << ev.e);
      CHECK(std::abs(ev.t[1]) * 0.35 / std::sqrt(2.0) <= 0.4 - 0.5 / std::sqrt(2.0) + 1e-12);
      for (int k = 0; k < 2; ++k)
        CHECK(tank.signed_distance(w.s.x().col(ev.child[static_cast<std::size_t>(k)])) >=
              0.5 * l0 / std::sqrt(2.0));
    }
    SUBCASE("h = 0.30 l0: every direction puts a child outside the clearance: refused") {
      auto w = setup(0.3 * l0);
      w.walls = &tank;
      const auto rep = w.run(p, zero_grad<2>);
      CHECK(rep.splits == 0);
      CHECK(rep.refused_for(res::refusal::wall) == 1);
      CHECK(w.s.n_real() == 3);
    }
    SUBCASE("3D: a floor 0.30 l0 below refuses, 0.60 l0 accepts") {
      const geometry::polygon_set<3> box(geometry::tank(vec<3>(0, 0, 0), vec<3>(0.2, 0.2, 0.2)));
      for (double h : {0.3, 0.6}) {
        world<3> w;
        points<3> x(3, 1);
        x.col(0) = vec<3>(0.1, 0.1, h * l0);
        w.s = make_state<3>(x, l0 * l0 * l0);
        w.walls = &box;
        const auto rep = w.run(split_at<3>(vec<3>(0.1, 0.1, 0.0), 2.0 * l0), zero_grad<3>);
        CAPTURE(h);
        CHECK(rep.splits == (h > 0.5 ? 1 : 0));  // L′/2 = 0.397 l0
        if (rep.splits == 1)
          for (int k = 0; k < 2; ++k)
            CHECK(box.signed_distance(w.s.x().col(rep.split_events[0].child[static_cast<std::size_t>(k)])) >=
                  0.5 * std::cbrt(0.5) * l0);
      }
    }
  }

  TEST_CASE("split_merge: a parent touching a wall keeps a child in contact with it (wall_contact)") {
    // Floor y = 0; parent at height h with one neighbour 0.9 l0 straight above, so without the rule the best
    // split is horizontal (e_i = 1 − √(0.9² + δ²) / l0 = 0.067; vertical: e_i = 0.347). L′ = l0/√2,
    // δ = 0.247 l0; clearance L′/2 = 0.354 l0; contact: the lower child within 0.75 L′ = 0.530 l0 when the
    // parent is within α_w L = l0 of the floor (docs/resolution.md "Hard cases").
    const geometry::polygon_set<2> tank(geometry::tank(vec<2>(0, 0), vec<2>(0.2, 0.2)));
    const double Lc = l0 / std::sqrt(2.0);
    const auto setup = [&](double h) {
      world<2> w;
      points<2> x(2, 2);
      x.col(0) = vec<2>(0.1, h);
      x.col(1) = vec<2>(0.1, h + 0.9 * l0);
      w.s = make_state<2>(x, l0 * l0);
      w.walls = &tank;
      return w;
    };
    const auto lower_child = [&](const world<2>& w, const res::split_event<2>& ev) {
      return std::min(tank.signed_distance(w.s.x().col(ev.child[0])),
                      tank.signed_distance(w.s.x().col(ev.child[1])));
    };
    auto p = split_at<2>(vec<2>(0.1, 0.0), 0.7 * l0);
    p.wall_contact = 0.75;  // opt-in (default inf)
    SUBCASE(
        "h = 0.62 l0: the horizontal split would leave the floor; a tilted one keeps the lower child within "
        "0.75 L′") {
      auto w = setup(0.62 * l0);
      const auto rep = w.run(p, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      const double d = lower_child(w, rep.split_events[0]);
      MESSAGE("t = " << rep.split_events[0].t.transpose() << ", lower child " << d / Lc
                     << " L′ from the floor");
      CHECK(d <= 0.75 * Lc + 1e-15);
      CHECK(d >= 0.5 * Lc);
    }
    SUBCASE(
        "the same with wall_contact = inf (the default): horizontal, both children 0.877 L′ from the floor") {
      auto w = setup(0.62 * l0);
      p.wall_contact = std::numeric_limits<double>::infinity();
      const auto rep = w.run(p, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      CHECK(std::abs(rep.split_events[0].t[1]) < 1e-15);
      CHECK(lower_child(w, rep.split_events[0]) == doctest::Approx(0.62 * l0).epsilon(1e-12));
    }
    // the same rule with the target reaching the higher parents
    auto wide = split_at<2>(vec<2>(0.1, 0.0), 1.2 * l0);
    wide.wall_contact = 0.75;
    SUBCASE("h = 1.1 l0: not in contact (beyond α_w L), the split is horizontal") {
      auto w = setup(1.1 * l0);
      const auto rep = w.run(wide, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      CHECK(std::abs(rep.split_events[0].t[1]) < 1e-15);
    }
    SUBCASE(
        "h = 0.95 l0: no direction brings a child within 0.75 L′ (0.95 − 0.247 > 0.530): refused, counted") {
      auto w = setup(0.95 * l0);
      const auto rep = w.run(wide, zero_grad<2>);
      CHECK(rep.splits == 0);
      CHECK(rep.refused_for(res::refusal::wall_contact) == 1);
      CHECK(w.s.n_real() == 2);
    }
    // wall_contact_fallback (opt-in): of the directions the contact rule alone refused, the one whose nearer
    // child is nearest the floor, if within wall_reach · L′ = L′ (the copy band of that child). Vertical
    // (k = 18 of the 36 candidates, admissible: the upper child 0.9 − 0.247 = 0.653 l0 below the neighbour,
    // e_i = 0.347 < α_e).
    wide.wall_contact_fallback = true;
    SUBCASE(
        "h = 0.95 l0 with wall_contact_fallback: vertical, the lower child 0.703 l0 = 0.994 L′ from the "
        "floor, counted") {
      auto w = setup(0.95 * l0);
      const auto rep = w.run(wide, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      CHECK(rep.contact_fallbacks == 1);
      CHECK(std::abs(rep.split_events[0].t[0]) < 1e-15);
      const double delta = 0.5 * 0.7 * Lc;  // eq. 67, α_t = 0.7
      CHECK(lower_child(w, rep.split_events[0]) == doctest::Approx(0.95 * l0 - delta).epsilon(1e-12));
      CHECK(lower_child(w, rep.split_events[0]) <= Lc);
      CHECK(rep.refused_for(res::refusal::wall_contact) == 0);
    }
    SUBCASE(
        "h = 0.99 l0 with wall_contact_fallback: the nearest child would be 1.05 L′ from the floor, beyond "
        "its copy band: refused") {
      auto w = setup(0.99 * l0);
      const auto rep = w.run(wide, zero_grad<2>);
      CHECK(rep.splits == 0);
      CHECK(rep.contact_fallbacks == 0);
      CHECK(rep.refused_for(res::refusal::wall_contact) == 1);
    }
    SUBCASE(
        "h = 0.62 l0 with wall_contact_fallback: a direction keeps contact, so the fallback is not used") {
      auto w = setup(0.62 * l0);
      p.wall_contact_fallback = true;
      const auto rep = w.run(p, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      CHECK(rep.contact_fallbacks == 0);
      CHECK(lower_child(w, rep.split_events[0]) <= 0.75 * Lc + 1e-15);
    }
    SUBCASE(
        "a corner with the fallback: the child nearest either wall (the left one), not the least e_i "
        "(vertical)") {
      // Parent 0.85 l0 from the left wall and 0.90 l0 above the floor, one neighbour 0.9 l0 to its right: the
      // least e_i is vertical (0.067), horizontal has 0.347 < α_e. Every direction is refused by the contact
      // rule (the nearest any child comes: 0.85 − 0.2475 = 0.6025 l0 > 0.530 l0); the fallback takes the one
      // whose child comes nearest a wall: horizontal, 0.6025 l0 = 0.852 L′ from the left wall (vertical:
      // 0.6525 l0 from the floor).
      world<2> w;
      points<2> x(2, 2);
      x.col(0) = vec<2>(0.85 * l0, 0.90 * l0);
      x.col(1) = vec<2>(1.75 * l0, 0.90 * l0);
      w.s = make_state<2>(x, l0 * l0);
      w.walls = &tank;
      auto q = split_at<2>(vec<2>(0.0, 0.0), 1.5 * l0);
      q.wall_contact = 0.75;
      q.wall_contact_fallback = true;
      const auto rep = w.run(q, zero_grad<2>);
      REQUIRE(rep.splits == 1);
      CHECK(rep.contact_fallbacks == 1);
      const auto& ev = rep.split_events[0];
      MESSAGE("t = " << ev.t.transpose() << ", e_i = " << ev.e << ", nearer child " << lower_child(w, ev) / Lc
                     << " L′");
      CHECK(std::abs(ev.t[1]) < 1e-15);
      const double delta = 0.5 * 0.7 * Lc;  // eq. 67, α_t = 0.7
      CHECK(lower_child(w, ev) == doctest::Approx(0.85 * l0 - delta).epsilon(1e-12));
      CHECK(ev.e == doctest::Approx(1.0 - (0.9 * l0 - delta) / l0).epsilon(1e-12));
      q.wall_contact_fallback = false;  // the same parent without the fallback: refused by the contact rule
      world<2> v;
      v.s = make_state<2>(x, l0 * l0);
      v.walls = &tank;
      const auto without = v.run(q, zero_grad<2>);
      CHECK(without.splits == 0);
      CHECK(without.refused_for(res::refusal::wall_contact) == 1);
    }
    SUBCASE("bad input: wall_contact below wall_clearance; the fallback without a contact rule") {
      p.wall_contact = 0.4;
      CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("wall_contact"), mpskit::error);
      p.wall_contact = std::numeric_limits<double>::infinity();
      p.wall_contact_fallback = true;
      CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("wall_contact_fallback"), mpskit::error);
    }
  }

  TEST_CASE("split_merge: e_i above α_e refuses the split") {
    // Four neighbours 0.3 l0 away on the axes and the diagonals: every child lands within 0.6 L_ij.
    world<2> w;
    points<2> x(2, 9);
    x.col(0) = vec<2>(0, 0);
    for (int k = 0; k < 8; ++k) {
      const double a = std::numbers::pi * k / 4;
      x.col(k + 1) = 0.3 * l0 * vec<2>(std::cos(a), std::sin(a));
    }
    w.s = make_state<2>(x, l0 * l0);
    res::split_merge_params<2> p;
    p.target_diameter = [](const vec<2>& y) { return y.norm() < 0.1 * l0 ? 0.5 * l0 : l0; };
    const auto rep = w.run(p, zero_grad<2>);
    CHECK(rep.splits == 0);
    CHECK(rep.refused_for(res::refusal::error_function) == 1);
  }

  TEST_CASE("split_merge: merge-then-split guard (L*(x′) ≥ β_s L′)") {
    // i: V = l0², j: V = 3 l0² (L_j = 1.732 l0), 1.2 l0 apart; L* = 1.5 l0 everywhere. i asks to merge
    // (1.5 > β_m = 1.414), j keeps (1.5/1.732 = 0.866 > β_s). Merged: L′ = 2 l0 and β_s L′ = 1.707 l0 > 1.5
    // l0: it would split at once, so the merge is refused. With V_j = l0²: L′ = 1.414 l0, β_s L′ = 1.207 l0:
    // merged.
    for (double vj : {3.0, 1.0}) {
      world<2> w;
      points<2> x(2, 2);
      x.col(0) = vec<2>(0, 0);
      x.col(1) = vec<2>(1.2 * l0, 0);
      w.s = make_state<2>(x, l0 * l0);
      w.s.template get<field::volume>()[1] = vj * l0 * l0;
      res::split_merge_params<2> p;
      p.target_diameter = [](const vec<2>&) { return 1.5 * l0; };
      const auto rep = w.run(p, zero_grad<2>);
      CAPTURE(vj);
      if (vj == 3.0) {
        CHECK(rep.merges == 0);
        CHECK(rep.refused_for(res::refusal::would_split) == 1);
        CHECK(w.s.n_real() == 2);
      } else {
        CHECK(rep.merges == 1);
        CHECK(w.s.n_real() == 1);
        CHECK(w.s.template get<field::volume>()[0] == 2.0 * l0 * l0);
        CHECK((w.s.flags()[0] & flag::merge_marked) != 0);
      }
    }
    SUBCASE("no partner within α_r L_ij") {
      world<2> w;
      points<2> x(2, 2);
      x.col(0) = vec<2>(0, 0);
      x.col(1) = vec<2>(1.6 * l0, 0);
      w.s = make_state<2>(x, l0 * l0);
      res::split_merge_params<2> p;
      p.target_diameter = [](const vec<2>&) { return 2.0 * l0; };
      const auto rep = w.run(p, zero_grad<2>);
      CHECK(rep.merges == 0);
      CHECK(rep.refused_for(res::refusal::no_partner) == 2);
    }
    SUBCASE("isolated particles and particles asking to split are not partners") {
      world<2> w;
      points<2> x(2, 3);
      x.col(0) = vec<2>(0, 0);
      x.col(1) = vec<2>(1.0 * l0, 0);
      x.col(2) = vec<2>(-1.0 * l0, 0);
      w.s = make_state<2>(x, l0 * l0);
      w.refresh();
      w.flags[1] = flag::isolated;
      res::split_merge_params<2> p;
      p.target_diameter = [](const vec<2>& y) { return y[0] < -0.5 * l0 ? 0.5 * l0 : 2.0 * l0; };
      p.split = false;
      const auto rep = w.run(p, zero_grad<2>);
      CHECK(rep.merges == 0);
      CHECK(rep.refused_for(res::refusal::no_partner) == 1);
      CHECK(rep.refused_for(res::refusal::isolated) == 1);
      CHECK(rep.refused_for(res::refusal::disabled) == 1);
    }
  }

  TEST_CASE("split_merge: pairing is mutual-nearest and does not depend on input order") {
    // Chain 0 —1.0— 1 —0.9— 2 —1.0— 3 (l0), all asking to merge: (1, 2) are mutual nearest, then (0, 3)
    // are too far apart (3 l0): 0 and 3 are refused with partner_taken.
    world<2> w;
    points<2> x(2, 4);
    x.col(0) = vec<2>(0, 0);
    x.col(1) = vec<2>(1.0 * l0, 0);
    x.col(2) = vec<2>(1.9 * l0, 0);
    x.col(3) = vec<2>(2.9 * l0, 0);
    w.s = make_state<2>(x, l0 * l0);
    res::split_merge_params<2> p;
    p.target_diameter = [](const vec<2>&) { return 2.0 * l0; };
    const auto rep = w.run(p, zero_grad<2>);
    REQUIRE(rep.merges == 1);
    CHECK(rep.merge_events[0].parent_id == std::array<particle_id, 2>{1, 2});
    CHECK(rep.refused_for(res::refusal::partner_taken) == 2);
  }

  TEST_CASE("split_merge: merge partners: alike first (default), both asking, or the nearest") {
    // 2 (asks) —1.0— 0 (asks) —0.9— 1 (keeps: L* = L): L* = 2 l0 for x < 0.5 l0, l0 beyond.
    const auto run = [](res::merge_partners mp, bool with_2) {
      world<2> w;
      points<2> x(2, with_2 ? 3 : 2);
      x.col(0) = vec<2>(0, 0);
      x.col(1) = vec<2>(0.9 * l0, 0);
      if (with_2) x.col(2) = vec<2>(-1.0 * l0, 0);
      w.s = make_state<2>(x, l0 * l0);
      res::split_merge_params<2> p;
      p.target_diameter = [](const vec<2>& y) { return y[0] < 0.5 * l0 ? 2.0 * l0 : l0; };
      p.partners = mp;
      return w.run(p, zero_grad<2>);
    };
    // nearest (the paper read literally): 0 takes the nearer 1, which does not ask; 2 finds no partner left.
    auto r = run(res::merge_partners::nearest, true);
    REQUIRE(r.merges == 1);
    CHECK(r.merge_events[0].parent_id == std::array<particle_id, 2>{0, 1});
    CHECK(r.refused_for(res::refusal::partner_taken) == 1);
    // alike_first and both_ask: 0 takes 2, which asks too, though 1 is nearer.
    for (auto mp : {res::merge_partners::alike_first, res::merge_partners::both_ask}) {
      r = run(mp, true);
      REQUIRE(r.merges == 1);
      CHECK(r.merge_events[0].parent_id == std::array<particle_id, 2>{0, 2});
    }
    // Without 2: alike_first falls back to the non-asking 1; both_ask refuses (no partner).
    r = run(res::merge_partners::alike_first, false);
    REQUIRE(r.merges == 1);
    CHECK(r.merge_events[0].parent_id == std::array<particle_id, 2>{0, 1});
    r = run(res::merge_partners::both_ask, false);
    CHECK(r.merges == 0);
    CHECK(r.refused_for(res::refusal::no_partner) == 1);
  }

  TEST_CASE("split_merge: same events, bitwise, under a permutation of the input") {
    std::mt19937_64 rng(seed_used());
    auto run_both = [&]<int D>(world<D> a, int m) {
      world<D> b = a;
      std::vector<index_t> perm(static_cast<std::size_t>(a.s.n_real()));
      std::iota(perm.begin(), perm.end(), 0);
      std::shuffle(perm.begin(), perm.end(), rng);
      b.s.reorder(perm);
      const auto p = banded_target<D>();
      const auto g = [](const sm_state<D>& s) {
        return [&s](index_t i) { return grad_of_id<D>(s.ids()[static_cast<std::size_t>(i)]); };
      };
      const auto ra = a.run(p, g(a.s));
      const auto rb = b.run(p, g(b.s));
      MESSAGE(D << "D, " << m << "^" << D << " particles: " << ra.splits << " splits, " << ra.merges
                << " merges, refused " << ra.refused_for(res::refusal::partner_taken) << " partner_taken, "
                << ra.refused_for(res::refusal::error_function) << " error_function");
      CHECK(ra.splits > 0);
      CHECK(ra.merges > 0);
      CHECK(ra.splits == rb.splits);
      CHECK(ra.merges == rb.merges);
      std::set<std::pair<particle_id, particle_id>> pa, pb;
      for (const auto& e : ra.merge_events) pa.insert({e.parent_id[0], e.parent_id[1]});
      for (const auto& e : rb.merge_events) pb.insert({e.parent_id[0], e.parent_id[1]});
      CHECK(pa == pb);
      std::vector<std::vector<double>> sa, sb;
      for (const auto& e : ra.split_events) sa.push_back({double(e.parent_id), e.t[0], e.t[1], e.e});
      for (const auto& e : rb.split_events) sb.push_back({double(e.parent_id), e.t[0], e.t[1], e.e});
      std::sort(sa.begin(), sa.end());
      std::sort(sb.begin(), sb.end());
      CHECK(bitwise_equal(sa, sb));
      CHECK(bitwise_equal(picture(a.s), picture(b.s)));
    };
    run_both.template operator()<2>(random_world<2>(30, rng), 30);
    run_both.template operator()<3>(random_world<3>(10, rng), 10);
  }

  TEST_CASE(
      "split_merge: children of neighbouring splits in one call keep (1 - alpha_e) L_ij from each other") {
    // Eqs. 68–69 check a candidate's children against the neighbours as they are, so two neighbours splitting
    // in the same call are checked against each other's parents only. The choices are revisited in id order
    // (docs/resolution.md, "Choices" 11): a later split's children must keep eq. 69's bound e < α_e against
    // an earlier split's children, r / L_ij > 1 − α_e with L_ij = (L_later + L′_earlier)/2. The case: a row
    // (2D) or a square layer (3D) of surface particles, normal +y / +z, spacing s = 0.75 L, all splitting.
    // Alone, each split is admissible: a child lies s − δ = 0.503 L > 0.4 L from the neighbouring parent
    // (δ = (α_t/2) L′ = 0.247 L in 2D). Two neighbours splitting toward each other put their inner children s
    // − 2δ = 0.255 L apart: r/L_ij = 0.255/0.854 = 0.30 < 0.4 (measured without the pass: 0.299 in 2D). In 2D
    // a surface particle has one tangent, so the later split cannot turn: it is refused and the row splits
    // every other particle (ids 0, 2, 4, ...); in 3D it turns within its tangent plane.
    const double s = 0.75 * l0;
    auto run_layer = [&]<int D>(int m, bool reversed = false) {
      const int my = D == 3 ? m : 1;
      points<D> x = points<D>::Zero(D, m * my);
      for (int b = 0; b < my; ++b)
        for (int a = 0; a < m; ++a) {
          x(0, a + m * b) = a * s;
          if constexpr (D == 3) x(1, a + m * b) = b * s;
        }
      world<D> w;
      w.s = make_state<D>(x, std::pow(l0, D));
      if (reversed) {  // ids no longer follow indices: the pass must go by id, not by index
        std::vector<index_t> perm(static_cast<std::size_t>(x.cols()));
        std::iota(perm.rbegin(), perm.rend(), 0);
        w.s.reorder(perm);
      }
      w.normals = points<D>::Zero(D, x.cols());
      w.normals.row(D - 1).setOnes();
      w.flags.assign(static_cast<std::size_t>(x.cols()), flag::surface);
      res::split_merge_params<D> p;
      p.target_diameter = [](const vec<D>&) { return 0.5 * l0; };
      const auto rep = w.run(p, zero_grad<D>);
      const double child = std::pow(0.5, 1.0 / D);
      double worst = 1e300;
      for (std::size_t i = 0; i < rep.split_events.size(); ++i)
        for (std::size_t j = i + 1; j < rep.split_events.size(); ++j) {
          const auto& ea = rep.split_events[i];
          const auto& eb = rep.split_events[j];
          const auto& later = ea.parent_id > eb.parent_id ? ea : eb;
          const auto& earlier = ea.parent_id > eb.parent_id ? eb : ea;
          const double Lij = 0.5 * (w.L[later.parent_index] + child * w.L[earlier.parent_index]);
          for (const index_t ca : later.child)
            for (const index_t cb : earlier.child)
              worst = std::min(worst, (w.s.x().col(ca) - w.s.x().col(cb)).norm() / Lij);
        }
      MESSAGE(D << "D, " << x.cols() << " surface particles: " << rep.splits << " splits, " << rep.redirected
                << " redirected, " << rep.refused_for(res::refusal::neighbour_children)
                << " refused (neighbour_children); min r/L_ij between children of different splits "
                << worst);
      CHECK(worst > 1.0 - p.alpha_e);
      return rep;
    };
    const auto r2 = run_layer.template operator()<2>(8);
    CHECK(r2.splits == 4);
    CHECK(r2.refused_for(res::refusal::neighbour_children) == 4);
    CHECK(r2.redirected == 0);
    for (const auto& e : r2.split_events) CHECK(e.parent_id % 2 == 0);
    const auto r2r = run_layer.template operator()<2>(8, true);  // the same row stored in reverse order
    CHECK(r2r.splits == 4);
    for (const auto& e : r2r.split_events) CHECK(e.parent_id % 2 == 0);
    const auto r3 = run_layer.template operator()<3>(4);
    CHECK(r3.splits == 16);  // the layer's choices do not clash (all turn alike); worst checked above
    // 3D, a redirected split: surface particles A (id 0) at the origin and B (id 1) at (s, 0, 0), normal +z,
    // each with two particles that keep their size at ±0.55 L in y. Alone, each chooses the same tangent
    // direction (25° from x in a hand model of eqs. 67–69 with N_θ = 36; a child along y would lie 0.27 L
    // from an obstacle, e = 0.73 > α_e), and their inner children would be 0.38 L_ij apart. B, decided
    // second, turns within its tangent plane (35° in the model) and its children keep > 0.4 L_ij from A's.
    {
      points<3> x(3, 6);
      x.col(0) << 0.0, 0.0, 0.0;
      x.col(1) << s, 0.0, 0.0;
      x.col(2) << 0.0, 0.55 * l0, 0.0;
      x.col(3) << 0.0, -0.55 * l0, 0.0;
      x.col(4) << s, 0.55 * l0, 0.0;
      x.col(5) << s, -0.55 * l0, 0.0;
      world<3> w;
      w.s = make_state<3>(x, std::pow(l0, 3));
      w.normals = points<3>::Zero(3, 6);
      w.normals.row(2).setOnes();
      w.flags.assign(6, 0);
      w.flags[0] = w.flags[1] = flag::surface;
      res::split_merge_params<3> p;
      p.target_diameter = [](const vec<3>& y) { return std::abs(y[1]) < 0.3 * l0 ? 0.5 * l0 : l0; };
      const auto rep = w.run(p, zero_grad<3>);
      REQUIRE(rep.splits == 2);
      CHECK(rep.redirected == 1);
      const auto& eA = rep.split_events[0].parent_id == 0 ? rep.split_events[0] : rep.split_events[1];
      const auto& eB = rep.split_events[0].parent_id == 0 ? rep.split_events[1] : rep.split_events[0];
      CHECK(std::abs(eA.t.dot(eB.t)) < 1.0 - 1e-9);  // B turned away from A's direction
      CHECK(std::abs(eB.t[2]) < 1e-12);               // within its tangent plane
      double worst = 1e300;
      for (const index_t cb : eB.child)
        for (const index_t ca : eA.child)
          worst = std::min(worst,
                           (w.s.x().col(cb) - w.s.x().col(ca)).norm() / (0.5 * (1.0 + std::cbrt(0.5)) * l0));
      MESSAGE("3D pair: A's direction (" << eA.t.transpose() << "), B's (" << eB.t.transpose()
              << "), min r/L_ij of B's children to A's " << worst);
      CHECK(worst > 1.0 - p.alpha_e);
    }
  }

  TEST_CASE("split_merge: bitwise identical for 1 and 2 threads (parallel direction search)") {
    // 90² particles, about 2/5 asking to split: above parallel_min_items, so exec::par runs threaded.
    std::mt19937_64 rng(seed_used());
    const world<2> w0 = random_world<2>(90, rng);
    std::vector<std::vector<std::vector<double>>> pics;
    std::vector<std::vector<particle_id>> ids;
    for (int threads : {1, 2}) {
#ifdef _OPENMP
      omp_set_num_threads(threads);
#else
      (void)threads;
#endif
      world<2> w = w0;
      auto p = banded_target<2>();
      p.target_diameter = [](const vec<2>& x) { return x[0] < 0.55 * 90 * l0 ? 0.4 * l0 : 3.0 * l0; };
      const auto rep =
          w.run(p, [&w](index_t i) { return grad_of_id<2>(w.s.ids()[static_cast<std::size_t>(i)]); });
      MESSAGE(threads << " thread(s): " << rep.splits << " splits, " << rep.merges << " merges");
      CHECK(rep.wanted_split > parallel_min_items);
      std::vector<std::vector<double>> pic;
      for (index_t i = 0; i < w.s.n_real(); ++i)
        pic.push_back({w.s.x()(0, i), w.s.x()(1, i), w.s.u()(0, i), w.s.u()(1, i),
                       w.s.template get<field::volume>()[i]});
      pics.push_back(std::move(pic));
      ids.push_back(w.s.ids());
    }
#ifdef _OPENMP
    omp_set_num_threads(1);
#endif
    CHECK(bitwise_equal(pics[0], pics[1]));  // same order, same values, bitwise
    CHECK(ids[0] == ids[1]);
  }

  TEST_CASE("split_merge: conservation ledger on random states (ΣV to 4 ulp, ΣVu to 8 ulp per event)") {
    std::mt19937_64 rng(seed_used());
    auto check = [&]<int D>(world<D> w) {
      const auto sums = [](const sm_state<D>& s) {
        res::detail::exact_sum V;
        std::array<res::detail::exact_sum, D> M{};
        double Vu = 0.0;
        for (index_t i = 0; i < s.n_real(); ++i) {
          const double v = s.template get<field::volume>()[i];
          V.add(v);
          for (int a = 0; a < D; ++a) M[static_cast<std::size_t>(a)].add_product(v, s.u()(a, i));
          Vu += v * s.u().col(i).norm();
        }
        return std::make_tuple(V, M, Vu);
      };
      const auto [V0, M0, S0] = sums(w.s);
      res::conservation_ledger<D> led;
      const auto rep = w.run(
          banded_target<D>(),
          [&w](index_t i) { return grad_of_id<D>(w.s.ids()[static_cast<std::size_t>(i)]); }, &led);
      const auto [V1, M1, S1] = sums(w.s);
      const double eps = std::numeric_limits<double>::epsilon();
      const double dV = V1.minus(V0) / (eps * V0.value());
      vec<D> dM;
      for (int a = 0; a < D; ++a)
        dM[a] = M1[static_cast<std::size_t>(a)].minus(M0[static_cast<std::size_t>(a)]);
      const double dMu = dM.norm() / (eps * std::max(S0, S1));
      MESSAGE(D << "D: " << rep.splits << " splits, " << rep.merges << " merges; per event max |ΔΣV| = "
                << rep.ledger.max_volume_ulps << " ulp, max |ΔΣVu| = " << rep.ledger.max_momentum_ulps
                << " ulp; whole state |ΔΣV| = " << dV << " ulp ΣV, |ΔΣVu| = " << dMu
                << " ulp ΣV|u|; ΔKE = " << rep.ledger.dKE << ", ΔL = " << rep.ledger.dL.transpose());
      CHECK(rep.splits > 10);
      CHECK(rep.merges > 10);
      CHECK(rep.ledger.max_volume_ulps <= 4.0);
      CHECK(rep.ledger.max_momentum_ulps <= 8.0);
      CHECK(std::abs(dV) <= 4.0);
      CHECK(dMu <= 8.0);
      CHECK(led.current().splits == rep.splits);
      CHECK(led.current().merges == rep.merges);
      w.s.validate();
      // Fields: children copy the parent's pressure, a merged particle has the volume-weighted one.
      CHECK(rep.resize.appended == 2 * rep.splits + rep.merges);
      CHECK(rep.resize.removed == rep.splits + 2 * rep.merges);
    };
    for (int r = 0; r < 3; ++r) {
      check.template operator()<2>(random_world<2>(24, rng));
      check.template operator()<3>(random_world<3>(9, rng));
    }
  }

  TEST_CASE("split_merge: merged fields are volume-weighted, children copy the parent's") {
    world<2> w;
    points<2> x(2, 3);
    x.col(0) = vec<2>(0, 0);
    x.col(1) = vec<2>(1.0 * l0, 0);
    x.col(2) = vec<2>(0.0, 5.0 * l0);
    w.s = make_state<2>(x, l0 * l0);
    auto& V = w.s.template get<field::volume>();
    auto& pr = w.s.template get<field::pressure>();
    V[1] = 0.5 * l0 * l0;
    pr[0] = 100.0;
    pr[1] = 400.0;
    pr[2] = 7.0;
    res::split_merge_params<2> p;
    p.target_diameter = [](const vec<2>& y) { return y[1] > 2.0 * l0 ? 0.5 * l0 : 2.0 * l0; };
    const auto rep = w.run(p, zero_grad<2>);
    REQUIRE(rep.merges == 1);
    REQUIRE(rep.splits == 1);
    const index_t m = rep.merge_events[0].merged;
    CHECK(pr[m] == doctest::Approx((100.0 * 1.0 + 400.0 * 0.5) / 1.5).epsilon(1e-15));
    CHECK(w.s.x()(0, m) == doctest::Approx(l0 / 3.0).epsilon(1e-15));  // eq. 72
    for (int k = 0; k < 2; ++k) CHECK(pr[rep.split_events[0].child[static_cast<std::size_t>(k)]] == 7.0);
  }

  TEST_CASE("split_merge: merging across a periodic boundary (minimum image, wrapped result)") {
    world<2> w;
    w.dom.lo = vec<2>(0, 0);
    w.dom.hi = vec<2>(20 * l0, 20 * l0);
    w.dom.periodic = {true, false};
    points<2> x(2, 2);
    x.col(0) = vec<2>(0.2 * l0, 5 * l0);
    x.col(1) = vec<2>(20 * l0 - 0.6 * l0, 5 * l0);
    w.s = make_state<2>(x, l0 * l0);
    res::split_merge_params<2> p;
    p.target_diameter = [](const vec<2>&) { return 2.0 * l0; };
    const auto rep = w.run(p, zero_grad<2>);
    REQUIRE(rep.merges == 1);
    CHECK(rep.merge_events[0].r == doctest::Approx(0.8 * l0).epsilon(1e-12));
    CHECK(w.s.x()(0, 0) == doctest::Approx(20 * l0 - 0.2 * l0).epsilon(1e-12));
  }

  TEST_CASE("split_merge: kinetic energy and angular momentum changes equal the hand values") {
    const double rho = 1000.0, U = 0.3, om = 40.0;
    SUBCASE("2D merge: ΔKE = −¼ ρ V U², ΔL = −½ ρ V l0 U") {
      // V_i = V_j = V = l0², x_ij = (l0, 0), u_i = 0, u_j = (0, U). Eq. 72: x′ = (l0/2, 0); eq. 73: u′ = (0,
      // U/2). Before: KE = ½ρVU², L = ρ V l0 U. After: KE = ½ρ(2V)(U/2)² = ¼ρVU², L = ρ(2V)(l0/2)(U/2) = ½ρV
      // l0 U. The paper says eq. 72 keeps the angular momentum: it keeps the centroid; L drops by ρ μ x_ij ×
      // u_ij.
      world<2> w;
      points<2> x(2, 2);
      x.col(0) = vec<2>(0, 0);
      x.col(1) = vec<2>(l0, 0);
      w.s = make_state<2>(x, l0 * l0);
      w.s.u().col(1) = vec<2>(0, U);
      res::split_merge_params<2> p;
      p.target_diameter = [](const vec<2>&) { return 2.0 * l0; };
      const auto rep = w.run(p, zero_grad<2>);
      REQUIRE(rep.merges == 1);
      const double V = l0 * l0;
      MESSAGE("2D merge: ΔKE = " << rep.ledger.dKE << " (hand " << -0.25 * rho * V * U * U << "), ΔL = "
                                 << rep.ledger.dL[0] << " (hand " << -0.5 * rho * V * l0 * U << ")");
      CHECK(rep.ledger.dKE == doctest::Approx(-0.25 * rho * V * U * U).epsilon(1e-12));
      CHECK(rep.ledger.dL[0] == doctest::Approx(-0.5 * rho * V * l0 * U).epsilon(1e-12));
      CHECK(rep.ledger.dVu.norm() <= 8 * std::numeric_limits<double>::epsilon() * V * U);
    }
    SUBCASE("2D split in a rigid rotation: ΔKE = ½ ρ V ω² δ², ΔL = ρ V ω δ²") {
      // One particle, u = (1, 2), ⟨∇u⟩ = [[0, −ω], [ω, 0]]; no neighbours: every direction ties, t = (1, 0).
      // δ = (α_t/2) l0/√2, children x ± δt with u ± a, a = ⟨∇u⟩ δt = (0, ωδ) (eq. 70). KE after =
      // ½ρ(V/2)(|u + a|² + |u − a|²) = ½ρV(|u|² + |a|²); L after = ρ(V/2)[δt × (u + a) − δt × (u − a)] = ρVδt
      // × a.
      world<2> w;
      points<2> x(2, 1);
      x.col(0) = vec<2>(0.05, 0.05);
      w.s = make_state<2>(x, l0 * l0);
      w.s.u().col(0) = vec<2>(1.0, 2.0);
      res::split_merge_params<2> p;
      p.target_diameter = [](const vec<2>&) { return 0.5 * l0; };
      mat<2> G;
      G << 0.0, -om, om, 0.0;
      const auto rep = w.run(p, [&G](index_t) { return G; });
      REQUIRE(rep.splits == 1);
      CHECK(rep.split_events[0].t == vec<2>(1.0, 0.0));
      const double V = l0 * l0, delta = 0.35 * l0 / std::sqrt(2.0);
      MESSAGE("2D split: ΔKE = " << rep.ledger.dKE << " (hand " << 0.5 * rho * V * om * om * delta * delta
                                 << "), ΔL = " << rep.ledger.dL[0] << " (hand "
                                 << rho * V * om * delta * delta << ")");
      CHECK(rep.ledger.dKE == doctest::Approx(0.5 * rho * V * om * om * delta * delta).epsilon(1e-9));
      CHECK(rep.ledger.dL[0] == doctest::Approx(rho * V * om * delta * delta).epsilon(1e-12));
      CHECK(rep.ledger.dVu.norm() == 0.0);
    }
    SUBCASE("3D merge: ΔL = −ρ μ x_ij × u_ij") {
      world<3> w;
      points<3> x(3, 2);
      x.col(0) = vec<3>(0, 0, 0);
      x.col(1) = vec<3>(l0, 0, 0);
      w.s = make_state<3>(x, l0 * l0 * l0);
      w.s.u().col(1) = vec<3>(0, U, 0);
      res::split_merge_params<3> p;
      p.target_diameter = [](const vec<3>&) { return 2.0 * l0; };
      const auto rep = w.run(p, zero_grad<3>);
      REQUIRE(rep.merges == 1);
      const double mu = 0.5 * l0 * l0 * l0;
      CHECK(rep.ledger.dL[0] == doctest::Approx(0.0));
      CHECK(rep.ledger.dL[1] == doctest::Approx(0.0));
      CHECK(rep.ledger.dL[2] == doctest::Approx(-rho * mu * l0 * U).epsilon(1e-12));
      CHECK(rep.ledger.dKE == doctest::Approx(-0.5 * rho * mu * U * U).epsilon(1e-12));
    }
  }

  TEST_CASE("split_merge: the ledger names a violating event; fluxes are summed per boundary") {
    res::conservation_ledger<2> led;
    const std::array<res::particle_view<2>, 1> before{{{1.0, vec<2>(0.5, 0.25), vec<2>(1.0, 0.0)}}};
    const std::array<res::particle_view<2>, 2> ok{
        {{0.5, vec<2>(0.4, 0.25), vec<2>(1.0, 0.1)}, {0.5, vec<2>(0.6, 0.25), vec<2>(1.0, -0.1)}}};
    const std::array<res::particle_view<2>, 2> bad{
        {{0.5, vec<2>(0.4, 0.25), vec<2>(1.0, 0.0)}, {0.5 + 1e-12, vec<2>(0.6, 0.25), vec<2>(1.0, 0.0)}}};
    const std::array<particle_id, 1> ids{42};
    CHECK_NOTHROW(led.record("split", ids, before, ok));
    try {
      led.record("split", ids, before, bad);
      FAIL("no error");
    } catch (const mpskit::error& e) {
      const std::string m = e.what();
      CHECK(m.find("split") != std::string::npos);
      CHECK(m.find("42") != std::string::npos);
      CHECK(m.find("ΣV") != std::string::npos);
    }
    led.add_flux("inflow", 2.0, vec<2>(1, 0), 3);
    led.add_flux("inflow", 1.0, vec<2>(1, 0), 1);
    led.add_flux("outflow", -0.5, vec<2>(-1, 0), -1);
    const auto st = led.close_step();
    REQUIRE(st.fluxes.size() == 2);
    CHECK(st.fluxes[0].volume == 3.0);
    CHECK(st.fluxes[0].particles == 4);
    CHECK(st.flux_volume() == 2.5);
    CHECK(led.current().fluxes.empty());
    CHECK(led.totals().fluxes.size() == 2);
    CHECK(led.steps() == 1);
  }

  TEST_CASE("split_merge: bad input is refused with a clear message") {
    world<2> w;
    w.s = make_state<2>(lattice<2>({3, 3}, vec<2>(l0, l0)), l0 * l0);
    res::split_merge_params<2> p;
    SUBCASE("no target diameter") {
      CHECK_THROWS_WITH_AS(w.run(p, zero_grad<2>), doctest::Contains("target_diameter"), mpskit::error);
    }
    SUBCASE("parameters out of range") {
      p.target_diameter = [](const vec<2>&) { return l0; };
      p.alpha_e = 0.0;
      p.n_theta = 0;
      CHECK_THROWS_WITH_AS(w.run(p, zero_grad<2>), doctest::Contains("alpha_e"), mpskit::error);
    }
    SUBCASE("a target diameter that is not a positive number") {
      p.target_diameter = [](const vec<2>& x) { return x[0] > 1.5 * l0 ? -1.0 : l0; };
      CHECK_THROWS_WITH_AS(w.run(p, zero_grad<2>), doctest::Contains("target_diameter returned -1"),
                           mpskit::error);
    }
    SUBCASE("diameters that are not the volumes'") {
      p.target_diameter = [](const vec<2>&) { return l0; };
      w.refresh();
      w.L[4] *= 1.01;
      CHECK_THROWS_WITH_AS(res::split_merge<>::apply(exec::seq{}, w.s, w.inputs(), p, zero_grad<2>),
                           doctest::Contains("V^(1/D)"), mpskit::error);
    }
    SUBCASE("a surface particle asks to split and no normals are given") {
      p.target_diameter = [](const vec<2>& x) { return x[0] > 1.5 * l0 ? 0.5 * l0 : l0; };
      w.refresh();
      w.flags.assign(9, flag::surface);
      auto in = w.inputs();
      in.normals = nullptr;
      CHECK_THROWS_WITH_AS(res::split_merge<>::apply(exec::seq{}, w.s, in, p, zero_grad<2>),
                           doctest::Contains("normals is null"), mpskit::error);
    }
    SUBCASE("a list of another state") {
      p.target_diameter = [](const vec<2>&) { return l0; };
      w.refresh();
      w.s.append(1, kind::fluid);
      CHECK_THROWS_WITH_AS(res::split_merge<>::apply(exec::seq{}, w.s, w.inputs(), p, zero_grad<2>),
                           doctest::Contains("rows"), mpskit::error);
    }
  }

  TEST_CASE("split_merge: the target callable may read wall and surface distances") {
    const geometry::polygon_set<2> tank(geometry::tank(vec<2>(0, 0), vec<2>(0.1, 0.1)));
    world<2> w;
    points<2> x = lattice<2>({5, 5}, vec<2>(l0, l0));
    x.array() += 0.03;
    w.s = make_state<2>(x, l0 * l0);
    w.walls = &tank;
    std::vector<double> seen_wall, seen_surface;
    res::split_merge_params<2> p;
    p.target_diameter = [&](const res::target_point<2>& tp) {
      if (tp.index != npos) {
        seen_wall.push_back(tp.wall_distance);
        seen_surface.push_back(tp.surface_distance);
      }
      return l0;
    };
    CHECK(p.target_diameter.wants_context());
    w.run(p, zero_grad<2>);
    REQUIRE(seen_wall.size() == 25);
    CHECK(seen_wall[0] == doctest::Approx(0.03).epsilon(1e-12));  // particle 0 at (0.03, 0.03)
    CHECK(std::isinf(seen_surface[0]));                           // no surface flags
  }

  TEST_CASE("split_merge: the LSMPS stepper's resolution stage (Taylor-Green vortex with a refined disc)") {
    // N = 20 (L = 0.05 m), periodic; L* = 0.75 L in the disc r < 0.25 m around (0.75, 0.75) m (split once:
    // 0.75 < β_s = 0.854, children keep: 0.75 L ≥ β_s L′ = 0.604 L), 1.05 L outside (children leaving merge:
    // 1.05 L > β_m L′ = L). 30 steps at a fixed Δt = 0.09 L′/U.
    cases::taylor_green_config c;
    c.n = 20;
    const double L = c.width / c.n;
    auto p = cases::taylor_green_params(c);
    p.time.mode = scheme::time_step_mode::fixed;
    p.time.dt_fixed = c.dt_courant * (L / std::sqrt(2.0)) / c.speed;  // Courant on the children's L′
    p.time.dt_max = p.time.dt_fixed;
    p.resolution.target_diameter = [L](const vec<2>& x) {
      return (x - vec<2>(0.75, 0.75)).norm() < 0.25 ? 0.75 * L : 1.05 * L;
    };
    simulation<tg_multires> sim(p, cases::taylor_green_state(c));
    const auto total = [](const auto& st) {
      res::detail::exact_sum v;
      for (index_t i = 0; i < st.n_real(); ++i) v.add(st.template get<field::volume>()[i]);
      return v;
    };
    const auto V0 = total(sim.state());
    const index_t n0 = sim.state().n_real();
    for (int k = 0; k < 30; ++k) sim.step();
    const auto V1 = total(sim.state());
    const double dV = V1.minus(V0) / (std::numeric_limits<double>::epsilon() * V0.value());
    double umax = 0.0;
    for (index_t i = 0; i < sim.state().n_real(); ++i) umax = std::max(umax, sim.state().u().col(i).norm());
    MESSAGE("Taylor-Green N=20, 30 steps: " << n0 << " -> " << sim.state().n_real() << " particles, "
                                            << sim.counters().splits << " splits, " << sim.counters().merges
                                            << " merges, ΔΣV = " << dV << " ulp ΣV, ledger ΔKE = "
                                            << sim.ledger().totals().dKE << " J/m, max|u| = " << umax);
    CHECK(sim.counters().splits > 20);
    CHECK(sim.state().n_real() == n0 + sim.counters().splits - sim.counters().merges);
    CHECK(sim.ledger().steps() == 30);
    CHECK(sim.ledger().totals().splits == sim.counters().splits);
    CHECK(std::abs(dV) <= 4.0 * static_cast<double>(sim.counters().splits + sim.counters().merges + 1));
    CHECK(umax < 2.0);
    sim.state().validate();
  }

TEST_CASE("split_merge: a particle removed outside lsmps_params::remove_outside is a ledger flux") {
  // The tank at rest of the case below, refined on its right part, with one more particle outside the tank
  // (right of its right wall at x = W) and the box's right side at x = W: it is removed at the start of the
  // first step and enters the ledger as the flux "left_domain" (−V, −V u, −1 particle); the splits balance to
  // the ulp, so ΣV at the end is ΣV0 − L² to rounding.
  const cases::polygon_tank_config tc = refined_tank_config();
  const auto tank = cases::make_polygon_tank<2>(tc);
  scheme::lsmps_state<2> s0(tank.size() + 1);
  s0.x().leftCols(tank.size()) = tank.x;
  s0.x().col(tank.size()) = vec<2>(tc.W + 0.02, 0.03);
  s0.u().setZero();
  s0.u().col(tank.size()) = vec<2>(0.5, 0.0);
  s0.get<field::volume>().setConstant(tc.L * tc.L);
  scheme::lsmps_params<2> p;
  p.resolution.target_diameter = [L = tc.L](const vec<2>& x) { return x[0] > 0.05 ? 0.75 * L : L; };
  p.remove_outside.hi[0] = tc.W;
  simulation<tank_multires<2>> sim(p, std::move(s0), &tank.walls);
  double V0 = 0.0;
  for (index_t i = 0; i < sim.state().n_real(); ++i) V0 += sim.state().get<field::volume>()[i];
  for (int k = 0; k < 3; ++k) sim.step();
  double V1 = 0.0;
  for (index_t i = 0; i < sim.state().n_real(); ++i) V1 += sim.state().get<field::volume>()[i];
  CHECK(sim.counters().left_domain == 1);
  CHECK(sim.counters().splits > 5);
  CHECK(sim.state().n_real() == tank.size() + sim.counters().splits - sim.counters().merges);
  const auto& fluxes = sim.ledger().totals().fluxes;
  REQUIRE(fluxes.size() == 1);
  CHECK(fluxes[0].name == "left_domain");
  CHECK(fluxes[0].volume == -tc.L * tc.L);
  CHECK(fluxes[0].momentum == vec<2>(-0.5 * tc.L * tc.L, 0.0));
  CHECK(fluxes[0].particles == -1);
  CHECK(V1 == doctest::Approx(V0 - tc.L * tc.L).epsilon(1e-14));
  // The runners' volume balance: ΣV(t) − ΣV(0) − net_boundary_volume() (no inflow or outflow here).
  CHECK(sim.counters().net_boundary_volume() == -tc.L * tc.L);
}

TEST_CASE_TEMPLATE(
    "split_merge: the LSMPS stepper splits at walls, a corner and the free surface (tank at rest)", Dim,
    std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
  // A polygon tank (60° incline on the left, L = 0.01 m) at rest; L* = 0.75 L in the right part x > 0.05 m,
  // which holds the right wall, the floor corner and the free surface: 3 steps. Every particle must stay at
  // a signed wall distance ≥ 0, volume and momentum balance per event (the ledger throws otherwise).
  constexpr int D = Dim::value;
  const cases::polygon_tank_config tc = refined_tank_config();
  const auto tank = cases::make_polygon_tank<D>(tc);
  scheme::lsmps_state<D> s0(tank.size());
  s0.x() = tank.x;
  s0.template get<field::volume>().setConstant(std::pow(tc.L, D));
  scheme::lsmps_params<D> p;
  p.resolution.target_diameter = [L = tc.L](const vec<D>& x) { return x[0] > 0.05 ? 0.75 * L : L; };
  simulation<tank_multires<D>> sim(p, std::move(s0), &tank.walls);
  const auto volume = [&]() {
    double v = 0.0;
    for (index_t i = 0; i < sim.state().n_real(); ++i) v += sim.state().template get<field::volume>()[i];
    return v;
  };
  const double V0 = volume();
  const index_t n0 = sim.state().n_real();
  index_t surface_splits = 0;
  for (int k = 0; k < 3; ++k) {
    sim.step();
    const auto& rep = sim.last_resolution();
    for (const auto& ev : rep.split_events)
      if (sim.state().flags()[static_cast<std::size_t>(ev.child[0])] & flag::surface) ++surface_splits;
  }
  double dmin = 1e300;
  for (index_t i = 0; i < sim.state().n_real(); ++i)
    dmin = std::min(dmin, tank.walls.signed_distance(sim.state().x().col(i)));
  MESSAGE(D << "D tank: " << n0 << " -> " << sim.state().n_real() << " particles, " << sim.counters().splits
            << " splits (" << surface_splits << " of surface particles), refused at walls "
            << sim.last_resolution().refused_for(res::refusal::wall)
            << " in the last step, min signed distance " << dmin / tc.L << " L, guard activations "
            << sim.counters().guarded);
  CHECK(sim.counters().splits > 5);
  CHECK(surface_splits > 0);
  CHECK(dmin > 0.0);
  CHECK(volume() == doctest::Approx(V0).epsilon(1e-14));
  CHECK(sim.ledger().totals().max_volume_ulps <= 4.0);
  sim.state().validate();
}

}  // TEST_SUITE

TEST_SUITE("multires_hard") {
  // Issue #9's hard cases at CI size: a 2D tank of water at rest (the scheme's defaults: ν = 1e-6 m²/s,
  // g = 9.81 m/s²) refined by splitting, run to its end
  // with the issue's bounds: no NaN or failure, max |u| ≤ 5 √(gH), min r_ij/L_ij ≥ 0.3, c ≤ 2, guard
  // activations reported (and asserted 0 here: the fluid is at rest). Beyond the issue, the tank must stay
  // quiet: the two fixes of docs/resolution.md "Hard cases" (mixed-size stencils in the filter band; a split
  // keeps a wall in contact) are what keep it so, and without them each case fails (measured there).
  struct hard_outcome {
    double umax_run = 0.0, umax_end = 0.0, rmin = 1e300, cmax = 0.0, Lmin = 1e300, dV = 0.0;
    long splits = 0, merges = 0, surface_splits = 0, guarded = 0, contact_refusals = 0, collisions = 0;
  };
  // target(x, t): L* as a function of position and time. T_end in √(H/g).
  template <int D = 2, class Target>
  hard_outcome run_hard_tank(const cases::polygon_tank_config& tc, double T_end, const Target& target,
                             double wall_contact = std::numeric_limits<double>::infinity(),
                             scheme::copy_row_kind copy_row = scheme::copy_row_kind::parent_gradient,
                             void (*configure)(scheme::lsmps_params<D>&) = nullptr) {
    const auto tank = cases::make_polygon_tank<D>(tc);
    scheme::lsmps_state<D> s0(tank.size());
    s0.x() = tank.x;
    s0.template get<field::volume>().setConstant(std::pow(tc.L, D));
    scheme::lsmps_params<D> p;
    p.resolution.wall_contact = wall_contact;
    p.copy_row = copy_row;
    if (configure) configure(p);
    double now = 0.0;
    p.resolution.target_diameter = [&](const vec<D>& x) { return target(x, now); };
    simulation<tank_multires<D>> sim(p, std::move(s0), &tank.walls);
    const double g = -p.g[D - 1], H = tank.surface_height, c = std::sqrt(g * H), T = std::sqrt(H / g);
    const auto volume = [&]() {
      double v = 0.0;
      for (index_t i = 0; i < sim.state().n_real(); ++i) v += sim.state().template get<field::volume>()[i];
      return v;
    };
    const double V0 = volume();
    const auto min_ratio = [&]() { return cases::min_pair_ratio(sim.state(), p.domain); };
    hard_outcome o;
    long k = 0;
    while (sim.time() < T_end * T) {
      now = sim.time();
      sim.step();
      const auto& st = sim.state();
      double um = 0.0;
      for (index_t i = 0; i < st.n_real(); ++i) {
        um = std::max(um, st.u().col(i).norm());
        o.Lmin = std::min(o.Lmin, std::pow(st.template get<field::volume>()[i], 1.0 / D));
      }
      o.umax_run = std::max(o.umax_run, um / c);
      o.umax_end = um / c;
      const auto& cp = sim.packing_ratio();
      for (index_t i = 0; i < std::min<index_t>(st.n_real(), cp.size()); ++i)
        o.cmax = std::max(o.cmax, cp[i]);
      for (const auto& ev : sim.last_resolution().split_events)
        if (st.flags()[static_cast<std::size_t>(ev.child[0])] & flag::surface) ++o.surface_splits;
      o.contact_refusals += static_cast<long>(sim.last_resolution().refused_for(res::refusal::wall_contact));
      // every step while the sizes change (the closest pairs appear in the step of a split), then every 10th
      if (++k <= 60 || k % 10 == 0 || !sim.last_resolution().split_events.empty())
        o.rmin = std::min(o.rmin, min_ratio());
    }
    o.rmin = std::min(o.rmin, min_ratio());
    o.splits = sim.counters().splits;
    o.merges = sim.counters().merges;
    o.guarded = sim.counters().guarded;
    o.collisions = sim.counters().collisions;
    o.dV = volume() / V0 - 1.0;
    sim.state().validate();
    std::printf(
        "multires_hard %dD: %ld steps, %ld -> %ld particles, L_min/L = %.3f, splits %ld (%ld of surface "
        "particles), "
        "merges %ld, contact refusals %ld; max |u| / sqrt(gH) over the run %.2e, at the end %.2e; min "
        "r_ij/L_ij %.3f; max c %.3f; guard %ld; collisions %ld; volume change %.1e\n",
        D, k, static_cast<long>(tank.size()), static_cast<long>(sim.state().n_real()), o.Lmin / tc.L,
        o.splits, o.surface_splits, o.merges, o.contact_refusals, o.umax_run, o.umax_end, o.rmin, o.cmax,
        o.guarded, o.collisions, o.dV);
    return o;
  }

  // A 2D box tank (vertical walls) of width W filled to H with L = 10 mm.
  cases::polygon_tank_config box_tank(double W, double H, double height) {
    cases::polygon_tank_config tc;
    tc.W = W;
    tc.H = H;
    tc.tank_height = height;
    tc.L = 0.01;
    tc.angle_deg = 90.0;
    return tc;
  }

  // The 3D box W = B = 0.1 m filled to H = 0.075 m with L = 12.5 mm (384 particles).
  cases::polygon_tank_config box_tank_3d() {
    cases::polygon_tank_config tc = box_tank(0.1, 0.075, 0.15);
    tc.L = 0.0125;
    tc.B = 0.1;
    return tc;
  }

  // The issue's bounds, common to every case.
  void check_issue_bounds(const hard_outcome& o) {
    CHECK(o.umax_run <= 5.0);
    CHECK(o.rmin >= 0.3);
    CHECK(o.cmax <= 2.0);
    CHECK(o.guarded == 0);
    CHECK(std::abs(o.dV) <= 1e-13);  // volume is the stored size: splits and merges conserve it to rounding
  }

  TEST_CASE("multires_hard: size ratio 5.7 in a refined disc inside a tank at rest, 5.5 sqrt(H/g)") {
    // W = 0.3 m, H = 0.2 m, L = 10 mm (600 particles); L* = L/5 within 20 mm of (0.15, 0.1) m, a linear ramp
    // to 1.05 L at 80 mm; the ratio is ramped in over the first 0.5 s (3.5 √(H/g) of this 0.2 m deep tank;
    // the comment said 5 until 2026-12-04, the value of the 0.1 m tanks below), as a flow brings particles
    // into a refined region. Five generations (0.707, 0.5, 0.354, 0.25, 0.177 L): L_min = L/√32.
    // Measured: ≈ 1450 particles, max |u| 9.2e-2 √(gH) during the ramp and 1.3e-3 at 8 √(H/g) (1.1e-3 at 12,
    // which the label ran until 2026-11-29), min r_ij/L_ij 0.69; without mixed-size stencils in the filter
    // band it failed at 4 √(H/g). To 6.5 √(H/g) since 2026-12-04 (issue #9's CI budget on a slower machine):
    // 1.4e-3 at the end, the rest as at 8 (the extremes fall in the ramp; measured). To 5.5 (2 √(H/g) after
    // the ramp) since the second cut that day (16 -> 14 s): 786 steps, 1440 particles, 1.5e-3 at the end; the
    // extremes as at 8.
    const cases::polygon_tank_config tc = box_tank(0.3, 0.2, 0.3);
    const double L = tc.L, T_end = 5.5;
    const auto o = run_hard_tank(tc, T_end, [L](const vec<2>& x, double t) {
      const double Lf = L / (1.0 + 4.0 * std::min(t / 0.5, 1.0));
      const double f = std::clamp(((x - vec<2>(0.15, 0.1)).norm() - 0.02) / 0.06, 0.0, 1.0);
      return Lf + f * (1.05 * L - Lf);
    });
    check_issue_bounds(o);
    CHECK(o.Lmin <= 0.18 * L);  // the ratio was reached: L/5.66
    CHECK(o.umax_end <= 1e-2);  // quiet at the end (measured 1.5e-3)
  }

  TEST_CASE(
      "multires_hard: splitting at the right wall, the floor corner and the free surface, 8 sqrt(H/g)") {
    // The box W = 0.2 m, H = 0.1 m, L = 10 mm (200 particles); L* = L/3 within 20 mm of the right wall, ramp
    // to 1.05 L at 80 mm (three generations, L_min = 0.354 L, ratio 2.8). Two runs: the target at once (three
    // generations in the first three steps) and ramped in over 0.5 s, both with wall_contact = 0.75 (opt-in).
    // Measured (2026-11-28): at once, max |u| 0.13 √(gH) in the first steps, 1.4e-2 at the end, min r_ij/L_ij
    // 0.470; ramped: 7.5e-3 and 2.4e-3, 0.483 (measured every step while sizes change). Before the
    // neighbouring- splits pass (docs/resolution.md, Choices 11) the at-once run closed to 0.282 and the
    // ramped one to 0.318: children of two neighbours splitting in the same step. Without the wall-contact
    // rule the first row sat 1.06-1.41 L′ above the floor (no copies there) and the PPE failed at step 16 (at
    // once) or t = 4.1 √(H/g) (ramped). To 8 √(H/g) since 2026-12-04 (10 before; issue #9's CI budget on a
    // slower machine): at the end 1.9e-2 (at once) and 1.8e-3 (ramped), the extremes as to 10 (measured).
    const cases::polygon_tank_config tc = box_tank(0.2, 0.1, 0.2);
    const double L = tc.L;
    for (const double ramp : {0.0, 0.5}) {
      CAPTURE(ramp);
      const auto o = run_hard_tank(tc, 8.0, [L, ramp](const vec<2>& x, double t) {
        const double Lf = L / (1.0 + 2.0 * (ramp > 0.0 ? std::min(t / ramp, 1.0) : 1.0));
        const double f = std::clamp((0.2 - x[0] - 0.02) / 0.06, 0.0, 1.0);
        return Lf + f * (1.05 * L - Lf);
      }, 0.75);  // the wall-contact rule, opt-in (split_merge_params::wall_contact)
      check_issue_bounds(o);  // the issue's min r_ij/L_ij ≥ 0.3 (measured 0.470 at once, 0.483 ramped)
      CHECK(o.Lmin <= 0.36 * L);
      CHECK(o.surface_splits > 0);
      CHECK(o.umax_end <= (ramp > 0.0 ? 1e-2 : 5e-2));  // measured 1.8e-3 (ramped), 1.9e-2 (at once)
    }
  }

  TEST_CASE(
      "multires_hard: size ratio 5 at the right wall, the floor corner and the free surface, 8 sqrt(H/g)") {
    // The box of the case above with L* = L/5 within 20 mm of the right wall (ramp to 1.05 L at 80 mm), the
    // ratio ramped in over 0.5 s; five generations, L_min = L/√32 (ratio 5.7). With the default wall options
    // it fails (docs/resolution.md "Hard cases": 4.6 √(H/g); with collisions, max |u| 8.3 √(gH) at T ≈ 4 and
    // a blow-up). With the dam break's most robust wall options (tpocml: two-point copy rows, wall-only
    // shifting, active set with copies, own-loop guard, cond1 ≤ 1e4, limited shifted velocity) it reached its
    // end but clustered in the split bursts (min r_ij/L_ij 0.194); the collision stage
    // (lsmps_params::collision, α1 = 0.5, deviation 17) holds the pairs apart. Measured (2026-12-03): max |u|
    // 0.80 √(gH), min r_ij/L_ij 0.494 as sampled here (0.474 measured after every step), max c 1.40, guard 0,
    // 845 splits. Ratio 4 with the same options once reached 6.8 √(gH) (a single splash at T ≈ 6.3) and
    // ratios 4.5 / 5.5 passed: the bounds hold run by run, not by construction. To 8 √(H/g) since 2026-12-06
    // (10 before; issue #9's CI budget): 1011 particles at the end, 821 splits / 10 merges, max |u| 0.80
    // √(gH), min r_ij/L_ij 0.494, max c 1.40, guard 0, 7807 colliding pairs (measured); the extremes as to
    // 10.
    const cases::polygon_tank_config tc = box_tank(0.2, 0.1, 0.2);
    const double L = tc.L;
    const auto o = run_hard_tank(
        tc, 8.0,
        [L](const vec<2>& x, double t) {
          const double Lf = L / (1.0 + 4.0 * std::min(t / 0.5, 1.0));
          const double f = std::clamp((0.2 - x[0] - 0.02) / 0.06, 0.0, 1.0);
          return Lf + f * (1.05 * L - Lf);
        },
        std::numeric_limits<double>::infinity(), scheme::copy_row_kind::parent_gradient,
        +[](scheme::lsmps_params<2>& p) {
          cases::tanaka_wall_variant_named(
              "two_point_wall_only_active_set_own_loop_copies_conditioned_limited", "multires_hard")
              .apply(p);
          p.collision.alpha1 = 0.5;
        });
    check_issue_bounds(o);  // measured 0.80 √(gH), 0.494, 1.40, guard 0
    CHECK(o.Lmin <= 0.18 * L);  // the ratio was reached: L/5.66
    CHECK(o.surface_splits > 0);
    // the stage acted (measured 8871 colliding directed pairs to 10 √(H/g), 7807 to 8)
    CHECK(o.collisions > 0);
  }

  TEST_CASE("multires_hard: 3D, splitting at a wall and along the floor edge, 3 sqrt(H/g)") {
    // Issue #9 item 3 in 3D with imaginary walls: the box W = B = 0.1 m filled to H = 0.075 m, L = 12.5 mm
    // (384 particles); L* = L/2 in the patch x ≥ 85 mm, 35 ≤ y ≤ 65 mm, z ≤ 25 mm (the right wall and the
    // floor, their edge inside), a linear ramp to 1.05 L 30 mm outside it, ramped in over 0.15 s (1.7
    // √(H/g)): three generations (0.794, 0.630, 0.5 L). Measured (2026-11-26): 384 → 532 particles (153
    // splits, 5 merges), max |u| 0.22 √(gH) during the ramp and 1.6e-2 at the end, min r_ij/L_ij 0.487,
    // c ≤ 1.38, guard 0, 34 s of one core (to 4 √(H/g)). To 3 √(H/g) since 2026-12-04 (issue #9's CI budget
    // on a slower machine; 14 -> 10 s): 384 -> 533 (151 splits, 2 merges), 2.9e-2 at the end, the extremes as
    // to 4 (they fall in the ramp; measured). A refined zone that holds a vertical edge of the box (two walls
    // meeting at the free surface) fails with these (default) wall rows: the next case, and
    // docs/resolution.md "What fails in 3D".
    const cases::polygon_tank_config tc = box_tank_3d();
    const double L = tc.L, T_end = 3.0;
    const auto o = run_hard_tank<3>(tc, T_end, [L](const vec<3>& x, double t) {
      const double Lf = L / (1.0 + std::min(t / 0.15, 1.0));
      const double d = std::max({0.085 - x[0], 0.035 - x[1], x[1] - 0.065, x[2] - 0.025, 0.0});
      const double f = std::clamp(d / 0.03, 0.0, 1.0);
      return Lf + f * (1.05 * L - Lf);
    });
    check_issue_bounds(o);
    CHECK(o.Lmin <= 0.51 * L);  // the ratio was reached: three generations, L/2
    CHECK(o.splits > 100);
    // decaying after the ramp (measured 2.9e-2 √(gH) at 3, 1.3 √(H/g) after it; 1.6e-2 at 4)
    CHECK(o.umax_end <= 5e-2);
  }

  TEST_CASE(
      "multires_hard: 3D, the whole right wall refined (vertical edges, triple corners), Neumann-point rows, "
      "3 sqrt(H/g)") {
    // The box of the previous case with L* = L/2 for x ≥ 85 mm (the whole right wall: both vertical edges
    // from the floor through the free surface and both triple corners at the floor), a linear ramp to 1.05 L
    // 30 mm outside it, ramped in over 0.15 s. With the default wall rows (copy_row = parent_gradient) this
    // fails: the PPE does not converge at 1.41 √(H/g) (2.39 and 2.44 with a 0.5 s ramp in the two records of
    // 2026-11-28; rerun with the cold restart of 2026-12-05: 1.42 and 2.53). Not the solver's: with SparseLU
    // behind BiCGSTAB (ppe::with_fallback) the velocities grow before the first failed solve and the run
    // blows up at 1.43 and 2.53 (docs/resolution.md "What fails in 3D", 2026-12-06). With the default rows
    // and scheme::lsmps_impact_params<3>() it runs to 7 √(H/g) within the issue's bounds (ramps 0.15, 0.3,
    // 0.5 s; harness only, 56 s to 3 √(H/g): not in CI). With the copies as Neumann points
    // (copy_row = neumann_points, docs/lsmps_scheme.md deviation 11; opt-in) it runs to the end. Measured
    // (2026-11-28; 34 s wall, two threads; to 7 √(H/g)): 384 -> 949 particles (583 splits, 18 merges), max
    // |u| 0.19 √(gH) during the ramp and 2.2e-2 at the end, min r_ij/L_ij 0.398, c ≤ 1.54, guard 0. To 4
    // √(H/g) since 2026-12-04 (issue #9's CI budget on a slower machine; 41 -> 21 s): 384 -> 956 (583 splits,
    // 11 merges), 1.7e-2 at the end, the extremes as to 7 (they fall in the ramp; measured). To 3 √(H/g)
    // since the second cut that day (21 -> 17 s): 384 -> 960 (582 splits, 6 merges), 1.6e-2 at the end, the
    // same extremes. With shift_second_wall on (opt-in, deviation 12) this case is worse: with a 0.45 s ramp
    // two L/2 particles in a floor triple corner drift to 0.269 L_ij (0.452 with it off); with this 0.15 s
    // ramp a burst there gives 0.240 and max |u| 8.5 √(gH) (rerun 2026-11-28; 2.85 in the earlier run of
    // docs/resolution.md). That option is off here, as by default.
    const cases::polygon_tank_config tc = box_tank_3d();
    const double L = tc.L, T_end = 3.0;
    const auto o = run_hard_tank<3>(tc, T_end, [L](const vec<3>& x, double t) {
      const double Lf = L / (1.0 + std::min(t / 0.15, 1.0));
      const double f = std::clamp(std::max(0.085 - x[0], 0.0) / 0.03, 0.0, 1.0);
      return Lf + f * (1.05 * L - Lf);
    }, std::numeric_limits<double>::infinity(), scheme::copy_row_kind::neumann_points);
    check_issue_bounds(o);  // min r_ij/L_ij ≥ 0.3 (measured 0.398), max |u| ≤ 5 √(gH) (0.19), c ≤ 2 (1.54)
    CHECK(o.Lmin <= 0.51 * L);  // the ratio was reached: L/2
    CHECK(o.splits > 400);      // the whole wall split (measured 582 to 3 √(H/g), 583 to 4 and 7)
    CHECK(o.umax_end <= 5e-2);  // settled after the ramp (measured 1.6e-2 √(gH))
  }
}  // TEST_SUITE

TEST_SUITE("taylor_green_multires") {
  // Issue #9's [taylor_green_multires] at CI size: Tanaka's refined disc (radius 0.25 m around (0.75, 0.75)
  // m) in the periodic inviscid Taylor–Green vortex, N = 50 (L = 0.02 m), to t = 0.35 s. The paper's target
  // is 3.5 mm at L = 5 mm (200²); at N = 50 the same ratio, L* = 0.7 L in the disc (one split: 0.7 L < β_s
  // L = 0.854 L; the children keep, 0.7 L ≥ β_s L′ = 0.604 L), and 1.05 L outside (children that leave merge:
  // 1.05 L > β_m L′ = L; with exactly L the merge test would be a tie, decided by rounding). Single
  // resolution: the same scene with L* = 1.05 L everywhere (no event).
  TEST_CASE("split_merge: Taylor-Green with Tanaka's refined disc against single resolution, 0.35 s") {
    const int n = 50;
    struct outcome {
      double drift = 0.0, rmin = 1e300, cmax = 0.0, umax = 0.0;
      long splits = 0, merges = 0, steps = 0;
      index_t nmax = 0, nend = 0;
      double ledger_dke = 0.0, max_volume_ulps = 0.0;
    };
    const auto run = [&](bool multi) {
      cases::taylor_green_config c;
      c.n = n;
      c.t_end = 0.35;
      const double L = c.width / c.n;
      auto p = cases::taylor_green_params(c);
      // Adaptive Δt (piecewise constant, Courant α_C = 0.1) under dt_max = 0.09 L′/U: both runs keep dt_max
      // (393 steps to 0.5 s, smallest diameter 0.707 L, measured). To t = 0.4 s since 2026-12-04 (0.5 s
      // before; issue #9's CI budget on a slower machine, 39 -> 29 s): 315 steps, drift -2.89e-3 against
      // -3.26e-3 single (-3.86e-3 / -3.98e-3 at 0.5 s), 1220 splits and 524 merges (1368 / 676), min
      // r_ij/L_ij 0.585 and c <= 1.142 as to 0.5 s. To 0.35 s since the second cut that day (29 -> 25 s): 275
      // steps, drift -3.49e-3 against -4.14e-3 single, 0.84x (0.89x at 0.4 s, 0.97x at 0.5 s: the drift is
      // not monotonic in t, both runs lose more energy by 0.35 s than by 0.4 s, so the 2x check below depends
      // on when it is taken), 1143 splits and 458 merges, min r_ij/L_ij 0.585 and c <= 1.142 as to 0.5 s.
      p.time.mode = scheme::time_step_mode::adaptive;
      p.time.dt_max = c.dt_courant * (L / std::sqrt(2.0)) / c.speed;
      // 0.7 L in the disc, a linear ramp over 4 L to 1.05 L outside (with a jump at r = 0.25 m, measured: min
      // r_ij/L_ij 0.28 instead of 0.44: a particle crossing the edge splits and merges back within steps).
      // The distance to the centre is the minimum image: the disc touches the periodic edges x = 1 m and
      // y = 1 m, and its ramp (r = 0.25–0.33 m) crosses them. With the plain distance L* jumped from ≈ 0.7 L
      // to 1.05 L across those edges, where the vortex carries particles into the disc (x = 1 m) and out of
      // it (y = 1 m) at up to U: min r_ij/L_ij 0.423 at the edges (instead of 0.518), children merged with
      // coarse neighbours (1.5 V) split twice on re-entry (0.61 L) and halved Δt (765 steps; measured).
      p.resolution.target_diameter = [L, multi, dom = p.domain](const vec<2>& x) {
        if (!multi) return 1.05 * L;
        vec<2> d = x - vec<2>(0.75, 0.75);
        dom.minimum_image(d);
        const double f = std::clamp((d.norm() - 0.25) / (4.0 * L), 0.0, 1.0);
        return (0.7 + 0.35 * f) * L;
      };
      // Merge order: the nearest eligible partner (the paper's text read literally), not the default
      // alike_first. Measured: min r_ij/L_ij 0.585 (alike_first 0.518, both_ask 0.434); with nearest
      // 0.585–0.588 for ramps of 2, 3, 4, 6 and 8 L, always between two coarse particles at the saddle (0.25,
      // 0.25) m, while with alike_first the minimum is a merged particle beside a child and moves with the
      // ramp (0.48–0.59).
      p.resolution.partners = res::merge_partners::nearest;
      simulation<tg_multires> sim(p, cases::taylor_green_state(c));
      const auto ke = [&]() {
        double e = 0.0;
        const auto& st = sim.state();
        for (index_t i = 0; i < st.n_real(); ++i)
          e += 0.5 * c.rho * st.template get<field::volume>()[i] * st.u().col(i).squaredNorm();
        return e;
      };
      const auto min_ratio = [&]() { return cases::min_pair_ratio(sim.state(), p.domain); };
      outcome o;
      const double e0 = ke();
      o.rmin = min_ratio();
      while (sim.time() < c.t_end) {
        sim.step();
        ++o.steps;
        const auto& st = sim.state();
        o.rmin = std::min(o.rmin, min_ratio());
        const auto& cp = sim.packing_ratio();
        for (index_t i = 0; i < std::min<index_t>(st.n_real(), cp.size()); ++i)
          o.cmax = std::max(o.cmax, cp[i]);
        for (index_t i = 0; i < st.n_real(); ++i) o.umax = std::max(o.umax, st.u().col(i).norm());
        o.nmax = std::max(o.nmax, st.n_real());
      }
      o.drift = ke() / e0 - 1.0;
      o.splits = sim.counters().splits;
      o.merges = sim.counters().merges;
      o.nend = sim.state().n_real();
      o.ledger_dke = sim.ledger().totals().dKE / e0;
      o.max_volume_ulps = sim.ledger().totals().max_volume_ulps;
      sim.state().validate();
      return o;
    };
    const outcome single = run(false), multi = run(true);
    for (const auto* o : {&single, &multi})
      std::printf(
          "taylor_green_multires %s: %ld steps, particles end %ld (max %ld), splits %ld, merges %ld, E/E0 - "
          "1 = %.3e, min r_ij/L_ij = %.3f, max c = %.3f, max |u| = %.3f, ledger dKE/E0 = %.2e\n",
          o == &single ? "single" : "multi ", o->steps, static_cast<long>(o->nend),
          static_cast<long>(o->nmax), o->splits, o->merges, o->drift, o->rmin, o->cmax, o->umax,
          o->ledger_dke);
    CHECK(single.splits == 0);
    CHECK(single.merges == 0);
    CHECK(multi.splits > 500);  // the disc is refined, and particles leaving it merge back
    CHECK(multi.merges > 300);
    // Issue #9: the energy drift no worse than 2× the single-resolution run at the same coarse spacing.
    CHECK(std::abs(multi.drift) <= 2.0 * std::abs(single.drift));
    // Issue #9: no clustering, min r_ij/L_ij ≥ 0.5 and c ≤ 1.5 throughout (the values are printed above and
    // in docs/resolution.md).
    // Measured: c ≤ 1.14 (single 1.14). min r_ij/L_ij 0.585 (single resolution 0.576): both at the vortex's
    // saddles, which compress the lattice, between coarse particles: the refinement adds no closer pair
    // (docs/resolution.md).
    CHECK(multi.rmin >= 0.5);
    CHECK(multi.cmax <= 1.5);
    CHECK(multi.max_volume_ulps <= 4.0);  // the ledger's per-event bound (it throws beyond it)
  }
}

namespace {
struct tanaka_multires : lsmps_defaults<2> {
  using resolution = mpskit::resolution::split_merge<>;
};
/// The largest packing ratio c of the real particles over every step (run_tanaka_dam_break's observer), one
/// of issue #9's hard-case bounds; the largest speed is the runner's own tanaka_dam_break_result::u_max.
struct run_max_packing {
  double c = 0.0;
  template <class Sim>
  void operator()(const Sim& sim) {
    const auto& cp = sim.packing_ratio();
    for (index_t i = 0; i < std::min<index_t>(sim.state().n_real(), cp.size()); ++i) c = std::max(c, cp[i]);
  }
};
}  // namespace

TEST_SUITE("dam_break_multires") {
  TEST_CASE(
      "dam break (§5.6.1) refined 2:1 toward the right-bottom corner: through the far-wall impact, front "
      "within 5 % of single resolution") {
    // Issue #9's [dam_break_multires] at a CI spacing: L = 4 mm; L* = 2 mm within 50 mm of (200, 0) mm, a
    // linear ramp to 1.05 L at 150 mm (the paper: 1–5 mm by the distance from that corner, its Fig. 24b is
    // not in the text; ours), wall_contact = 0.75 (a split beside a wall keeps a child in contact,
    // docs/resolution.md). Both runs to T = 3.15, through the surge's impact on the far wall (the probe
    // (195, 5) mm wet at T ≈ 2.9, its 10 ms window ending by T ≈ 3.1; to T = 3.4 until 2026-12-04, cut for
    // issue #9's CI budget on a slower machine, 106 -> 65 s: the same front, speed, pair, packing, probe and
    // impulse numbers; 371 splits and 0 merges, 1621 particles at the end, 2128 / 1585 steps, where to
    // T = 3.4 548, 2, 1796, 2835 / 1939; measured), with the options of the main example
    // (cases::tanaka_impact_walls, the collision stage at alpha1 0.5 with isolated particles, isolated
    // particles in the shifting penalty; all opt-in: with the library's defaults the single-resolution dam
    // break fails at T ≈ 1.6, docs/lsmps_scheme.md; until 2026-12-03 this test ran to T = 2.8 with
    // copy_two_point and wall-only shifting, whose multi-resolution run fails at T ≈ 3.2). Measured
    // (2026-12-03, to T = 3.4, -O3 harness and this test, the same numbers): largest front difference 2.0 %
    // (T = 2.90), RMS 0.49 % up to the single run's impact (T = 2.953), the same over the largest connected
    // body (2026-12-04: neither run has spray ahead of its surge before the impact); multi 4.72 sqrt(gH),
    // closest pair 0.457 L, single 3.13 sqrt(gH), 0.486 L, no guard activation in either; 548 splits, 2
    // merges. The issue's impulse within 10 % is not asserted: over 10 ms from the first wet sample the
    // multi-resolution run has 14.5 Pa s against 22.6 (36 % apart), over 20 ms 48.0 against 52.6 (9 %), and
    // single runs at 5, 4, 2.5 and 2 mm give 31.9, 22.6, -0.5, 0.04 Pa s over 10 ms (the 2.5 and 2 mm probes
    // are first wetted by a film ahead of the surge): the measure does not converge with resolution, so a
    // bound on it would test noise (docs/resolution.md "Dam break with splitting").
    cases::tanaka_dam_break_config c;
    c.L = 0.004;
    scheme::lsmps_params<2> p = scheme::lsmps_impact_params<2>();
    const double T_end = 3.15;
    const auto single = cases::run_tanaka_dam_break(c, T_end, p);
    const vec<2> corner(c.vessel_right, 0.0);
    const double L = c.L, Lf = 0.5 * c.L;
    p.resolution.target_diameter = [=](const vec<2>& x) {
      return Lf + std::clamp(((x - corner).norm() - 0.05) / 0.1, 0.0, 1.0) * (1.05 * L - Lf);
    };
    p.resolution.wall_contact = 0.75;
    run_max_packing maxima;
    const auto multi = cases::run_tanaka_dam_break<tanaka_multires>(c, T_end, p, false, maxima);
    // Samples are taken at the first step at or after each multiple of 0.05 T, so the two runs' sample times
    // differ by up to a step: the multi-resolution front is interpolated linearly to the single run's times.
    REQUIRE(multi.T.size() >= 2);
    const cases::impact_measures ms = cases::far_wall_impact(single), mm = cases::far_wall_impact(multi);
    const cases::tanaka_dam_break db = cases::make_tanaka_dam_break(c);
    // Fronts compared up to the single run's first wet sample at the far-wall probe: after it both fronts are
    // the vessel's width (as the main example and the speed-against-error reporter compare them).
    const cases::front_difference d = cases::compare_fronts(multi, single, db.t_star(ms.t_arrival));
    // The same over the largest connected body (io::largest_body: spray clusters ahead of the surge left
    // out).
    const cases::front_difference b = cases::compare_fronts(multi, single, db.t_star(ms.t_arrival),
                                                            &cases::tanaka_dam_break_result::Z_body);
    const double sqrt_gh = std::sqrt(c.g * c.column_height);
    std::printf("dam_break_multires: body front: largest difference %.4f at T = %.2f (RMS %.4f)\n", b.max,
                b.T_max, b.rms);
    std::printf(
        "dam_break_multires: to T = %.2f, %zu front samples, largest |Z_multi/Z_single - 1| = %.4f at T = "
        "%.2f (RMS %.4f); "
        "particles %ld -> %ld (single %ld), L_min %.2f mm, splits %ld merges %ld, volume change %.1e, guard "
        "%ld / %ld, "
        "max |u| %.2f / %.2f sqrt(gH), closest pair %.3f / %.3f L, max c %.3f, probe wet at T = %.3f / %.3f, "
        "impulse over 10 ms %.1f / %.1f Pa s, steps %ld / %ld, wall %.1f / %.1f s\n",
        T_end, single.Z.size(), d.max, d.T_max, d.rms, static_cast<long>(multi.particles),
        static_cast<long>(multi.particles_end), static_cast<long>(single.particles_end), multi.L_min * 1e3,
        multi.splits, multi.merges, multi.volume_change, multi.guarded, single.guarded, multi.u_max / sqrt_gh,
        single.u_max / sqrt_gh, multi.min_pair_ratio, single.min_pair_ratio, maxima.c,
        db.t_star(mm.t_arrival), db.t_star(ms.t_arrival), mm.impulse, ms.impulse, multi.steps, single.steps,
        multi.wall_seconds, single.wall_seconds);
    // (Both runs throw if they fail before T_end: catch_failure is off.)
    CHECK(d.samples >= 55);  // the comparison covered the run up to the impact (T ≈ 2.95, every 0.05 T)
    CHECK(d.max <= 0.05);           // the issue's 5 %
    CHECK(b.samples == d.samples);  // ... and for the front over the largest body
    CHECK(b.max <= 0.05);
    CHECK(mm.complete);  // both probes got wet and their 10 ms windows ended: the runs went through
    CHECK(ms.complete);             // the far-wall impact ...
    CHECK(db.t_star(mm.t_arrival) > 2.8);  // ... wet by the surge (it reaches the far wall at T ≈ 2.9)
    CHECK(db.t_star(ms.t_arrival) > 2.8);
    CHECK(multi.u_max <= 5.0 * sqrt_gh);  // the issue's hard-case bounds for the multi-resolution run
    CHECK(multi.min_pair_ratio >= 0.3);
    CHECK(maxima.c <= 2.0);
    CHECK(multi.splits > 50);       // the surge was refined ...
    CHECK(multi.L_min <= 0.5 * L * (1.0 + 1e-12));  // ... down to the target 2 mm
    // volume is the stored size: events conserve it to rounding
    CHECK(std::abs(multi.volume_change) <= 1e-13);
    CHECK(multi.guarded == 0);
    CHECK(single.guarded == 0);
  }

  TEST_CASE(
      "the main example's multi-resolution run: the obstacle case through the far-wall impact (T = 3.55) "
      "within the hard-case bounds") {
    // Issue #9's [dam_break_multires] obstacle case and a hard case (splitting at the block's corners, at the
    // floor, at the free surface of the surge running over it, and in the far-wall impact):
    // examples/multires_dam_break.cpp with its default arguments, the multi-resolution run alone: L = 5 mm,
    // L* = 2.5 mm within 30 mm of the block's centre, a ramp to 1.05 L at 60 mm, to T = 3.55 (the example:
    // 3.8), the options that carry it through the surge's impact on the far wall (cases::tanaka_impact_walls,
    // the collision stage at alpha1 0.5 with isolated particles, isolated particles in the shifting penalty;
    // all opt-in, docs/resolution.md "The main example"). Measured (2026-12-03, the example at -O3 and this
    // test, the same numbers, to T = 3.8): max |u| 3.27 sqrt(gH), closest pair 0.525 L, c <= 1.201, no guard
    // activation, 1001 splits, 719 merges, the far-wall probe (195, 5) mm wet at T = 3.352 and its 10 ms
    // window complete (T = 3.49), volume 1.6e-15. To T = 3.55 since 2026-12-04 (issue #9's CI budget on a
    // slower machine, 62 -> 50 s): the same extremes and probe, 922 splits, 652 merges (measured). Asserted:
    // the issue's bounds through the impact and no guard activation, that the surge reached the far wall (the
    // impact window complete: the run is not a run that stopped short of it), the zone refined and merged
    // back, volume to rounding. Not asserted: the front and impulse against single resolution (the 2.5 mm run
    // costs 4 minutes; the example prints them).
    const cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(0.005);
    scheme::lsmps_params<2> p = scheme::lsmps_impact_params<2>();
    cases::refine_around_block(p, c, 2.0, 0.03, 0.06);
    const double Lf = 0.5 * c.L;
    run_max_packing maxima;
    const double T_end = 3.55;
    const auto r = cases::run_tanaka_dam_break<cases::obstacle_multires_scene>(c, T_end, p, false, maxima);
    const cases::impact_measures m = cases::far_wall_impact(r);
    const cases::tanaka_dam_break db = cases::make_tanaka_dam_break(c);  // T = t sqrt(2g/h0)
    const double sqrt_gh = std::sqrt(c.g * c.column_height);
    std::printf(
        "dam_break_multires obstacle through the impact: to T = %.2f, particles %ld -> %ld, splits %ld "
        "merges %ld, "
        "volume change %.1e, guard %ld, max |u| %.2f sqrt(gH), min r_ij/L_ij %.3f, max c %.3f, probe wet at "
        "T = %.3f, impulse %.1f Pa s%s, steps %ld, %.1f s\n",
        T_end, static_cast<long>(r.particles), static_cast<long>(r.particles_end), r.splits, r.merges,
        r.volume_change, r.guarded, r.u_max / sqrt_gh, r.min_pair_ratio, maxima.c, db.t_star(m.t_arrival),
        m.impulse, m.complete ? "" : " (window incomplete)", r.steps, r.wall_seconds);
    CHECK(r.u_max <= 5.0 * sqrt_gh);    // the issue's explosion bound
    CHECK(r.min_pair_ratio >= 0.3);     // the issue's clustering bound
    CHECK(maxima.c <= 2.0);             // the issue's packing bound
    CHECK(r.guarded == 0);              // no particle crossed a wall, in the impact included
    CHECK(m.complete);                  // the probe got wet and its 10 ms impact window ended before T_end
    // ... by the surge, not by a splash over the block (the coarse run's film: 2.56)
    CHECK(db.t_star(m.t_arrival) > 3.0);
    CHECK(r.splits > 100);
    CHECK(r.merges > 20);
    CHECK(r.L_min <= Lf * (1.0 + 1e-12));
    CHECK(std::abs(r.volume_change) <= 1e-13);
  }
}  // TEST_SUITE

TEST_SUITE("multires_hard") {
  TEST_CASE(
      "2 s of Tanaka's dam break refined 2:1 toward the far corner, in the open vessel (issue #9 hard "
      "case)") {
    // Issue #9's hard case "2 s of the dam break" at a CI size: L = 10 mm (the column 10 x 20 particles),
    // L* = 5 mm within 50 mm of (200, 0) mm, a linear ramp to 1.05 L at 150 mm (the dam_break_multires zone),
    // to t = 2 s (T = 28): the far-wall impact, the run-up, the plunging return wave and the sloshing after
    // it. What it takes (all opt-in; docs/resolution.md "Dam break with splitting"): the dam break's
    // conditioned, limited wall options; the collision stage at alpha1 = 0.7 with isolated particles taking
    // part (collision.isolated); isolated particles in the shifting's overlap penalty
    // (shift_isolated_penalty, deviation 18). The vessel is the case's open one (300 mm walls, ours: the
    // paper gives no height); what the run-up throws over its walls is removed
    // (tanaka_dam_break_config::remove_outside, lsmps_params::remove_outside, deviation 19; before it such
    // particles fell for ever outside and max |u| grew without bound, so this test ran in a vessel with a
    // lid). Measured (2026-12-03, -O3 harness): max |u| 3.14 sqrt(gH), min r_ij/L_ij 0.501 over all pairs
    // (isolated ones included), c <= 1.21, no guard activation, 200 -> 324 particles, 1 removed over the
    // walls, 13 012 steps; without the penalty 3.19 / 0.427 (no guard activation either). Asserted: the
    // issue's bounds and no guard activation, the fine size reached, the volume balance to rounding (the
    // removed volume counted).
    cases::tanaka_dam_break_config c;
    c.L = 0.01;
    scheme::lsmps_params<2> p;
    cases::tanaka_wall_variant_named("two_point_wall_only_active_set_own_loop_copies_conditioned_limited",
                                     "test")
        .apply(p);
    p.collision.alpha1 = 0.7;
    p.collision.isolated = true;
    p.shift_isolated_penalty = true;
    const vec<2> corner(c.vessel_right, 0.0);
    const double L = c.L, Lf = 0.5 * c.L;
    p.resolution.target_diameter = [=](const vec<2>& x) {
      return Lf + std::clamp(((x - corner).norm() - 0.05) / 0.1, 0.0, 1.0) * (1.05 * L - Lf);
    };
    p.resolution.wall_contact = 0.75;
    run_max_packing maxima;
    const auto r = cases::run_tanaka_dam_break<tanaka_multires>(c, 28.0, p, false, maxima);
    const double umax = r.u_max, cmax = maxima.c;
    const double sqrt_gh = std::sqrt(c.g * c.column_height);
    std::printf(
        "multires_hard dam break 2 s: particles %ld -> %ld, L_min %.2f mm, splits %ld merges %ld, volume "
        "change %.1e, guard %ld, max |u| %.2f sqrt(gH), min r_ij/L_ij %.3f (T = %.2f; %.3f without isolated "
        "particles), max c %.3f, collisions %ld, removed over the walls %ld, steps %ld, %.1f s\n",
        static_cast<long>(r.particles), static_cast<long>(r.particles_end), r.L_min * 1e3, r.splits, r.merges,
        r.volume_change, r.guarded, umax / sqrt_gh, r.min_pair_ratio, r.T_min_pair,
        r.min_pair_ratio_non_isolated, cmax, r.collisions, r.left_domain, r.steps, r.wall_seconds);
    CHECK(umax <= 5.0 * sqrt_gh);      // the issue's explosion bound
    CHECK(r.min_pair_ratio >= 0.3);    // the issue's clustering bound (every pair of real particles)
    // shift_isolated_penalty's effect (deviation 18): 0.501 with it, 0.427 without (both measured);
    // fails if the scheme stops passing its isolated particles to the penalty.
    CHECK(r.min_pair_ratio >= 0.45);
    CHECK(cmax <= 2.0);                // the issue's packing bound
    CHECK(r.guarded == 0);             // no particle crossed a wall
    CHECK(r.splits > 100);             // the surge was refined at the far corner
    CHECK(r.L_min <= Lf * (1.0 + 1e-12));
    // ΣV at the end + ΣV removed = ΣV0 (splits conserve it exactly)
    CHECK(std::abs(r.volume_change) <= 1e-13);
    // The penalty of isolated particles needs the per-pair direction (the printed -grad c ignores where they
    // are).
    p.shift.penalty = regularize::penalty_direction::concentration_gradient;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("shift_isolated_penalty"), mpskit::error);
  }
}  // TEST_SUITE

TEST_SUITE("restart") {
  TEST_CASE(
      "restart: LSMPS 3D tank refining at a wall and the floor, 25 steps + save + 25 equals load + 25 "
      "bitwise") {
    // The 3D box of the multires_hard case (L = 12.5 mm, imaginary walls, split/merge to L/2 at the right
    // wall and the floor; here the target at once, no ramp, so the first steps split). In 3D the ledger's
    // angular momentum has three components and the particles three coordinates: the checkpoint must carry
    // all of them.
    mpskit::test::scratch tmp("mpskit_test_split_merge", "restart3d");
    cases::polygon_tank_config tc;  // the multires_hard suite's box_tank_3d()
    tc.W = 0.1;
    tc.H = 0.075;
    tc.tank_height = 0.15;
    tc.angle_deg = 90.0;
    tc.L = 0.0125;
    tc.B = 0.1;
    const double L = tc.L;
    const auto tank = cases::make_polygon_tank<3>(tc);
    scheme::lsmps_state<3> s0(tank.size());
    s0.x() = tank.x;
    s0.get<field::volume>().setConstant(L * L * L);
    scheme::lsmps_params<3> p;
    p.resolution.target_diameter = [L](const vec<3>& x) {
      const double d = std::max({0.085 - x[0], 0.035 - x[1], x[1] - 0.065, x[2] - 0.025, 0.0});
      return 0.5 * L + std::clamp(d / 0.03, 0.0, 1.0) * 0.55 * L;
    };
    simulation<tank_multires<3>> a(p, s0, &tank.walls);
    for (int k = 0; k < 25; ++k) a.step();
    io::save_simulation(tmp / "c.mpscp", a);
    for (int k = 0; k < 25; ++k) a.step();
    simulation<tank_multires<3>> b(p, s0, &tank.walls);
    io::load_simulation(tmp / "c.mpscp", b);
    for (int k = 0; k < 25; ++k) b.step();
    CHECK(a.counters().splits > 0);  // the run refined (measured: splits in the first steps)
    const auto& sa = a.state();
    const auto& sb = b.state();
    REQUIRE(sa.n_real() == sb.n_real());
    const index_t n = sa.n_real();
    const auto bits = [](const auto& x, const auto& y) {
      return x.size() == y.size() &&
             std::memcmp(x.data(), y.data(), sizeof(double) * static_cast<std::size_t>(x.size())) == 0;
    };
    CHECK(bits(Eigen::MatrixXd(sa.x().leftCols(n)), Eigen::MatrixXd(sb.x().leftCols(n))));
    CHECK(bits(Eigen::MatrixXd(sa.u().leftCols(n)), Eigen::MatrixXd(sb.u().leftCols(n))));
    CHECK(bits(Eigen::VectorXd(sa.get<field::pressure>().head(n)),
               Eigen::VectorXd(sb.get<field::pressure>().head(n))));
    CHECK(bits(Eigen::VectorXd(sa.get<field::volume>().head(n)),
               Eigen::VectorXd(sb.get<field::volume>().head(n))));
    CHECK(std::equal(sa.ids().begin(), sa.ids().begin() + n, sb.ids().begin()));
    CHECK(a.time() == b.time());
    CHECK(a.counters().splits == b.counters().splits);
    CHECK(a.counters().merges == b.counters().merges);
    CHECK(a.counters().copies == b.counters().copies);
    CHECK(a.counters().ppe_iterations == b.counters().ppe_iterations);
    CHECK(a.ledger().steps() == b.ledger().steps());
    const auto& la = a.ledger().totals();
    const auto& lb = b.ledger().totals();
    CHECK(la.splits == lb.splits);
    CHECK(bits(Eigen::Vector3d(la.dL), Eigen::Vector3d(lb.dL)));
    CHECK(bits(Eigen::Vector3d(la.dVu), Eigen::Vector3d(lb.dVu)));
    // eq. 72 changes angular momentum: the component values were carried, not zeros
    CHECK(la.dL.norm() > 0.0);
  }
}  // TEST_SUITE

TEST_SUITE("bad_input") {
  // examples/multires_dam_break.cpp's command line (cases/multires_dam_break_options.hpp; the README's main
  // example): the examples are not built in CI, so its defaults and refusals are checked here.
  TEST_CASE("multires_dam_break's command line: defaults, readings and refusals") {
    const auto read = [](std::vector<const char*> args) {
      args.insert(args.begin(), "multires_dam_break");
      return cases::read_multires_dam_break_options(static_cast<int>(args.size()), args.data());
    };
    // The defaults: 5 mm refined 2:1 within 30 mm of the block, ramp to 60 mm, T = 3.8, with the library's
    // impact configuration (the active set's release and warm start as the preset has them).
    const scheme::lsmps_params<2> impact = scheme::lsmps_impact_params<2>();
    const cases::multires_dam_break_options d = read({});
    CHECK(d.L_mm == 5.0);
    CHECK(d.ratio == 2.0);
    CHECK(d.T_end == 3.8);
    CHECK(d.r0_mm == 30.0);
    CHECK(d.r1_mm == 60.0);
    CHECK(d.single);
    CHECK_NOTHROW(d.validate());
    const scheme::lsmps_params<2> p = d.params();
    CHECK(p.active_set_solves == impact.active_set_solves);
    CHECK(p.active_set_release == impact.active_set_release);
    CHECK(p.active_set_warm_start == impact.active_set_warm_start);
    CHECK(p.op.max_condition == impact.op.max_condition);
    CHECK(p.collision.alpha1 == impact.collision.alpha1);
    CHECK(p.collision.isolated == impact.collision.isolated);
    CHECK(p.shift_isolated_penalty == impact.shift_isolated_penalty);

    // Readings: --full is the paper's 5 mm at 5:1; the scheme's switches reach the parameters.
    const auto f =
        read({"--full", "--no-single", "--release", "--warm", "--no-shift-isolated", "--collision", "0.4",
              "--no-collide-isolated", "--r0", "20", "--r1", "50", "--contact-fallback", "--out", "o"});
    CHECK(f.L_mm == 5.0);
    CHECK(f.ratio == 5.0);
    CHECK_FALSE(f.single);
    CHECK(f.r0_mm == 20.0);
    CHECK(f.r1_mm == 50.0);
    CHECK(f.contact_fallback);
    CHECK_FALSE(d.contact_fallback);
    CHECK(f.out == "o");
    CHECK_NOTHROW(f.validate());
    const scheme::lsmps_params<2> q = f.params();
    CHECK(q.active_set_release);
    CHECK(q.active_set_warm_start);
    CHECK_FALSE(q.shift_isolated_penalty);
    CHECK(q.collision.alpha1 == 0.4);
    CHECK_FALSE(q.collision.isolated);

    // Reading refusals.
    CHECK_THROWS_WITH_AS(read({"--r0", "abc"}), doctest::Contains("multires_dam_break: --r0 'abc'"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--ratio"}), doctest::Contains("--ratio needs a value"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--single"}), doctest::Contains("unknown option '--single'"), mpskit::error);
    // Validation, before any output.
    const auto refused = [&](std::vector<const char*> args, const char* text) {
      const cases::multires_dam_break_options o = read(std::move(args));
      CHECK_THROWS_WITH_AS(o.validate(), doctest::Contains(text), mpskit::error);
    };
    refused({"--L", "-5"}, "--L -5 mm: must be > 0");
    refused({"--L", "150"}, "tanaka_dam_break_config.L");  // above the 100 mm column: the case refuses it
    refused({"--ratio", "0.5"}, "--ratio 0.5: must be >= 1");
    refused({"--T", "0"}, "--T 0: must be > 0");
    refused({"--r0", "60", "--r1", "30"}, "need 0 <= r0 < r1");
    refused({"--r0", "-1"}, "need 0 <= r0 < r1");
    refused({"--walls", "nope"}, "wall variant 'nope'");
    refused({"--collision", "1.6"}, "alpha1");
    refused({"--collision", "0", "--collide-isolated"}, "needs the collision stage on");
    // --release with wall options that have no active set (the scheme's own refusal, before any output).
    refused({"--walls", "parent_gradient", "--release"}, "active_set_release");
    refused({"--warm", "--no-single"}, "active_set_warm_start");
  }

  // examples/gears.cpp's command line (cases/gears_options.hpp): --full applied first, the knobs' readings
  // and every kind of refusal.
  TEST_CASE("gears' command line: defaults, --full in any position, readings and refusals") {
    const auto read = [](std::vector<const char*> args) {
      args.insert(args.begin(), "gears");
      return cases::read_gears_options(static_cast<int>(args.size()), args.data());
    };
    const cases::gears_config defaults;
    const cases::gears_options d = read({});
    CHECK(d.c.L_min == defaults.L_min);
    CHECK(d.c.t_end == defaults.t_end);
    CHECK(d.c.window == defaults.window);
    CHECK(d.out == "out/gears");
    CHECK_FALSE(d.geometry_only);
    CHECK_NOTHROW(d.validate());
    // --full is the paper's 0.4 s from L* = 0.1 mm; an option given with it overrides it on either side.
    const cases::gears_options f = read({"--t-end", "0.2", "--full"});
    CHECK(f.c.L_min == 0.1e-3);
    CHECK(f.c.r_fine == 4e-3);
    CHECK(f.c.window == 0.1);
    CHECK(f.vtk_every == 0.02);
    CHECK(f.c.t_end == 0.2);
    CHECK(read({"--full", "--t-end", "0.3"}).c.t_end == 0.3);
    CHECK(read({"--out", "--full"}).c.L_min == defaults.L_min);  // a directory called "--full"
    CHECK(read({"--out", "--full"}).out == "--full");
    // The knobs reach the case and the scheme; 0 switches --filter and --two-point off.
    const cases::gears_options k =
        read({"--filter", "0", "--two-point", "0", "--cprime", "0.01", "--alpha-o", "0.4", "--no-merge",
              "--shift-as-printed", "--ilut", "--geometry-only", "--lmax", "1.6e-3", "--wall-limit", "60"});
    CHECK(k.c.params.boundary_filter.strength == 0.0);
    CHECK(k.c.params.copy_two_point == 0.0);
    CHECK(k.c.params.volume.c_prime_min == doctest::Approx(0.99).epsilon(1e-15));
    CHECK(k.c.params.volume.c_prime_max == doctest::Approx(1.01).epsilon(1e-15));
    CHECK(k.c.boundary.alpha_o == 0.4);
    CHECK_FALSE(k.c.params.resolution.merge);
    CHECK(k.c.params.shift.projection == regularize::penalty_projection::with_displacement);
    CHECK(k.ilut);
    CHECK(k.geometry_only);
    CHECK(k.c.L_max == 1.6e-3);
    CHECK(k.c.wall_limit == 60.0);
    CHECK_NOTHROW(k.validate());
    // Reading refusals: not wholly a number, <= 0 (< 0 where 0 is off), a missing value, an unknown option.
    CHECK_THROWS_WITH_AS(read({"--t-end", "--full"}), doctest::Contains("gears: --t-end '--full'"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--lmin", "0"}), doctest::Contains("--lmin '0': must be > 0"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--filter", "-0.1"}), doctest::Contains("--filter '-0.1': must be >= 0"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--courant"}), doctest::Contains("--courant needs a value"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--t_end", "1"}), doctest::Contains("unknown option '--t_end'"),
                         mpskit::error);
    // Validation, before any output: a given window not inside the run; knobs out of the scheme's range.
    CHECK_THROWS_WITH_AS(read({"--t-end", "0.03", "--window", "0.05"}).validate(),
                         doctest::Contains("--window 0.05 must be shorter than --t-end 0.03"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--cprime", "1"}).validate(), doctest::Contains("c_prime_min"), mpskit::error);
    CHECK_THROWS_WITH_AS(read({"--alpha-o", "2"}).validate(), doctest::Contains("alpha_o"), mpskit::error);
    // A short --t-end without --window: the default window follows it (0.2 t_end).
    cases::gears_options s = read({"--t-end", "0.005"});
    CHECK_NOTHROW(s.validate());
    CHECK(s.fit_default_window());
    CHECK(s.c.window == doctest::Approx(1e-3).epsilon(1e-15));
    cases::gears_options dd = d;
    CHECK_FALSE(dd.fit_default_window());  // the default run keeps its window
    CHECK(dd.c.window == defaults.window);
  }
}
