// surface/ (free-surface detectors) and regularize/ (collision model, Fickian shifting): flat free
// surfaces of square/cubic lattices (exact and jittered), isolated particles, the NPCD "or" reading, the
// flat-surface asymmetry |F|⁰ against a hand computation, collision kinematics and momentum, shifting
// symmetry and restoring direction, masks, bad input, and bitwise equality for 1 and 2 threads.
// Random cases print their seed; set MPSKIT_SEED to reproduce or vary it.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/kernel/zhang_wan.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/regularize/collision.hpp"
#include "mpskit/regularize/concepts.hpp"
#include "mpskit/regularize/fickian_shifting.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/asymmetry.hpp"
#include "mpskit/surface/concepts.hpp"
#include "mpskit/surface/neighbour_count.hpp"
#include "mpskit/surface/npcd.hpp"
#include "mpskit/surface/pnd_threshold.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace mpskit;

namespace {

/// The least a type must offer to model surface::SurfaceDetector (STYLE.md archetypes).
struct detector_archetype {
  struct params_type {};
  const params_type& params() const { return p_; }
  template <Execution E, class Op, class P>
  void detect(E, const points<Op::dim>&, const search::neighbour_list<Op::dim>&, const Op&, const P&,
              std::span<const std::uint8_t>, std::vector<flag::type>&) const {}
  template <class Op, class P>
  double value(const points<Op::dim>&, const search::neighbour_list<Op::dim>&, const Op&, const P&,
               index_t) const {
    return 0.0;
  }
  template <class Op>
  double threshold(const Op&) const {
    return 0.0;
  }
  params_type p_;
};

/// The least a type must offer to model regularize::CollisionModel.
struct collision_archetype {
  struct params_type {};
  struct report {
    index_t pairs = 0;
    double max_dv = 0.0;
  };
  template <Execution E, int D, class P, class M>
  report apply(E, points<D>&, points<D>&, const search::neighbour_list<D>&, const P&, const M&,
               double) const {
    return {};
  }
};

/// The least a type must offer to model regularize::ShiftingModel.
struct shifting_archetype {
  struct params_type {};
  struct report {
    index_t shifted = 0;
    double max_shift_over_l0 = 0.0;
  };
  template <Execution E, class Op, class P, class M>
  report apply(E, points<Op::dim>&, const search::neighbour_list<Op::dim>&, const Op&, const P&, const M&,
               std::span<const flag::type>) const {
    return {};
  }
};

using op2 = op::mps<2>;
using op3 = op::mps<3>;
static_assert(surface::ClassicSupports<op2> && surface::ClassicSupports<op3> &&
              !surface::ClassicSupports<int>);
static_assert(surface::SurfaceDetector<surface::pnd_threshold, op2> &&
              surface::SurfaceDetector<surface::neighbour_count, op3> &&
              surface::SurfaceDetector<surface::npcd, op2> &&
              surface::SurfaceDetector<surface::asymmetry, op3> &&
              surface::SurfaceDetector<detector_archetype, op2> && !surface::SurfaceDetector<int, op2>);
static_assert(regularize::CollisionModel<regularize::collision, 2> &&
              regularize::CollisionModel<regularize::collision, 3> &&
              regularize::CollisionModel<collision_archetype, 2> && !regularize::CollisionModel<int, 2>);
static_assert(std::is_same_v<surface::npcd::fields, field_list<>> &&
              std::is_same_v<regularize::collision::fields, field_list<>>);  // core fields only
static_assert(regularize::ShiftingModel<regularize::fickian_shifting, op2> &&
              regularize::ShiftingModel<regularize::fickian_shifting, op3> &&
              regularize::ShiftingModel<shifting_archetype, op2> && !regularize::ShiftingModel<int, op2>);

constexpr double l0 = 0.01;

std::uint64_t test_seed() {
  const char* s = std::getenv("MPSKIT_SEED");
  return s ? std::strtoull(s, nullptr, 10) : 20261122ull;
}

/// A block of m^(D−1) × layers lattice particles (spacing l0), periodic on the first D−1 axes (period m l0)
/// and, when `periodic_vertical`, on the last; otherwise its top and bottom layers are flat free surfaces.
/// `depth[i]` = layers between i and the nearer free surface (0 = surface layer).
template <int D>
struct block {
  points<D> x;
  std::vector<int> depth;
  search::domain<D> dom;
  search::neighbour_list<D> nl;
  op::mps<D> op{op::mps_params{l0, 2.1, 3.1}};

  block(int m, int layers, double jitter, std::uint64_t seed, bool periodic_vertical = false) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-jitter, jitter);
    const int mz = D == 3 ? m : 1;
    x.resize(D, static_cast<index_t>(m) * mz * layers);
    index_t k = 0;
    for (int c = 0; c < layers; ++c)
      for (int b = 0; b < mz; ++b)
        for (int a = 0; a < m; ++a, ++k) {
          x(0, k) = a * l0 + U(rng) * l0;
          if constexpr (D == 3) x(1, k) = b * l0 + U(rng) * l0;
          x(D - 1, k) = c * l0 + U(rng) * l0;
          depth.push_back(std::min(c, layers - 1 - c));
        }
    for (int a = 0; a < D; ++a) {
      const bool per = a < D - 1 || periodic_vertical;
      dom.periodic[a] = per;
      dom.lo[a] = -0.5 * l0;
      dom.hi[a] = ((a < D - 1 ? m : layers) - 0.5) * l0;
    }
  }
  void build() { nl.build(exec::seq{}, x, search::uniform_radius{op.re_large()}, {0.0, dom}); }
  index_t n() const { return x.cols(); }
  index_t layer_size(int m) const { return D == 3 ? index_t(m) * m : m; }
};

template <class Det, int D>
std::vector<flag::type> detect_all(const Det& det, block<D>& b, Eigen::VectorXd* values = nullptr) {
  std::vector<flag::type> flags(static_cast<std::size_t>(b.n()), 0);
  std::vector<std::uint8_t> cand(static_cast<std::size_t>(b.n()), 1);
  det.detect(exec::seq{}, b.x, b.nl, b.op, surface::all_participate{}, cand, flags, values);
  return flags;
}

bool is_surface(flag::type f) { return (f & flag::surface) != 0; }

/// Counts flagged particles at depth 0, 1 and ≥ 2.
template <int D>
std::array<index_t, 3> flagged_by_depth(const block<D>& b, const std::vector<flag::type>& flags) {
  std::array<index_t, 3> c{};
  for (index_t i = 0; i < b.n(); ++i)
    if (is_surface(flags[static_cast<std::size_t>(i)]))
      ++c[static_cast<std::size_t>(std::min(b.depth[static_cast<std::size_t>(i)], 2))];
  return c;
}

template <int D>
void check_flat_surface(double jitter, std::uint64_t seed, bool with_pnd = true) {
  const int m = D == 2 ? 16 : 8, layers = 10;
  block<D> b(m, layers, jitter, seed);
  b.build();
  const index_t surface_layers = 2 * b.layer_size(m);  // top + bottom layer, by construction
  const surface::pnd_threshold pnd;
  const surface::neighbour_count cnt;
  const surface::npcd np;
  const surface::asymmetry asy;
  const std::array<std::array<index_t, 3>, 4> got = {
      flagged_by_depth(b, detect_all(pnd, b)), flagged_by_depth(b, detect_all(cnt, b)),
      flagged_by_depth(b, detect_all(np, b)), flagged_by_depth(b, detect_all(asy, b))};
  const std::string names[] = {"pnd_threshold", "neighbour_count", "npcd", "asymmetry"};
  for (std::size_t k = with_pnd ? 0 : 1; k < 4; ++k) {
    CAPTURE(names[k]);
    CAPTURE(jitter);
    MESSAGE(D << "D " << names[k] << " jitter " << jitter << ": flagged at depth 0/1/>=2 = " << got[k][0]
              << "/" << got[k][1] << "/" << got[k][2] << " of " << surface_layers
              << " surface-layer particles");
    CHECK(got[k][0] == surface_layers);         // every particle of both free layers
    CHECK(got[k][2] == 0);                      // nothing two or more layers deep
    if (jitter <= 0.01) CHECK(got[k][1] == 0);  // exactly the two free layers
  }
}

}  // namespace

TEST_SUITE("surface") {
  TEST_CASE("surface: every detector flags exactly the free layers of a flat lattice block") {
    // Perfect lattice: the top and bottom layers of a slab periodic sideways, 2·m^(D−1) particles. The
    // margins are wide (docs/surface.md): e.g. 2D at 2.1 l0, n/n0 = 0.68 on the top row, 0.9985 below.
    check_flat_surface<2>(0.0, 0);
    check_flat_surface<3>(0.0, 0);
  }

  TEST_CASE("surface: on a jittered block the free layers are flagged and nothing two layers deep") {
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    // Jitter ±0.01 l0 per coordinate: still exactly the two free layers for every detector (checked for
    // 200 seeds while writing this test; the closest margin is the PND test at α_d = 0.97, 3 % below n0).
    check_flat_surface<2>(0.01, seed);
    check_flat_surface<3>(0.01, seed + 1);
    // Jitter ±0.05 l0: neighbour count, NPCD and asymmetry keep the free layers and nothing deeper (200 of
    // 200 seeds); the PND test at α_d = 0.97 then flags interior particles in every run (n_i fluctuates by
    // more than 3 %), which is the known weakness of density tests (Tanaka 2018 §4.6), so it is left out.
    check_flat_surface<2>(0.05, seed + 2, false);
    check_flat_surface<3>(0.05, seed + 3, false);
  }

  TEST_CASE("surface: an isolated particle is flagged by every detector") {
    block<2> b(12, 6, 0.0, 0);
    b.x.conservativeResize(2, b.n() + 1);
    b.x.col(b.n() - 1) << 5.0 * l0, 20.0 * l0;  // far above the block (14 l0 above the top row)
    b.depth.push_back(0);
    b.build();
    const index_t iso = b.n() - 1;
    Eigen::VectorXd v;
    CHECK(is_surface(detect_all(surface::pnd_threshold{}, b, &v)[static_cast<std::size_t>(iso)]));
    CHECK(v[iso] == 0.0);
    CHECK(is_surface(detect_all(surface::neighbour_count{}, b, &v)[static_cast<std::size_t>(iso)]));
    CHECK(v[iso] == 0.0);
    CHECK(is_surface(detect_all(surface::npcd{}, b, &v)[static_cast<std::size_t>(iso)]));
    CHECK(v[iso] == 0.0);  // σ reported as 0 without neighbours; N = 0 ≤ 4 decides
    // Asymmetry with the PND clause switched off: eq. 15 alone gives |F| = 0; the no-neighbour rule flags it.
    CHECK(is_surface(detect_all(surface::asymmetry{{0.9, 0.0}}, b, &v)[static_cast<std::size_t>(iso)]));
    CHECK(v[iso] == 0.0);
  }

  TEST_CASE("surface: NPCD reads 'or' (flat surface: sigma > rho_f l0 with 17 neighbours)") {
    block<2> b(16, 8, 0.0, 0);
    b.build();
    const surface::npcd np;
    const std::vector<flag::type> flags = detect_all(np, b);
    index_t tested = 0;
    for (index_t i = 0; i < b.n(); ++i) {
      if (b.depth[static_cast<std::size_t>(i)] != 0) continue;
      const surface::npcd_measure m = np.measure(b.x, b.nl, b.op, surface::all_participate{}, i);
      // On the top row N_i (3.1 l0) = 28 − 11 = 17 > 4, so the printed "and" would call it inner.
      CHECK(m.count == 17);
      CHECK(m.sigma > np.threshold(b.op));
      CHECK(is_surface(flags[static_cast<std::size_t>(i)]));
      ++tested;
    }
    CHECK(tested == 32);
    // And the N ≤ 4 clause alone: a particle with 4 neighbours in a symmetric cross has σ = 0 but is flagged.
    points<2> y(2, 5);
    y << 0.0, l0, -l0, 0.0, 0.0,  //
        0.0, 0.0, 0.0, l0, -l0;   // i at the origin, four neighbours at distance l0
    search::neighbour_list<2> nl;
    const op2 op({l0, 2.1, 3.1});
    nl.build(exec::seq{}, y, search::uniform_radius{op.re_large()});
    const surface::npcd_measure m = np.measure(y, nl, op, surface::all_participate{}, 0);
    CHECK(m.count == 4);
    CHECK(m.sigma <= 1e-15 * l0);  // symmetric cross: the centroid is on i
    CHECK(np.is_surface(m, op));
  }

  TEST_CASE("surface: |F|0 of a flat lattice surface against a hand computation") {
    // Seed 004 eq. 14, particle at the origin, neighbours in the lower half-space, quadratic W = (1 − r/re)².
    const double re = 2.1;
    const auto W = [&](double r) { return (1.0 - r / re) * (1.0 - r / re); };
    const double s2 = std::sqrt(2.0), s3 = std::sqrt(3.0);
    // 2D: below: (0,−1) r=1, (±1,−1) r=√2, (0,−2) r=2 (vertical components 1, 1/√2, 1); n0 over 12 points.
    const double n0_2 = 4 * W(1) + 4 * W(s2) + 4 * W(2);
    const double F2 = 2.0 / n0_2 * (W(1) + 2 * W(s2) / s2 + W(2));
    CHECK(n0_2 == doctest::Approx(1.53316).epsilon(1e-5));  // bmmr.md §2.2 [DERIVED]
    CHECK(surface::flat_surface_asymmetry<kernel::quadratic, 2>(re) == doctest::Approx(F2).epsilon(1e-14));
    // 3D: below: (0,0,−1) r=1; 4 at √2; 4 at √3; (0,0,−2) r=2; n0: 6 at 1, 12 at √2, 8 at √3, 6 at 2.
    const double n0_3 = 6 * W(1) + 12 * W(s2) + 8 * W(s3) + 6 * W(2);
    const double F3 = 3.0 / n0_3 * (W(1) + 4 * W(s2) / s2 + 4 * W(s3) / s3 + W(2));
    CHECK(surface::flat_surface_asymmetry<kernel::quadratic, 3>(re) == doctest::Approx(F3).epsilon(1e-14));
    MESSAGE("|F|0 quadratic 2.1 l0: 2D " << F2 << ", 3D " << F3);
    // The detector's |F_i| on the top row of a perfect periodic slab is |F|0 (same sums, other order).
    block<2> b(16, 8, 0.0, 0);
    b.build();
    const surface::asymmetry asy;
    for (index_t i = 0; i < b.n(); ++i)
      if (b.depth[static_cast<std::size_t>(i)] == 0)
        CHECK(asy.value(b.x, b.nl, b.op, surface::all_participate{}, i) ==
              doctest::Approx(F2).epsilon(1e-12));
    // The reference follows the operator's kernel: Zhang–Wan W = re/(0.85 r + 0.15 re) − 1 (seed 004 eq. 3).
    const auto Wz = [&](double r) { return re / (0.85 * r + 0.15 * re) - 1.0; };
    const double n0_z = 4 * Wz(1) + 4 * Wz(s2) + 4 * Wz(2);
    const double Fz = 2.0 / n0_z * (Wz(1) + 2 * Wz(s2) / s2 + Wz(2));
    CHECK(surface::flat_surface_asymmetry<kernel::zhang_wan, 2>(re) == doctest::Approx(Fz).epsilon(1e-14));
  }

  TEST_CASE("surface: only candidates change, and only their surface bit") {
    block<2> b(12, 8, 0.01, test_seed() + 3);
    b.build();
    const std::size_t n = static_cast<std::size_t>(b.n());
    std::vector<flag::type> before(n), flags;
    std::vector<std::uint8_t> cand(n);
    for (std::size_t i = 0; i < n; ++i) {
      before[i] = (i % 3 == 0 ? flag::surface : 0u) | (i % 5 == 0 ? flag::guarded : 0u) | flag::degenerate;
      cand[i] = i % 2;
    }
    flags = before;
    surface::npcd{}.detect(exec::seq{}, b.x, b.nl, b.op, surface::all_participate{}, cand, flags);
    const std::vector<flag::type> all = detect_all(surface::npcd{}, b);
    bool ok = true;
    for (std::size_t i = 0; i < n; ++i) {
      if (!cand[i])
        ok &= flags[i] == before[i];
      else
        ok &= (flags[i] & ~flag::surface) == (before[i] & ~flag::surface) &&
              is_surface(flags[i]) == is_surface(all[i]);
    }
    CHECK(ok);
  }

  TEST_CASE("surface: participates excludes neighbours (a block seen without its upper half)") {
    block<2> b(12, 10, 0.0, 0);
    b.build();
    // Only the lower 5 layers participate: the 5th layer (index 4) becomes a flat surface for the lower part.
    std::vector<int> layer(static_cast<std::size_t>(b.n()));
    for (index_t i = 0; i < b.n(); ++i)
      layer[static_cast<std::size_t>(i)] = static_cast<int>(std::lround(b.x(1, i) / l0));
    const auto lower = [&](index_t j) { return layer[static_cast<std::size_t>(j)] < 5; };
    std::vector<flag::type> flags(static_cast<std::size_t>(b.n()), 0);
    std::vector<std::uint8_t> cand(static_cast<std::size_t>(b.n()));
    for (index_t i = 0; i < b.n(); ++i) cand[static_cast<std::size_t>(i)] = lower(i);
    surface::pnd_threshold{}.detect(exec::seq{}, b.x, b.nl, b.op, lower, cand, flags);
    index_t flagged = 0, wrong = 0;
    for (index_t i = 0; i < b.n(); ++i) {
      const bool f = is_surface(flags[static_cast<std::size_t>(i)]);
      const int L = layer[static_cast<std::size_t>(i)];
      flagged += f;
      wrong += f != (L == 0 || L == 4);
    }
    CHECK(flagged == 24);  // layers 0 and 4, 12 each
    CHECK(wrong == 0);
  }

  TEST_CASE("surface: detection runs on wall particles (dry wall flagged, wet wall not)") {
    // A periodic strip: layers 0–1 dummy, layer 2 wall, layers 3–7 fluid over columns 0–7 only.
    // Candidates are fluid and wall particles (bmmr.md §2.7 [EXT]: dry walls get P = 0).
    const int m = 16;
    block<2> full(m, 8, 0.0, 0);
    std::vector<index_t> keep;
    for (index_t i = 0; i < full.n(); ++i) {
      const int col = static_cast<int>(std::lround(full.x(0, i) / l0)),
                lay = static_cast<int>(std::lround(full.x(1, i) / l0));
      if (lay <= 2 || col < 8) keep.push_back(i);
    }
    block<2> b = full;
    b.x.resize(2, static_cast<index_t>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k) b.x.col(static_cast<index_t>(k)) = full.x.col(keep[k]);
    b.build();
    std::vector<std::uint8_t> cand(keep.size());
    for (index_t i = 0; i < b.n(); ++i) cand[static_cast<std::size_t>(i)] = std::lround(b.x(1, i) / l0) >= 2;
    for (const bool use_npcd : {true, false}) {
      CAPTURE(use_npcd);
      std::vector<flag::type> flags(keep.size(), 0);
      if (use_npcd)
        surface::npcd{}.detect(exec::seq{}, b.x, b.nl, b.op, surface::all_participate{}, cand, flags);
      else
        surface::pnd_threshold{}.detect(exec::seq{}, b.x, b.nl, b.op, surface::all_participate{}, cand,
                                        flags);
      index_t dry = 0, wet = 0, dummies = 0;
      for (index_t i = 0; i < b.n(); ++i) {
        const long col = std::lround(b.x(0, i) / l0), lay = std::lround(b.x(1, i) / l0);
        const bool f = is_surface(flags[static_cast<std::size_t>(i)]);
        if (lay < 2) dummies += f;
        if (lay == 2 && col >= 10 && col <= 13) dry += f;  // ≥ 3 l0 from any fluid particle
        if (lay == 2 && col >= 2 && col <= 5) wet += f;    // under the fluid, full support
      }
      CHECK(dry == 4);
      CHECK(wet == 0);
      CHECK(dummies == 0);  // not candidates
    }
  }

  TEST_CASE("surface: bad parameters and sizes are refused") {
    CHECK_THROWS_AS(surface::pnd_threshold({1.5}), mpskit::error);
    CHECK_THROWS_AS(surface::neighbour_count({0.0}), mpskit::error);
    CHECK_THROWS_AS(surface::npcd({0.93, -1.0}), mpskit::error);
    CHECK_THROWS_AS(surface::asymmetry({0.9, 2.0}), mpskit::error);
    CHECK_THROWS_AS((surface::flat_surface_asymmetry<kernel::quadratic, 2>(0.0)), mpskit::error);
    try {
      surface::npcd({2.0, 0.25, -1});
      FAIL("no throw");
    } catch (const mpskit::error& e) {
      const std::string msg = e.what();
      CHECK(msg.find("beta_f") != std::string::npos);
      CHECK(msg.find("max_neighbours") != std::string::npos);
    }
    block<2> b(8, 4, 0.0, 0);
    b.build();
    std::vector<flag::type> flags(3);
    std::vector<std::uint8_t> cand(static_cast<std::size_t>(b.n()), 1);
    CHECK_THROWS_AS(
        surface::npcd{}.detect(exec::seq{}, b.x, b.nl, b.op, surface::all_participate{}, cand, flags),
        mpskit::error);
  }

  TEST_CASE("surface: detectors, collision and shifting are bitwise identical for 1 and 2 threads") {
#ifdef _OPENMP
    const std::uint64_t seed = test_seed() + 4;
    MESSAGE("seed = " << seed);
    block<3> b(8, 8, 0.1, seed);
    b.build();
    const auto run_detectors = [&](std::vector<std::vector<flag::type>>& F, std::vector<Eigen::VectorXd>& V) {
      F.assign(4, std::vector<flag::type>(static_cast<std::size_t>(b.n()), 0));
      V.assign(4, Eigen::VectorXd());
      std::vector<std::uint8_t> cand(static_cast<std::size_t>(b.n()), 1);
      surface::pnd_threshold{}.detect(exec::par{}, b.x, b.nl, b.op, surface::all_participate{}, cand, F[0],
                                      &V[0]);
      surface::neighbour_count{}.detect(exec::par{}, b.x, b.nl, b.op, surface::all_participate{}, cand, F[1],
                                        &V[1]);
      surface::npcd{}.detect(exec::par{}, b.x, b.nl, b.op, surface::all_participate{}, cand, F[2], &V[2]);
      surface::asymmetry{}.detect(exec::par{}, b.x, b.nl, b.op, surface::all_participate{}, cand, F[3],
                                  &V[3]);
    };
    std::mt19937_64 rng(seed + 1);
    std::normal_distribution<double> N(0.0, 1.0);
    points<3> u(3, b.n());
    for (index_t i = 0; i < b.n(); ++i) u.col(i) << N(rng), N(rng), N(rng);
    const auto fluid = [](index_t i) { return i % 7 != 0; };
    const regularize::collision col({l0, 0.85, 0.2});
    const regularize::fickian_shifting sh;
    std::vector<std::vector<flag::type>> F1, F2;
    std::vector<Eigen::VectorXd> V1, V2;
    points<3> du1, du2, dr1, dr2;
    omp_set_num_threads(1);
    run_detectors(F1, V1);
    const regularize::collision_report c1 =
        col.velocity_change(exec::par{}, b.x, u, b.nl, regularize::every_particle{}, fluid, du1);
    const regularize::shift_report s1 =
        sh.displacement(exec::par{}, b.x, b.nl, b.op, regularize::every_particle{}, fluid, F1[2], dr1);
    omp_set_num_threads(2);
    REQUIRE(max_threads() == 2);
    run_detectors(F2, V2);
    const regularize::collision_report c2 =
        col.velocity_change(exec::par{}, b.x, u, b.nl, regularize::every_particle{}, fluid, du2);
    const regularize::shift_report s2 =
        sh.displacement(exec::par{}, b.x, b.nl, b.op, regularize::every_particle{}, fluid, F2[2], dr2);
    for (std::size_t k = 0; k < 4; ++k) {
      CHECK(F1[k] == F2[k]);
      CHECK((V1[k].array() == V2[k].array() || (V1[k].array().isNaN() && V2[k].array().isNaN())).all());
    }
    // jitter ±0.1 l0 with unit random velocities: some pairs closer than 0.85 l0 approach
    CHECK(c1.pairs > 0);
    CHECK((du1.array() == du2.array()).all());
    CHECK(c1.pairs == c2.pairs);
    CHECK(c1.max_dv == c2.max_dv);
    CHECK((dr1.array() == dr2.array()).all());
    CHECK(s1.max_shift_over_l0 == s2.max_shift_over_l0);
    CHECK(s1.shifted == s2.shifted);
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
}

TEST_SUITE("regularize") {
  TEST_CASE("regularize: a head-on pair gets the paper's velocity change and keeps its momentum") {
    // Seed 001 eq. 13, α1 = 0.85, α2 = 0.2, α3 = 2: x_ij = (0.5 l0, 0), u_i = (v, 0), u_j = (−v, 0):
    // (r·u)/|r| = −2v, Δu_i = 1.2/2 · (−2v) e_x = −1.2 v e_x, Δu_j = +1.2 v e_x.
    const double v = 0.3;
    points<2> x(2, 2), u(2, 2);
    x << 0.0, 0.5 * l0, 0.0, 0.0;
    u << v, -v, 0.0, 0.0;
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    const regularize::collision col({l0, 0.85, 0.2});
    const double dt = 1e-3;
    const points<2> x0 = x;
    const regularize::collision_report rep =
        col.apply(exec::seq{}, x, u, nl, regularize::every_particle{}, regularize::every_particle{}, dt);
    CHECK(rep.pairs == 2);
    CHECK(u(0, 0) == doctest::Approx(v - 1.2 * v).epsilon(1e-15));
    CHECK(u(0, 1) == doctest::Approx(-v + 1.2 * v).epsilon(1e-15));
    CHECK(u(1, 0) == 0.0);
    CHECK(rep.max_dv == doctest::Approx(1.2 * v).epsilon(1e-15));
    CHECK(x(0, 0) == doctest::Approx(x0(0, 0) - 1.2 * v * dt).epsilon(1e-15));  // eq. 24: r** = r* + Δu Δt
  }

  TEST_CASE("regularize: oblique collision: restitution of the normal velocity, tangential kept, momentum") {
    const std::uint64_t seed = test_seed() + 10;
    MESSAGE("seed = " << seed);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    const regularize::collision col({l0, 0.85, 0.2});
    int tested = 0;
    for (int trial = 0; trial < 200; ++trial) {
      points<3> x(3, 2), u(3, 2);
      x.col(0).setZero();
      x.col(1) << U(rng), U(rng), U(rng);
      x.col(1) *= 0.45 * l0;  // |r| < 0.78 l0 < α1 l0
      u.col(0) << U(rng), U(rng), U(rng);
      u.col(1) << U(rng), U(rng), U(rng);
      search::neighbour_list<3> nl;
      nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
      const vec<3> n = x.col(1).normalized();
      const vec<3> rel0 = u.col(1) - u.col(0), P0 = u.col(0) + u.col(1);
      const points<3> u0 = u;
      const double vn0 = rel0.dot(n);
      col.apply(exec::seq{}, x, u, nl, regularize::every_particle{}, regularize::every_particle{}, 0.0);
      if (!(vn0 < 0.0)) {  // receding: untouched, bitwise
        CHECK((u.array() == u0.array()).all());
        continue;
      }
      ++tested;
      const vec<3> rel = u.col(1) - u.col(0), P = u.col(0) + u.col(1);
      // Pair momentum (equal masses): bitwise-antisymmetric pair terms, so only the final sums round.
      CHECK((P - P0).norm() <= 1e-15 * (u0.col(0).norm() + u0.col(1).norm()));
      CHECK(rel.dot(n) == doctest::Approx(-0.2 * vn0).epsilon(1e-12));  // restitution α2 (Lee et al. 2011)
      CHECK((rel - rel.dot(n) * n - (rel0 - vn0 * n)).norm() <= 1e-14 * rel0.norm());  // tangential unchanged
    }
    CHECK(tested > 50);
  }

  TEST_CASE("regularize: receding, distant and non-participating pairs are untouched; walls do not move") {
    const regularize::collision col({l0, 0.85, 0.2});
    points<2> x(2, 2), u(2, 2);
    search::neighbour_list<2> nl;
    // Receding at 0.5 l0.
    x << 0.0, 0.5 * l0, 0.0, 0.0;
    u << -1.0, 1.0, 0.0, 0.0;
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    points<2> u0 = u;
    CHECK(col.apply(exec::seq{}, x, u, nl, regularize::every_particle{}, regularize::every_particle{}, 1e-3)
              .pairs == 0);
    CHECK((u.array() == u0.array()).all());
    // Approaching but at 0.9 l0 > α1 l0.
    x << 0.0, 0.9 * l0, 0.0, 0.0;
    u << 1.0, -1.0, 0.0, 0.0;
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    u0 = u;
    CHECK(col.apply(exec::seq{}, x, u, nl, regularize::every_particle{}, regularize::every_particle{}, 1e-3)
              .pairs == 0);
    CHECK((u.array() == u0.array()).all());
    // Approaching at 0.5 l0 but neither counts as a partner.
    x << 0.0, 0.5 * l0, 0.0, 0.0;
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    CHECK(col.apply(
                 exec::seq{}, x, u, nl, [](index_t) { return false; }, regularize::every_particle{}, 1e-3)
              .pairs == 0);
    CHECK((u.array() == u0.array()).all());
    // A wall neighbour (immovable, α3 = 1): the fluid particle bounces with restitution α2 against the
    // wall's velocity, the wall keeps its velocity and position.
    x << 0.0, 0.5 * l0, 0.0, 0.3 * l0;
    u << 1.0, 0.2, 0.5, -0.1;  // particle 1 is a moving wall
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    u0 = u;
    const points<2> x0 = x;
    const auto fluid = [](index_t i) { return i == 0; };
    const vec<2> n = (x.col(1) - x.col(0)).normalized();
    const double vn0 = (u0.col(1) - u0.col(0)).dot(n);
    REQUIRE(vn0 < 0.0);
    const regularize::collision_report rep =
        col.apply(exec::seq{}, x, u, nl, regularize::every_particle{}, fluid, 1e-3);
    CHECK(rep.pairs == 1);
    CHECK((u.col(1).array() == u0.col(1).array()).all());
    CHECK((x.col(1).array() == x0.col(1).array()).all());
    CHECK((u.col(1) - u.col(0)).dot(n) == doctest::Approx(-0.2 * vn0).epsilon(1e-13));
  }

  TEST_CASE("regularize: collisions in a compressed cloud conserve the total momentum") {
    const std::uint64_t seed = test_seed() + 11;
    MESSAGE("seed = " << seed);
    block<2> b(16, 16, 0.25, seed, true);
    b.x *= 0.8;  // spacing 0.8 l0: many pairs inside α1 l0 = 0.85 l0
    b.dom.lo *= 0.8;
    b.dom.hi *= 0.8;
    b.build();
    std::mt19937_64 rng(seed + 1);
    std::normal_distribution<double> N(0.0, 1.0);
    points<2> u(2, b.n());
    for (index_t i = 0; i < b.n(); ++i) u.col(i) << N(rng), N(rng);
    const points<2> u0 = u;
    const regularize::collision col({l0, 0.85, 0.2});
    const regularize::collision_report rep =
        col.apply(exec::seq{}, b.x, u, b.nl, regularize::every_particle{}, regularize::every_particle{}, 0.0);
    MESSAGE("colliding directed pairs: " << rep.pairs << ", particles changed: " << rep.particles);
    CHECK(rep.pairs > 100);
    CHECK(rep.pairs % 2 == 0);  // symmetric test: both members of a pair see it
    const vec<2> dP = (u - u0).rowwise().sum();
    const double scale = (u - u0).colwise().norm().sum();
    // Every pair term is bitwise antisymmetric; only the summation order differs per particle, so the
    // residual is a few ulps of the summed magnitudes (n·ε·Σ|Δu| bound, far below it in practice).
    CHECK(dP.norm() <= 1e-14 * scale);
  }

  TEST_CASE(
      "regularize: sized collisions: contact at alpha1 L_ij, restitution, momentum sum V u for unequal "
      "volumes") {
    const std::uint64_t seed = test_seed() + 12;
    MESSAGE("seed = " << seed);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-1.0, 1.0), S(0.2, 1.0);
    const regularize::sized_collision_params p{0.5, 0.2};
    int tested = 0;
    for (int trial = 0; trial < 200; ++trial) {
      const double L0 = S(rng) * l0, L1 = S(rng) * l0;  // size ratios up to 5
      const Eigen::VectorXd L = (Eigen::VectorXd(2) << L0, L1).finished();
      const Eigen::VectorXd V = L.array().square();  // 2D: V = L²
      points<2> x(2, 2), u(2, 2), du;
      x.col(0).setZero();
      x.col(1) << U(rng), U(rng);
      // |r| ≤ 0.24 (L0 + L1) < α1 L_01
      x.col(1) *= 0.24 * (L0 + L1) / x.col(1).norm() * (0.5 + 0.5 * std::abs(U(rng)));
      u.col(0) << U(rng), U(rng);
      u.col(1) << U(rng), U(rng);
      search::neighbour_list<2> nl;
      nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
      const vec<2> n = x.col(1).normalized();
      const double vn0 = (u.col(1) - u.col(0)).dot(n);
      regularize::sized_collisions(exec::seq{}, x, u, L, V, nl, regularize::every_particle{},
                                   regularize::every_particle{}, p, du);
      if (!(vn0 < 0.0)) {  // receding: no change
        CHECK(du.isZero(0.0));
        continue;
      }
      ++tested;
      const points<2> u1 = u + du;
      const vec<2> rel0 = u.col(1) - u.col(0), rel = u1.col(1) - u1.col(0);
      const vec<2> P0 = V[0] * u.col(0) + V[1] * u.col(1), P = V[0] * u1.col(0) + V[1] * u1.col(1);
      // Σ V u of the pair: share V_j/(V_i + V_j) makes V_i Δu_i = −V_j Δu_j up to rounding of the two shares.
      CHECK((P - P0).norm() <= 1e-14 * (V[0] * u.col(0).norm() + V[1] * u.col(1).norm()));
      CHECK(rel.dot(n) == doctest::Approx(-0.2 * vn0).epsilon(1e-12));  // restitution α2, as for equal masses
      CHECK((rel - rel.dot(n) * n - (rel0 - vn0 * n)).norm() <= 1e-14 * rel0.norm());  // tangential unchanged
      // The lighter particle takes the larger change: |Δu_i| V_i = |Δu_j| V_j.
      CHECK(du.col(0).norm() * V[0] == doctest::Approx(du.col(1).norm() * V[1]).epsilon(1e-12));
    }
    CHECK(tested > 50);
    // The contact distance is α1 (L_i + L_j)/2: an approaching pair just inside collides, just outside does
    // not.
    const Eigen::VectorXd L = (Eigen::VectorXd(2) << l0, 0.2 * l0).finished(), V = L.array().square();
    const double contact = 0.5 * 0.5 * 1.2 * l0;
    for (const double f : {0.999, 1.001}) {
      points<2> x(2, 2), u(2, 2), du;
      x << 0.0, f * contact, 0.0, 0.0;
      u << 1.0, -1.0, 0.0, 0.0;
      search::neighbour_list<2> nl;
      nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
      const regularize::collision_report rep = regularize::sized_collisions(
          exec::seq{}, x, u, L, V, nl, regularize::every_particle{}, regularize::every_particle{}, p, du);
      CHECK(rep.pairs == (f < 1.0 ? 2 : 0));
    }
    // Against an immovable partner (a wall copy): the movable particle bounces with restitution, the partner
    // keeps its velocity, whatever the volumes.
    points<2> x(2, 2), u(2, 2), du;
    x << 0.0, 0.2 * l0, 0.0, 0.1 * l0;
    u << 1.0, 0.3, 0.5, 0.0;
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    const vec<2> n = (x.col(1) - x.col(0)).normalized();
    const double vn0 = (u.col(1) - u.col(0)).dot(n);
    REQUIRE(vn0 < 0.0);
    regularize::sized_collisions(exec::seq{}, x, u, L, V, nl, regularize::every_particle{},
                                 [](index_t i) { return i == 0; }, p, du);
    CHECK(du.col(1).isZero(0.0));
    CHECK((u.col(1) - u.col(0) - du.col(0)).dot(n) == doctest::Approx(-0.2 * vn0).epsilon(1e-13));
    // Bad numbers and sizes that do not match x are refused.
    CHECK_THROWS_AS(regularize::sized_collision_params({-0.1, 0.2}).validate(), mpskit::error);
    CHECK_THROWS_AS(regularize::sized_collision_params({0.5, 1.5}).validate(), mpskit::error);
    CHECK_THROWS_WITH_AS(
        regularize::sized_collisions(exec::seq{}, x, u, L, Eigen::VectorXd(V.head(1)), nl,
                                     regularize::every_particle{}, regularize::every_particle{}, p, du),
        doctest::Contains("V 1 values"), mpskit::error);
    CHECK_THROWS_AS(regularize::sized_collisions(exec::seq{}, x, u, L, V, nl, regularize::every_particle{},
                                                 regularize::every_particle{},
                                                 regularize::sized_collision_params{2.0, 0.2}, du),
                    mpskit::error);
  }

  TEST_CASE("regularize: shifting is zero on a perfect periodic lattice (symmetry)") {
    block<2> b2(12, 12, 0.0, 0, true);
    b2.build();
    block<3> b3(8, 8, 0.0, 0, true);
    b3.build();
    const regularize::fickian_shifting sh;
    std::vector<flag::type> f2(static_cast<std::size_t>(b2.n()), 0), f3(static_cast<std::size_t>(b3.n()), 0);
    points<2> dr2;
    points<3> dr3;
    const regularize::shift_report r2 = sh.displacement(
        exec::seq{}, b2.x, b2.nl, b2.op, regularize::every_particle{}, regularize::every_particle{}, f2, dr2);
    const regularize::shift_report r3 = sh.displacement(
        exec::seq{}, b3.x, b3.nl, b3.op, regularize::every_particle{}, regularize::every_particle{}, f3, dr3);
    CHECK(r2.shifted == b2.n());
    CHECK(r3.shifted == b3.n());
    // Opposite lattice neighbours cancel; positions a·l0 are not exact binary numbers, hence 1e-12 l0.
    CHECK(r2.max_shift_over_l0 <= 1e-12);
    CHECK(r3.max_shift_over_l0 <= 1e-12);
    MESSAGE("max shift / l0 on perfect lattices: 2D " << r2.max_shift_over_l0 << ", 3D "
                                                      << r3.max_shift_over_l0);
  }

  TEST_CASE("regularize: a particle displaced from its lattice site is shifted back towards it") {
    block<2> b(12, 12, 0.0, 0, true);
    const index_t k = 6 * 12 + 6;
    const vec<2> site = b.x.col(k);
    b.x(0, k) += 0.1 * l0;
    b.build();
    const regularize::fickian_shifting sh;
    std::vector<flag::type> flags(static_cast<std::size_t>(b.n()), 0);
    points<2> dr;
    sh.displacement(exec::seq{}, b.x, b.nl, b.op, regularize::every_particle{}, regularize::every_particle{},
                    flags, dr);
    CAPTURE(dr.col(k).transpose());
    CHECK(dr(0, k) < 0.0);                               // back towards the site (−x)
    CHECK(std::abs(dr(1, k)) <= 1e-12 * l0);             // mirror symmetry about the x axis through the site
    CHECK(dr.col(k).norm() <= 0.05 * l0 * (1 + 1e-15));  // eq. 10 cap
    CHECK((b.x.col(k) + dr.col(k) - site).norm() < 0.1 * l0);
    // 3D, displaced along a diagonal: Δr is anti-parallel to the displacement (cubic symmetry).
    block<3> c(8, 8, 0.0, 0, true);
    const index_t q = 4 * 64 + 4 * 8 + 4;
    const vec<3> delta = vec<3>(1.0, 1.0, 1.0).normalized() * (0.08 * l0);
    c.x.col(q) += delta;
    c.build();
    std::vector<flag::type> f3(static_cast<std::size_t>(c.n()), 0);
    points<3> d3;
    sh.displacement(exec::seq{}, c.x, c.nl, c.op, regularize::every_particle{}, regularize::every_particle{},
                    f3, d3);
    CHECK(d3.col(q).dot(delta) < 0.0);
    CHECK(d3.col(q).normalized().dot(delta.normalized()) == doctest::Approx(-1.0).epsilon(1e-12));
  }

  TEST_CASE("regularize: shifting never moves walls, surface or isolated particles, and caps at 0.05 l0") {
    const std::uint64_t seed = test_seed() + 12;
    MESSAGE("seed = " << seed);
    block<2> b(12, 10, 0.15, seed);
    b.build();
    std::vector<flag::type> flags = detect_all(surface::npcd{}, b);
    const auto fluid = [](index_t i) { return i % 4 != 0; };  // every 4th particle is a wall
    for (std::size_t i = 5; i < flags.size(); i += 31) flags[i] |= flag::isolated;
    const points<2> x0 = b.x;
    // A huge A_F makes every shift hit the cap.
    const regularize::fickian_shifting sh({1e4, 0.2, 0.1, 0.05});
    const regularize::shift_report rep =
        sh.apply(exec::seq{}, b.x, b.nl, b.op, regularize::every_particle{}, fluid, flags);
    index_t moved_fixed = 0, moved = 0, eligible = 0;
    for (index_t i = 0; i < b.n(); ++i) {
      const bool fixed = !fluid(i) || (flags[static_cast<std::size_t>(i)] & (flag::surface | flag::isolated));
      const bool changed = (b.x.col(i).array() != x0.col(i).array()).any();
      moved_fixed += fixed && changed;
      moved += changed;
      eligible += !fixed;
      CHECK((b.x.col(i) - x0.col(i)).norm() <= 0.05 * l0 * (1 + 1e-12));
    }
    CHECK(moved_fixed == 0);
    CHECK(rep.shifted == eligible);
    CHECK(moved > 0);
    CHECK(rep.capped > 0);
    CHECK(rep.max_shift_over_l0 == doctest::Approx(0.05).epsilon(1e-14));
  }

  TEST_CASE("regularize: bad parameters are refused") {
    CHECK_THROWS_AS(regularize::collision({0.0, 0.85, 0.2}), mpskit::error);
    CHECK_THROWS_AS(regularize::collision({l0, 0.85, 1.5}), mpskit::error);
    CHECK_THROWS_AS(regularize::fickian_shifting({-1.0}), mpskit::error);
    const regularize::collision col({l0, 0.85, 0.2});
    points<2> x(2, 2), u(2, 3);
    x << 0.0, 0.5 * l0, 0.0, 0.0;
    u.setZero();
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * l0});
    CHECK_THROWS_AS(
        col.apply(exec::seq{}, x, u, nl, regularize::every_particle{}, regularize::every_particle{}, 0.0),
        mpskit::error);
    points<2> u2 = points<2>::Zero(2, 2);
    CHECK_THROWS_AS(
        col.apply(exec::seq{}, x, u2, nl, regularize::every_particle{}, regularize::every_particle{}, -1.0),
        mpskit::error);
  }
}
