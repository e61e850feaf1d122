// regularize/tanaka_shift.hpp (Tanaka 2018 §4.7, eqs. 93–100) and the LSMPS wall cases of issue #7
// (examples/cases/polygon_tank.hpp, examples/cases/tanaka_dam_break.hpp).
// Random inputs use a seed printed with each case; set MPSKIT_SEED to reproduce or vary it.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "cases/polygon_tank.hpp"
#include "cases/tanaka_dam_break.hpp"
#include "mpskit/regularize/tanaka_shift.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/wall/imaginary.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace mpskit;

namespace {

std::uint64_t test_seed() {
  const char* s = std::getenv("MPSKIT_SEED");
  return s ? std::strtoull(s, nullptr, 10) : 20261122ull;
}

constexpr double L0 = 0.01;  // particle diameter of the shift tests (m)

/// m^D lattice of spacing L0 at (k + ½) L0, each coordinate jittered uniformly by ±jitter·L0.
template <int D>
points<D> lattice(int m, int m_last, double jitter, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-jitter, jitter);
  index_t n = m_last;
  for (int a = 0; a + 1 < D; ++a) n *= m;
  points<D> x(D, n);
  for (index_t k = 0; k < n; ++k) {
    index_t r = k;
    for (int a = 0; a < D; ++a) {
      const int ma = a + 1 < D ? m : m_last;
      x(a, k) = (static_cast<double>(r % ma) + 0.5 + (jitter > 0.0 ? U(rng) : 0.0)) * L0;
      r /= ma;
    }
  }
  return x;
}

/// Periodic box [0, m L0) on the axes flagged.
template <int D>
search::domain<D> periodic_box(int m, int m_last, std::array<bool, D> axes) {
  search::domain<D> d;
  d.periodic = axes;
  for (int a = 0; a < D; ++a) d.hi[a] = (a + 1 < D ? m : m_last) * L0;
  return d;
}

template <int D>
search::neighbour_list<D> build_list(const points<D>& x, const Eigen::VectorXd& L,
                                     const search::domain<D>& dom = {}) {
  search::neighbour_list<D> nl;
  nl.build(exec::seq{}, x, search::per_particle_radius{&L, 3.1}, search::build_options<D>{0.0, dom});
  return nl;
}

struct all_participate {
  bool operator()(index_t) const { return true; }
};

/// Everything the shift needs, for particles 0..n−1 all active, no normals, zero ∇c.
template <int D>
struct shift_case {
  points<D> x;
  Eigen::VectorXd L;
  search::domain<D> dom{};
  search::neighbour_list<D> nl;
  points<D> grad_c, n, dx;
  std::vector<std::uint8_t> tangential, active;
  explicit shift_case(points<D> xx, const search::domain<D>& d = {}) : x(std::move(xx)), dom(d) {
    L = Eigen::VectorXd::Constant(x.cols(), L0);
    grad_c.setZero(D, x.cols());
    n.setZero(D, x.cols());
    tangential.assign(static_cast<std::size_t>(x.cols()), 0);
    active.assign(static_cast<std::size_t>(x.cols()), 1);
  }
  void build() { nl = build_list<D>(x, L, dom); }
  template <class E = exec::seq, class P = all_participate>
  regularize::tanaka_shift_report run(const regularize::tanaka_shift_params& p = {}, E e = {},
                                      const P& part = {}, const points<D>* n_wall = nullptr,
                                      const points<D>* n_wall2 = nullptr,
                                      const std::vector<std::uint8_t>* penalty_only = nullptr) {
    return regularize::tanaka_shift_displacement<D>(e, x, L, nl, part, grad_c, n, tangential, active, p, dx,
                                                    n_wall, n_wall2, penalty_only);
  }
};

/// Eqs. (93)–(100) written literally, O(n²), for a non-periodic cloud (the reference of the library's
/// rearranged sums): g_i = Σ w (x_j + r* x_ji/|x_ji|)/Σ w, δx** = −Σ w ε L_ij ∇c/|∇c| (L_ij: mpskit's
/// dimensional reading of eq. 96), then eq. 99 and eq. 100.
template <int D, class P>
points<D> literal_shift(const shift_case<D>& c, const P& part, const regularize::tanaka_shift_params& p) {
  const index_t m = static_cast<index_t>(c.active.size());
  points<D> out = points<D>::Zero(D, m);
  for (index_t i = 0; i < m; ++i) {
    if (!c.active[static_cast<std::size_t>(i)]) continue;
    vec<D> num = vec<D>::Zero();
    double den = 0.0, pen = 0.0;
    for (index_t j = 0; j < c.x.cols(); ++j) {
      if (j == i || !part(j)) continue;
      const vec<D> xji = c.x.col(i) - c.x.col(j);
      const double r = xji.norm();
      const double Lij = 0.5 * (c.L[i] + c.L[j]), Rij = 0.5 * (p.re_ratio * c.L[i] + p.re_ratio * c.L[j]);
      if (!(r < Rij)) continue;
      const double w = (r / Rij - 1.0) * (r / Rij - 1.0);  // eq. 29
      const double rs = r <= p.alpha_T * Lij
                            ? Lij
                            : (Rij - Lij) / (Rij - p.alpha_T * Lij) * (r - p.alpha_T * Lij) + Lij;  // eq. 95
      num += w * (c.x.col(j) + rs * xji / r);
      den += w;
      if (r < (1.0 - p.alpha_p) * Lij) pen += w * ((1.0 - p.alpha_p) * Lij - r) / Lij * Lij;  // eq. 97 × L_ij
    }
    vec<D> d = vec<D>::Zero();
    if (den > 0.0) {
      const vec<D> g = num / den;  // eq. 94
      if ((g - c.x.col(i)).norm() > p.alpha_g * c.L[i]) d = g - c.x.col(i);  // eq. 93
    }
    const vec<D> gc = c.grad_c.col(i);
    if (gc.norm() > 0.0) d += -pen * gc / gc.norm();  // eqs. 96, 98
    if (c.tangential[static_cast<std::size_t>(i)]) {
      const vec<D> ni = c.n.col(i);
      const mat<D> proj = mat<D>::Identity() - ni * ni.transpose();
      d = (proj * d).eval();  // eq. 99
    }
    if (d.norm() > p.alpha_S * c.L[i]) d *= p.alpha_S * c.L[i] / d.norm();  // eq. 100
    out.col(i) = d;
  }
  return out;
}


/// The jittered 10 × 10 lattice of the eq. 91 tests after one shift (seed test_seed() + offset), and the
/// linear velocity field u = A x the tests put on it.
struct shifted_linear {
  std::uint64_t seed;
  std::mt19937_64 rng;
  shift_case<2> c;
  mat<2> A;
  explicit shifted_linear(std::uint64_t offset)
      : seed(test_seed() + offset), rng(seed), c(lattice<2>(10, 10, 0.2, rng)) {
    c.build();
    c.run();
    A << 0.3, -1.2, 2.0, 0.7;
  }
};

}  // namespace

TEST_SUITE("tanaka_shift") {
  TEST_CASE_TEMPLATE("regularize: tanaka shift is zero on a perfect periodic lattice", Dim,
                     std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
    constexpr int D = Dim::value;
    const int m = D == 2 ? 12 : 8;  // period ≥ 8 L0 > 2 R = 6.2 L0: one image per neighbour
    std::mt19937_64 rng(0);
    std::array<bool, D> all{};
    all.fill(true);
    shift_case<D> c(lattice<D>(m, m, 0.0, rng), periodic_box<D>(m, m, all));
    c.build();
    // Defaults: every particle is interior; the symmetric sums of eq. 94 cancel to rounding (far below
    // α_g L = 1e-3 L, so eq. 93 returns exactly 0), no pair is closer than 0.9 L (no penalty), ∇c = 0.
    const regularize::tanaka_shift_report r = c.run();
    CHECK(r.active == c.x.cols());
    CHECK(r.moved == 0);
    CHECK((c.dx.array() == 0.0).all());
    // α_g = 0 exposes the raw centre of mass: zero by symmetry up to the rounding of ~30–120 terms of
    // size ≤ 0.2 L each (tolerance 1e-14 L, about 50 ulps of L).
    regularize::tanaka_shift_params p;
    p.alpha_g = 0.0;
    c.run(p);
    const double worst = c.dx.cwiseAbs().maxCoeff() / L0;
    MESSAGE("max |g - x| / L on the perfect lattice (alpha_g = 0): " << worst);
    CHECK(worst <= 1e-14);
  }

  TEST_CASE_TEMPLATE(
      "regularize: tanaka shift sends a displaced particle back toward its site, limited to alpha_S L", Dim,
      std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
    constexpr int D = Dim::value;
    const int m = D == 2 ? 12 : 8;
    std::mt19937_64 rng(0);
    std::array<bool, D> all{};
    all.fill(true);
    shift_case<D> c(lattice<D>(m, m, 0.0, rng), periodic_box<D>(m, m, all));
    // Displace one particle by 0.2 L along an axis (2D) or the cube diagonal (3D): by the lattice's
    // mirror symmetries the restoring displacement is anti-parallel to the displacement.
    const index_t k = c.x.cols() / 2 + m / 2;
    vec<D> e = vec<D>::Ones();
    if constexpr (D == 2) e = vec<D>(1.0, 0.0);
    e.normalize();
    c.x.col(k) += 0.2 * L0 * e;
    c.build();
    // Unlimited first (α_S huge): the raw δx* of eqs. 93–95 points back and is shorter than the offset.
    regularize::tanaka_shift_params p;
    p.alpha_S = 1e6;
    c.run(p);
    const vec<D> raw = c.dx.col(k);
    MESSAGE("unlimited restoring shift / L: " << raw.norm() / L0 << " (offset 0.2, alpha_S 0.01)");
    CHECK(raw.dot(e) < 0.0);                                 // back toward the site
    CHECK((raw - raw.dot(e) * e).norm() <= 1e-14 * L0);      // along the displacement (symmetry)
    CHECK(raw.norm() < 0.2 * L0);                            // no overshoot
    // Defaults: eq. 100 keeps the direction and cuts the length to min(|raw|, α_S L). In 2D the raw
    // shift exceeds α_S L (measured 0.014 L), in 3D along the diagonal it does not (0.0045 L).
    const regularize::tanaka_shift_report r = c.run();
    const vec<D> d = c.dx.col(k);
    CAPTURE(d.transpose());
    const double cap = 0.01 * L0;
    CHECK(d.norm() == doctest::Approx(std::min(raw.norm(), cap)).epsilon(1e-14));
    CHECK((d - d.norm() / raw.norm() * raw).norm() <= 1e-15 * L0);
    if (D == 2) {
      CHECK(raw.norm() > cap);
      CHECK(r.limited >= 1);
      CHECK(r.max_shift_over_L == doctest::Approx(0.01).epsilon(1e-14));
    }
  }

  TEST_CASE(
      "regularize: tanaka shift pushes an overlapping pair apart along its line (penalty, eqs. 96-97)") {
    const double ang = 0.37;
    const vec<2> e(std::cos(ang), std::sin(ang));
    points<2> x(2, 2);
    x.col(0) = vec<2>(0.1, 0.2);
    x.col(1) = x.col(0) + 0.5 * L0 * e;  // r = 0.5 L
    shift_case<2> c(x);
    c.grad_c.col(0) = 3.0 * e;  // c grows toward the neighbour (the caller's LSMPS ∇c)
    c.grad_c.col(1) = -3.0 * e;
    c.build();
    // Penalty alone: α_g huge switches eq. 93 off, α_S huge switches eq. 100 off.
    regularize::tanaka_shift_params p;
    p.alpha_g = 1e6;
    p.alpha_S = 1e6;
    c.run(p);
    const double w = (0.5 / 3.1 - 1.0) * (0.5 / 3.1 - 1.0);  // eq. 29 at r = 0.5 L, R = 3.1 L
    const double depth = (0.9 - 0.5) * L0;                    // eq. 97 × L_ij: (1 − α_p) L − r
    CHECK((c.dx.col(0) + w * depth * e).norm() <= 1e-15 * L0);  // −w ε L ∇c/|∇c| (rounding only)
    CHECK((c.dx.col(1) - w * depth * e).norm() <= 1e-15 * L0);
    // Centre of mass alone (no ∇c): eq. 94 puts i at the target point at distance r* = L from j.
    c.grad_c.setZero();
    p.alpha_g = 0.001;
    c.run(p);
    CHECK((c.dx.col(0) + 0.5 * L0 * e).norm() <= 1e-15 * L0);
    // Defaults: both terms push apart, limited to α_S L along the line.
    c.grad_c.col(0) = 3.0 * e;
    c.grad_c.col(1) = -3.0 * e;
    const regularize::tanaka_shift_report r = c.run();
    CHECK(r.limited == 2);
    CHECK((c.dx.col(0) + 0.01 * L0 * e).norm() <= 1e-15 * L0);
    CHECK((c.dx.col(1) - 0.01 * L0 * e).norm() <= 1e-15 * L0);
  }

  TEST_CASE("regularize: tanaka shift with penalty_only: an excluded particle enters eq. 96 only") {
    // lsmps_params::shift_isolated_penalty (deviation 18): particle 1 does not participate (an isolated one)
    // and sits 0.5 L from particle 0, particle 2 participates 2 L away on the other side. With
    // penalty_only[1] set, particle 0's displacement is the one without particle 1 plus eq. 96's per-pair
    // push away from it, −w ε L x_01/r (exact to rounding: eq. 100 is switched off); eq. 94 does not see
    // particle 1.
    const double ang = 0.37;
    const vec<2> e(std::cos(ang), std::sin(ang));
    points<2> x(2, 3);
    x.col(0) = vec<2>(0.1, 0.2);
    x.col(1) = x.col(0) + 0.5 * L0 * e;
    x.col(2) = x.col(0) - 2.0 * L0 * e;
    shift_case<2> c(x);
    c.active[1] = 0;
    c.build();
    regularize::tanaka_shift_params p;
    p.penalty = regularize::penalty_direction::pair;
    p.alpha_S = 1e6;
    const auto part = [](index_t j) { return j != 1; };
    c.run(p, exec::seq{}, part);
    const vec<2> without = c.dx.col(0);
    CHECK(without.dot(e) > 0.0);  // eq. 94: particle 2 pushes 0 away from it (eq. 95 never pulls)
    std::vector<std::uint8_t> only(3, 0);
    only[1] = 1;
    c.run(p, exec::seq{}, part, nullptr, nullptr, &only);
    const double w = (0.5 / 3.1 - 1.0) * (0.5 / 3.1 - 1.0);  // eq. 29 at r = 0.5 L, R = 3.1 L
    const double depth = (0.9 - 0.5) * L0;                    // eq. 97 × L_ij
    CHECK((c.dx.col(0) - (without - w * depth * e)).norm() <= 1e-15 * L0);
    CHECK(c.dx.col(1).isZero(0.0));  // inactive rows do not move
    // A flag on a participating row changes nothing; a wrong length is refused.
    only.assign(3, 1);
    c.run(p, exec::seq{}, all_participate{}, nullptr, nullptr, &only);
    const points<2> all = c.dx;
    c.run(p, exec::seq{}, all_participate{});
    CHECK((c.dx.array() == all.array()).all());
    only.resize(2);
    CHECK_THROWS_WITH_AS(c.run(p, exec::seq{}, part, nullptr, nullptr, &only),
                         doctest::Contains("penalty_only"), mpskit::error);
    // The printed direction −∇c does not push i away from j: refused. A row beyond active.size() (a ghost)
    // too.
    only.assign(3, 0);
    only[1] = 1;
    p.penalty = regularize::penalty_direction::concentration_gradient;
    CHECK_THROWS_WITH_AS(c.run(p, exec::seq{}, part, nullptr, nullptr, &only),
                         doctest::Contains("penalty_only needs penalty_direction::pair"), mpskit::error);
    p.penalty = regularize::penalty_direction::pair;
    c.active.resize(2);
    only.assign(3, 0);
    only[2] = 1;
    CHECK_THROWS_WITH_AS(c.run(p, exec::seq{}, part, nullptr, nullptr, &only),
                         doctest::Contains("penalty_only is set at row 2"), mpskit::error);
  }

  TEST_CASE("regularize: tanaka shift of surface particles is tangential (eq. 99)") {
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    const int m = 12, rows = 8;
    shift_case<2> c(lattice<2>(m, rows, 0.15, rng), periodic_box<2>(m, rows, {true, false}));
    c.build();
    // Top row: surface particles with a tilted outward normal; ∇c points into the fluid there.
    const vec<2> nrm(std::sin(0.3), std::cos(0.3));
    index_t top = 0, moved_top = 0;
    for (index_t i = 0; i < c.x.cols(); ++i)
      if (c.x(1, i) > (rows - 1) * L0) {
        c.tangential[static_cast<std::size_t>(i)] = 1;
        c.n.col(i) = nrm;
        c.grad_c.col(i) = vec<2>(0.0, -50.0);
        ++top;
      }
    const regularize::tanaka_shift_report r = c.run();
    CHECK(r.projected == top);
    double worst = 0.0;
    for (index_t i = 0; i < c.x.cols(); ++i)
      if (c.tangential[static_cast<std::size_t>(i)]) {
        worst = std::max(worst, std::abs(c.dx.col(i).dot(nrm)));
        moved_top += c.dx.col(i).norm() > 0.0;
      }
    MESSAGE("max |dx . n| / L over " << top << " surface particles: " << worst / L0);
    CHECK(worst <= 1e-14 * L0);  // one projection of a vector ≤ 0.01 L: rounding ~1e-18 L
    CHECK(moved_top > 0);        // jittered: the tangential part is not zero
  }

  TEST_CASE_TEMPLATE("regularize: tanaka shift with a second (wall) normal removes both normal components",
                     Dim, std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
    constexpr int D = Dim::value;
    const std::uint64_t seed = test_seed() + 6;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    const int m = D == 2 ? 12 : 7;
    shift_case<D> c(lattice<D>(m, m, 0.2, rng));
    std::normal_distribution<double> N(0.0, 1.0);
    points<D> nw(D, c.x.cols());
    for (index_t i = 0; i < c.x.cols(); ++i) {
      vec<D> a, b;
      for (int k = 0; k < D; ++k) {
        a[k] = N(rng);
        b[k] = N(rng);
      }
      c.n.col(i) = a.normalized();
      nw.col(i) = b.normalized();  // random: not orthogonal to n (the Gram–Schmidt step matters)
      c.tangential[static_cast<std::size_t>(i)] = 1;
      c.grad_c.col(i) = 30.0 * vec<D>(b - a);
    }
    c.build();
    regularize::tanaka_shift_params p;
    p.alpha_S = 1e6;  // the unlimited vectors are larger: a stronger test of the projection
    const regularize::tanaka_shift_report r = c.run(p, exec::seq{}, all_participate{}, &nw);
    CHECK(r.projected == c.x.cols());
    double along_n = 0.0, along_w = 0.0, size = 0.0;
    for (index_t i = 0; i < c.x.cols(); ++i) {
      along_n = std::max(along_n, std::abs(c.dx.col(i).dot(c.n.col(i))));
      along_w = std::max(along_w, std::abs(c.dx.col(i).dot(nw.col(i))));
      size = std::max(size, c.dx.col(i).norm());
    }
    MESSAGE("max |dx.n| / L = " << along_n / L0 << ", max |dx.n_wall| / L = " << along_w / L0
                                << ", max |dx| / L = " << size / L0);
    // Two projections of vectors ≤ 0.3 L: rounding ~1e-16 L; in 2D two independent normals leave nothing.
    CHECK(along_n <= 1e-14 * L0);
    CHECK(along_w <= 1e-14 * L0);
    if (D == 2) CHECK(size <= 1e-14 * L0);
    if (D == 3) CHECK(size > 1e-3 * L0);  // the component along n × n_wall survives
    points<D> bad(D, 3);
    CHECK_THROWS_WITH_AS(c.run(p, exec::seq{}, all_participate{}, &bad), doctest::Contains("n_wall"),
                         mpskit::error);
  }

  TEST_CASE("regularize: tanaka shift with two wall normals (a 3D edge): only the edge direction survives") {
    // lsmps_params::shift_second_wall: eq. 99 along both walls of an edge. Interior particles (n = 0) with
    // the walls x = 0 and y = 0: δx must be along z exactly (both components removed); with a random n as
    // well, nothing survives (three independent directions in 3D). Random unit normals for the second part,
    // so the Gram–Schmidt steps matter.
    constexpr int D = 3;
    const std::uint64_t seed = test_seed() + 7;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    shift_case<D> c(lattice<D>(7, 7, 0.2, rng));
    std::normal_distribution<double> N(0.0, 1.0);
    points<D> w1(D, c.x.cols()), w2(D, c.x.cols());
    for (index_t i = 0; i < c.x.cols(); ++i) {
      w1.col(i) = vec<D>(1.0, 0.0, 0.0);
      w2.col(i) = vec<D>(0.0, 1.0, 0.0);
      c.tangential[static_cast<std::size_t>(i)] = 1;
      c.grad_c.col(i) = 30.0 * vec<D>(N(rng), N(rng), N(rng));
    }
    c.build();
    regularize::tanaka_shift_params p;
    p.alpha_S = 1e6;
    c.run(p, exec::seq{}, all_participate{}, &w1, &w2);
    double off = 0.0, along = 0.0;
    for (index_t i = 0; i < c.x.cols(); ++i) {
      off = std::max({off, std::abs(c.dx(0, i)), std::abs(c.dx(1, i))});
      along = std::max(along, std::abs(c.dx(2, i)));
    }
    MESSAGE("edge: max |dx_x|, |dx_y| = " << off / L0 << " L, max |dx_z| = " << along / L0 << " L");
    CHECK(off == 0.0);            // (I − e_x⊗e_x)(I − e_y⊗e_y) removes both components exactly
    CHECK(along > 1e-3 * L0);     // the edge direction is free
    for (index_t i = 0; i < c.x.cols(); ++i) {  // random n, random walls: nothing left
      vec<D> a(N(rng), N(rng), N(rng)), b(N(rng), N(rng), N(rng)), d(N(rng), N(rng), N(rng));
      c.n.col(i) = a.normalized();
      w1.col(i) = b.normalized();
      w2.col(i) = d.normalized();
    }
    c.run(p, exec::seq{}, all_participate{}, &w1, &w2);
    double size = 0.0;
    for (index_t i = 0; i < c.x.cols(); ++i) size = std::max(size, c.dx.col(i).norm());
    CHECK(size <= 1e-13 * L0);  // three independent constraints in 3D: rounding only
    points<D> bad(D, 3);
    CHECK_THROWS_WITH_AS(c.run(p, exec::seq{}, all_participate{}, &w1, &bad), doctest::Contains("n_wall2"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(c.run(p, exec::seq{}, all_participate{}, nullptr, &w2), doctest::Contains("n_wall2"),
                         mpskit::error);
  }

  TEST_CASE(
      "regularize: tanaka shift at a contact line: the printed eq. 99 freezes an overlapping pair, wall_only "
      "separates it") {
    // Wall x = 0 (normal +x into the fluid), free surface above (normal +y): in 2D the two normals of eq. 99
    // remove every direction, so a pair at the contact line cannot be pushed apart (the failure seen in
    // Tanaka's dam break at T ≈ 1.44, docs/regularize.md). wall_only keeps the overlap penalty δx** and
    // removes only its component into the wall.
    points<2> x(2, 2);
    x.col(0) = vec<2>(0.30 * L0, 0.5);
    x.col(1) = vec<2>(0.65 * L0, 0.5 - 0.10 * L0);
    const vec<2> xij = x.col(1) - x.col(0);
    const double r = xij.norm();
    const vec<2> e = xij / r;
    shift_case<2> c(x);
    points<2> nw(2, 2);
    for (index_t i = 0; i < 2; ++i) {
      c.tangential[static_cast<std::size_t>(i)] = 1;
      c.n.col(i) = vec<2>(0.0, 1.0);
      nw.col(i) = vec<2>(1.0, 0.0);
    }
    c.build();
    regularize::tanaka_shift_params p;
    p.penalty = regularize::penalty_direction::pair;
    p.alpha_g = 1e6;  // eq. 93 off: the penalty alone
    p.alpha_S = 1e6;  // eq. 100 off
    c.run(p, exec::seq{}, all_participate{}, &nw);
    CHECK(c.dx.col(0).norm() <= 1e-15 * L0);  // printed: nothing left
    CHECK(c.dx.col(1).norm() <= 1e-15 * L0);
    p.projection = regularize::penalty_projection::wall_only;
    c.run(p, exec::seq{}, all_participate{}, &nw);
    const double k = kernel::quadratic::w(r, 3.1 * L0) * (0.9 * L0 - r);  // eq. 29 × eq. 97 × L_ij, per pair
    // Particle 1 is pushed away from the wall along +e: kept whole. Particle 0 is pushed along −e, which
    // points into the wall: only the tangential part (along +y) is kept.
    CHECK((c.dx.col(1) - k * e).norm() <= 1e-15 * L0);
    CHECK(std::abs(c.dx(0, 0)) <= 1e-15 * L0);
    CHECK(c.dx(1, 0) == doctest::Approx(-k * e[1]).epsilon(1e-13));
    CHECK((xij + c.dx.col(1) - c.dx.col(0)).norm() > r + 0.5 * k);  // the pair separates
  }

  TEST_CASE(
      "regularize: tanaka shift wall_only: a particle overlapping the wall is pushed off it, one at L/2 is "
      "not") {
    // Row 0: a fluid particle beside the wall x = 0; row 1 (a ghost, j >= active.size()): its imaginary copy
    // on the wall. At L/2 (the lattice at rest) the copy is outside (1 − α_p) L/2 = 0.45 L: no push in either
    // form. At 0.2 L the printed eq. 99 removes the copy's push (tangential only); wall_only keeps it.
    for (const double d : {0.5, 0.2}) {
      points<2> x(2, 2);
      x.col(0) = vec<2>(d * L0, 0.3);
      x.col(1) = vec<2>(0.0, 0.3);
      shift_case<2> c(x);
      c.active.assign(1, 1);
      c.tangential[0] = 1;
      points<2> nw = points<2>::Zero(2, 2);
      nw.col(0) = vec<2>(1.0, 0.0);
      c.build();
      regularize::tanaka_shift_params p;
      p.penalty = regularize::penalty_direction::pair;
      p.alpha_g = 1e6;
      p.alpha_S = 1e6;
      c.run(p, exec::seq{}, all_participate{}, &nw);
      CHECK(c.dx.col(0).norm() <= 1e-15 * L0);
      p.projection = regularize::penalty_projection::wall_only;
      c.run(p, exec::seq{}, all_participate{}, &nw);
      const double r = d * L0, edge = 0.45 * L0;
      const double expect = r < edge ? kernel::quadratic::w(r, 3.1 * L0) * (edge - r) : 0.0;
      CAPTURE(d);
      CHECK(c.dx(0, 0) == doctest::Approx(expect).epsilon(1e-13));
      CHECK(std::abs(c.dx(1, 0)) <= 1e-15 * L0);
      if (d < 0.45) CHECK(c.dx(0, 0) > 0.0);  // off the wall
    }
  }

  TEST_CASE("regularize: tanaka shift matches eqs. 93-100 written literally (random diameters, masks)") {
    const std::uint64_t seed = test_seed() + 1;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    shift_case<2> c(lattice<2>(14, 10, 0.25, rng));
    std::uniform_real_distribution<double> U(0.8, 1.25), A(0.0, 2.0 * std::numbers::pi), G(-40.0, 40.0);
    for (index_t i = 0; i < c.x.cols(); ++i) {
      c.L[i] = U(rng) * L0;
      c.grad_c.col(i) = vec<2>(G(rng), G(rng));
      const double a = A(rng);
      c.n.col(i) = vec<2>(std::cos(a), std::sin(a));
      c.tangential[static_cast<std::size_t>(i)] = i % 3 == 0;
      c.active[static_cast<std::size_t>(i)] = i % 11 != 0;
    }
    c.active.resize(c.active.size() - 7);  // the last 7 rows act as ghosts (neighbours only)
    const auto part = [](index_t j) { return j % 5 != 1; };
    c.build();
    for (const double alpha_S : {0.01, 1e6}) {
      CAPTURE(alpha_S);
      regularize::tanaka_shift_params p;
      p.alpha_S = alpha_S;
      const regularize::tanaka_shift_report r = c.run(p, exec::seq{}, part);
      const points<2> ref = literal_shift<2>(c, part, p);
      REQUIRE(c.dx.cols() == ref.cols());
      // The library sums x_ij (1 − r*/r) instead of forming g_i − x_i from absolute positions
      // (~0.1 m): rounding ≤ 1e-15 m ≈ 1e-13 L; tolerance 1e-12 L.
      CHECK((c.dx - ref).cwiseAbs().maxCoeff() <= 1e-12 * L0);
      CHECK(r.moved > 0);
      if (alpha_S < 1.0) CHECK(r.limited > 0);
    }
  }

  TEST_CASE("regularize: iterated tanaka shift regularises a jittered periodic lattice and then stops") {
    const std::uint64_t seed = test_seed() + 5;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    const int m = 20;
    shift_case<2> c(lattice<2>(m, m, 0.3, rng), periodic_box<2>(m, m, {true, true}));
    // Nearest-neighbour distance statistics (min and standard deviation, in L).
    const auto stats = [&](double& dmin, double& sd) {
      double s = 0.0, s2 = 0.0;
      dmin = 1e300;
      const search::support<search::uniform_radius> near{{1.5 * L0}, search::radius_rule::own};
      for (index_t i = 0; i < c.x.cols(); ++i) {
        double nn = 1e300;
        c.nl.for_each_neighbour(c.x, i, near,
                                [&](index_t, const vec<2>&, double r2) { nn = std::min(nn, std::sqrt(r2)); });
        dmin = std::min(dmin, nn);
        s += nn;
        s2 += nn * nn;
      }
      const double mean = s / static_cast<double>(c.x.cols());
      sd = std::sqrt(std::max(0.0, s2 / static_cast<double>(c.x.cols()) - mean * mean));
      dmin /= L0;
      sd /= L0;
    };
    c.build();
    double dmin0, sd0;
    stats(dmin0, sd0);
    // δx* only (∇c = 0): x ← x + δx, list rebuilt, until eq. 93's threshold leaves every particle
    // still (measured: 0.43–0.46 L → 0.889–0.900 L and sd 0.14 → 0.025 L, still after ≤ 150 passes for
    // five seeds).
    int passes = 0;
    for (; passes < 300; ++passes) {
      const regularize::tanaka_shift_report r = c.run();
      if (r.moved == 0) break;
      c.x += c.dx;
      for (index_t i = 0; i < c.x.cols(); ++i) c.x.col(i) = c.dom.wrap(c.x.col(i));
      c.build();
    }
    double dmin1, sd1;
    stats(dmin1, sd1);
    MESSAGE("min nearest distance " << dmin0 << " L -> " << dmin1 << " L, sd " << sd0 << " L -> " << sd1
                                    << " L, still after " << passes << " passes");
    CHECK(passes < 300);
    CHECK(dmin1 >= 0.85);
    CHECK(sd1 <= 0.25 * sd0);
  }

  TEST_CASE("regularize: apply_tanaka_shift reproduces a linear velocity field (eq. 91)") {
    const shifted_linear s(2);
    MESSAGE("seed = " << s.seed << " (MPSKIT_SEED)");
    const shift_case<2>& c = s.c;
    const mat<2>& A = s.A;
    points<2> u = A * c.x;
    points<2> x = c.x;
    regularize::apply_tanaka_shift<2>(exec::seq{}, c.dx, [&](index_t) { return A; }, x, u);
    // u = A x is linear, so the first-order Taylor update is exact: u_new = A x_new to rounding.
    CHECK((u - A * x).cwiseAbs().maxCoeff() <= 1e-15);
    CHECK((x - c.x - c.dx).cwiseAbs().maxCoeff() <= 1e-17);
  }

  TEST_CASE(
      "regularize: limit_to_neighbour_range keeps eq. 91 exact inside the data and stops its extrapolation") {
    // (1) The linear field of the case above on a jittered lattice, every interior particle shifted by at
    // most α_S L = 0.01 L: x_i + δx_i lies well inside its neighbours' hull, so A (x_i + δx_i) lies inside
    // the range of their values and the limiter leaves eq. 91 exact (rounding: 1e-15) and counts nothing
    // there.
    const shifted_linear s(3);
    MESSAGE("seed = " << s.seed << " (MPSKIT_SEED)");
    const shift_case<2>& c = s.c;
    const mat<2>& A = s.A;
    const points<2> u = A * c.x;
    int interior = 0, clipped_interior = 0;
    for (index_t i = 0; i < c.x.cols(); ++i) {
      const auto nb = c.nl.neighbours(i);
      bool inside = true;  // neighbours on all four sides within 1.5 L: not on the lattice's edge
      for (int a = 0; a < 2; ++a)
        for (const double sgn : {-1.0, 1.0}) {
          bool any = false;
          for (const auto jj : nb)
            any = any || sgn * (c.x(a, static_cast<index_t>(jj)) - c.x(a, i)) > 0.5 * c.L[i];
          inside = inside && any;
        }
      if (!inside) continue;
      ++interior;
      vec<2> un = u.col(i) + A * c.dx.col(i);
      clipped_interior += regularize::limit_to_neighbour_range<2>(un, u, i, nb);
      CHECK((un - A * (c.x.col(i) + c.dx.col(i))).cwiseAbs().maxCoeff() <= 1e-15);
    }
    REQUIRE(interior >= 36);
    CHECK(clipped_interior == 0);

    // (2) The 2 mm dam-break failure in miniature (docs/lsmps_scheme.md "The shifted velocity's limiter"): a
    // particle at height y = 0.05 L over a floor moving at 10 m/s along it, its neighbours its copy on the
    // floor (wall velocity 0) and one particle 2 L away at 9 m/s. The one-sided gradient is ∂u/∂y = (10
    // − 0)/y, and a shift δy = α_S L = 0.01 L away from the floor adds 10 · 0.01/0.05 = 2 m/s (20 %) per
    // step. Clipped to the range [0, 10] of the data: unchanged, counted. A shift toward the slower neighbour
    // is inside the range: kept.
    points<2> uw(2, 3);
    uw << 10.0, 0.0, 9.0, 0.0, 0.0, 0.0;
    const std::vector<index_t> nbw{1, 2};
    mat<2> G;
    G << 0.0, 10.0 / 0.05, 0.0, 0.0;  // per L: ∂u_x/∂y
    vec<2> up = uw.col(0) + G * vec<2>(0.0, 0.01);
    REQUIRE(up(0) == doctest::Approx(12.0));
    CHECK(regularize::limit_to_neighbour_range<2>(up, uw, 0, nbw));
    CHECK(up(0) == 10.0);
    CHECK(up(1) == 0.0);
    vec<2> down = uw.col(0) + vec<2>(-0.5, 0.0);
    CHECK(!regularize::limit_to_neighbour_range<2>(down, uw, 0, nbw));
    CHECK(down(0) == 9.5);
  }

  TEST_CASE("regularize: tanaka shift refuses bad input") {
    using P = regularize::tanaka_shift_params;
    CHECK_NOTHROW(P{}.validate());
    P p;
    p.alpha_g = -1.0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("alpha_g"), mpskit::error);
    p = P{};
    p.alpha_T = 3.1;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("alpha_T"), mpskit::error);
    p = P{};
    p.alpha_p = 1.0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("alpha_p"), mpskit::error);
    p = P{};
    p.alpha_S = 0.0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("alpha_S"), mpskit::error);
    p = P{};
    p.re_ratio = 1.0;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("re_ratio"), mpskit::error);
    p = P{};
    p.alpha_S = std::nan("");
    CHECK_THROWS_AS(p.validate(), mpskit::error);

    std::mt19937_64 rng(0);
    shift_case<2> c(lattice<2>(6, 6, 0.0, rng));
    c.build();
    c.L[3] = 0.0;
    CHECK_THROWS_WITH_AS(c.run(), doctest::Contains("particle 3 has diameter L"), mpskit::error);
    c.L[3] = L0;
    c.grad_c.resize(2, 5);
    CHECK_THROWS_WITH_AS(c.run(), doctest::Contains("grad_c"), mpskit::error);
    c.grad_c.setZero(2, c.x.cols());
    c.tangential.resize(3);
    CHECK_THROWS_WITH_AS(c.run(), doctest::Contains("tangential_only"), mpskit::error);
    c.tangential.assign(static_cast<std::size_t>(c.x.cols()), 0);
    c.active.assign(static_cast<std::size_t>(c.x.cols()) + 1, 1);
    CHECK_THROWS_WITH_AS(c.run(), doctest::Contains("active"), mpskit::error);
  }
}

TEST_SUITE("shift_threads") {
  TEST_CASE("regularize: tanaka shift is bitwise identical for 1 and 2 threads") {
#ifdef _OPENMP
    const std::uint64_t seed = test_seed() + 3;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    const int m = 72;  // 5184 particles ≥ parallel_min_items (4096): exec::par really threads
    shift_case<2> c(lattice<2>(m, m, 0.15, rng), periodic_box<2>(m, m, {true, true}));
    std::uniform_real_distribution<double> G(-40.0, 40.0);
    for (index_t i = 0; i < c.x.cols(); ++i) {
      c.grad_c.col(i) = vec<2>(G(rng), G(rng));
      c.tangential[static_cast<std::size_t>(i)] = i % 4 == 0;
      c.n.col(i) = c.grad_c.col(i).normalized();
    }
    c.build();
    const int before = max_threads();
    omp_set_num_threads(1);
    const regularize::tanaka_shift_report r1 = c.run({}, exec::par{});
    const points<2> d1 = c.dx;
    omp_set_num_threads(2);
    REQUIRE(max_threads() == 2);
    const regularize::tanaka_shift_report r2 = c.run({}, exec::par{});
    const points<2> d2 = c.dx;
    omp_set_num_threads(before);
    const regularize::tanaka_shift_report rs = c.run({}, exec::seq{});
    CHECK(r1.moved > 0);
    CHECK(r1.limited > 0);
    CHECK((d1.array() == d2.array()).all());
    CHECK((d1.array() == c.dx.array()).all());  // exec::seq too
    for (const auto* r : {&r2, &rs}) {
      CHECK(r1.moved == r->moved);
      CHECK(r1.limited == r->limited);
      CHECK(r1.projected == r->projected);
      CHECK(r1.max_shift_over_L == r->max_shift_over_L);
    }
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
}

// ---- LSMPS wall cases of issue #7 -------------------------------------------------------------------
namespace {

/// Smallest signed distance of the particles to the walls.
template <int D>
double min_signed_distance(const geometry::polygon_set<D>& walls, const points<D>& x) {
  double s = std::numeric_limits<double>::infinity();
  for (index_t i = 0; i < x.cols(); ++i) s = std::min(s, walls.signed_distance(vec<D>(x.col(i))));
  return s;
}

/// Centroid of element e.
template <int D>
vec<D> centroid(const geometry::polygon_set<D>& walls, index_t e) {
  const mat<D> v = walls.element(e);
  return v.rowwise().mean();
}

template <int D>
void check_polygon_tank(const cases::polygon_tank_config& cfg) {
  const cases::polygon_tank<D> t = cases::make_polygon_tank<D>(cfg);
  const double L = cfg.L;
  CAPTURE(D);
  CAPTURE(cfg.lid);
  CAPTURE(cfg.angle_deg);
  REQUIRE(t.size() > 0);
  REQUIRE(static_cast<index_t>(t.faces.size()) == t.walls.size());
  CHECK(t.walls.quality().flipped == 0);  // the hand-wound elements were already consistent
  CHECK(t.walls.quality().inconsistent.empty());
  CHECK(t.walls.quality().degenerate.empty());
  if constexpr (D == 3) CHECK(t.walls.quality().closed() == cfg.lid);  // closed mesh iff lid
  // Every particle at signed distance ≥ L/2 (the fill's rule, 1e-12 m for rounding) and inside the
  // analytic tank below the fill depth.
  const double smin = min_signed_distance<D>(t.walls, t.x);
  MESSAGE("D = " << D << ": " << t.size() << " particles, min signed distance / L = " << smin / L
                 << ", surface height z_s = " << t.surface_height << " (H = " << t.H << ")");
  CHECK(smin >= 0.5 * L - 1e-12);
  bool all_inside = true;
  for (index_t i = 0; i < t.size(); ++i)
    all_inside = all_inside && t.inside(t.x.col(i)) && t.x(D - 1, i) < t.H;
  CHECK(all_inside);
  // Volume: the floor, right wall, end walls and surface are lattice-aligned (W, H, B multiples of L)
  // and matched exactly; only the incline's band of cells with 0 < s < L/2 is dropped (about half a
  // layer) and cells crossing it are kept. Bound: one layer, |N L^D − V(H)| ≤ L × wetted incline.
  const double V = t.volume(t.H), NV = static_cast<double>(t.size()) * std::pow(L, D);
  const double bound = L * t.incline_wetted(t.H);
  MESSAGE("N L^D = " << NV << ", V(H) = " << V
                     << ", |diff| / (L x wetted incline) = " << std::abs(NV - V) / bound);
  CHECK(std::abs(NV - V) <= bound);
  // z_s solves V(z_s) = N L^D; so it is below H by at most one layer normal to the incline.
  CHECK(t.volume(t.surface_height) == doctest::Approx(NV).epsilon(1e-12));
  CHECK(t.surface_height <= t.H + 1e-12);
  CHECK(t.surface_height >= t.H - L);
  CHECK(t.hydrostatic_pressure(t.corner(), 1000.0, 9.81) ==
        doctest::Approx(1000.0 * 9.81 * t.surface_height));
  // Normals point into the fluid: a point just off each element's centroid along its normal is inside
  // the analytic tank, and just behind it is outside.
  bool into = true;
  for (index_t e = 0; e < t.walls.size(); ++e) {
    const vec<D> c = centroid<D>(t.walls, e), n = t.walls.element_normal(e);
    into = into && t.inside(vec<D>(c + 1e-3 * L * n)) && !t.inside(vec<D>(c - 1e-3 * L * n));
  }
  CHECK(into);
  // Concave corner: each face's neighbour leaves the corner on the fluid side of the face (the normals
  // converge), n_incline · (floor point − corner) > 0 and n_floor · (incline point − corner) > 0; the
  // interior angle is 180° − θ.
  index_t e_inc = npos, e_floor = npos;
  for (index_t e = 0; e < t.walls.size(); ++e) {
    if (t.faces[static_cast<std::size_t>(e)] == cases::tank_face::incline && e_inc == npos) e_inc = e;
    if (t.faces[static_cast<std::size_t>(e)] == cases::tank_face::floor && e_floor == npos) e_floor = e;
  }
  REQUIRE(e_inc != npos);
  REQUIRE(e_floor != npos);
  const vec<D> n_inc = t.walls.element_normal(e_inc), n_floor = t.walls.element_normal(e_floor);
  const vec<D> corner = t.corner();
  vec<D> floor_pt = corner, incline_pt = corner;
  floor_pt[0] += 0.5 * cfg.W;
  incline_pt[0] -= 0.5 * cfg.tank_height * t.cot();
  incline_pt[D - 1] += 0.5 * cfg.tank_height;
  CHECK(n_inc.dot(floor_pt - corner) > 0.0);
  CHECK(n_floor.dot(incline_pt - corner) > 0.0);
  const double theta = cfg.angle_deg * std::numbers::pi / 180.0;
  CHECK(std::acos(std::clamp(n_inc.dot(n_floor), -1.0, 1.0)) == doctest::Approx(theta).epsilon(1e-12));
  // The closest point of a particle near the corner is on one of the two faces (no spurious wall).
  CHECK(t.walls.signed_distance(vec<D>(corner + 0.5 * L * (n_inc + n_floor).normalized())) > 0.0);
}

}  // namespace

TEST_SUITE("cases_lsmps") {
  TEST_CASE("cases: polygon tank (2D and 3D, lid and open top, 45 and 60 degrees)") {
    for (const bool lid : {true, false})
      for (const double angle : {60.0, 45.0}) {
        cases::polygon_tank_config cfg;
        cfg.lid = lid;
        cfg.angle_deg = angle;
        check_polygon_tank<2>(cfg);
        check_polygon_tank<3>(cfg);
      }
    cases::polygon_tank_config fine;
    fine.L = 0.004;  // W, H, B multiples of L; 50 × 50 rows in 2D
    check_polygon_tank<2>(fine);
  }

  TEST_CASE_TEMPLATE(
      "cases: tanaka shift with imaginary copies keeps polygon-tank particles >= L/2 from the walls", Dim,
      std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
    constexpr int D = Dim::value;
    const cases::polygon_tank<D> t = cases::make_polygon_tank<D>({});
    const index_t nr = t.size();
    const double L = t.L;
    const int passes = D == 2 ? 100 : 10;
    points<D> x = t.x;
    double smin = 1e300;
    index_t moved = 0;
    for (int it = 0; it < passes; ++it) {
      // Step-start layout of the LSMPS solver: real fluid, then its imaginary copies (wall/imaginary.hpp).
      Eigen::VectorXd Lall = Eigen::VectorXd::Constant(nr, L);
      points<D> xa = x;
      std::vector<wall::imaginary_copy<D>> copies;
      wall::make_imaginary<D>(
          xa, Lall, nr, [](index_t) { return true; }, t.walls, wall::imaginary_params{}, copies);
      wall::write_ghosts<D>(copies, nr, xa, Lall);
      search::neighbour_list<D> nl;
      nl.build(exec::seq{}, xa, search::per_particle_radius{&Lall, 3.1}, search::build_options<D>{});
      // tangential_only: particles with a copy (near a wall: n = the first copy's wall normal, n_wall =
      // a second copy's, at the concave corner) and the top row (n = +z; the wall normal moves to n_wall).
      points<D> gc = points<D>::Zero(D, nr), n = points<D>::Zero(D, nr), nw = points<D>::Zero(D, nr), dx;
      std::vector<std::uint8_t> tang(static_cast<std::size_t>(nr), 0), act(static_cast<std::size_t>(nr), 1);
      for (const wall::imaginary_copy<D>& cp : copies) {
        if (n.col(cp.parent).squaredNorm() == 0.0)
          n.col(cp.parent) = cp.normal;
        else
          nw.col(cp.parent) = cp.normal;
        tang[static_cast<std::size_t>(cp.parent)] = 1;
      }
      for (index_t i = 0; i < nr; ++i)
        if (x(D - 1, i) > t.H - L) {
          if (n.col(i).squaredNorm() > 0.0) nw.col(i) = n.col(i);
          n.col(i) = vec<D>::Unit(D - 1);
          tang[static_cast<std::size_t>(i)] = 1;
        }
      const regularize::tanaka_shift_report r = regularize::tanaka_shift_displacement<D>(
          exec::seq{}, xa, Lall, nl, [](index_t) { return true; }, gc, n, tang, act,
          regularize::tanaka_shift_params{}, dx, &nw);
      moved = std::max(moved, r.moved);
      x += dx;
      smin = std::min(smin, min_signed_distance<D>(t.walls, x));
    }
    double drift = 0.0;
    for (index_t i = 0; i < nr; ++i) drift = std::max(drift, (x.col(i) - t.x.col(i)).norm());
    MESSAGE("D = " << D << ": " << passes << " passes, up to " << moved << " of " << nr
                   << " particles moved per pass, max drift " << drift / L << " L, min signed distance "
                   << smin / L << " L");
    // Near-wall particles move parallel to their (flat) walls and are pushed off the concave corner;
    // others come no closer than L (α_w L) before they get a copy: min s stays L/2 (1e-12 L rounding).
    CHECK(smin >= 0.5 * L * (1.0 - 1e-12));
    CHECK(moved > 0);  // the lattice does not fit the incline: shifting is not idle
  }

  TEST_CASE("cases: polygon tank refuses bad configurations") {
    cases::polygon_tank_config c;
    c.angle_deg = 20.0;
    CHECK_THROWS_WITH_AS(cases::make_polygon_tank<2>(c), doctest::Contains("angle_deg"), mpskit::error);
    c = {};
    c.tank_height = c.H;
    CHECK_THROWS_WITH_AS(cases::make_polygon_tank<2>(c), doctest::Contains("tank_height"), mpskit::error);
    c = {};
    c.L = -1.0;
    CHECK_THROWS_WITH_AS(cases::make_polygon_tank<3>(c), doctest::Contains("L = -1"), mpskit::error);
    c = {};
    c.B = 0.005;
    CHECK_NOTHROW(cases::make_polygon_tank<2>(c));  // B is a 3D number
    CHECK_THROWS_WITH_AS(cases::make_polygon_tank<3>(c), doctest::Contains("L: is 0.01"), mpskit::error);
  }

  TEST_CASE("cases: Tanaka dam break vessel, column, probe and front") {
    for (const double L : {0.001, 0.003, 0.0025}) {
      CAPTURE(L);
      cases::tanaka_dam_break_config cfg;
      cfg.L = L;
      const cases::tanaka_dam_break d = cases::make_tanaka_dam_break(cfg);
      const double smin = min_signed_distance<2>(d.walls, d.x);
      CHECK(smin >= 0.5 * L - 1e-12);
      // Column area 0.1 × 0.2 m²: left wall and floor are lattice-aligned; the right and top free
      // faces lose at most one layer when L does not divide 0.1 or 0.2. Bound: L × (0.1 + 0.2).
      const double NV = static_cast<double>(d.size()) * L * L, V = 0.1 * 0.2;
      MESSAGE("L = " << L << ": " << d.size() << " particles (paper, L = 1 mm: "
                     << cases::tanaka_dam_break::paper_particles << "), N L^2 / V = " << NV / V);
      CHECK(std::abs(NV - V) <= L * (0.1 + 0.2));
      if (L == 0.001) CHECK(d.size() == 100 * 200);  // L divides both sides
      bool in_column = true;
      for (index_t i = 0; i < d.size(); ++i)
        in_column = in_column && d.x(0, i) > -0.2 && d.x(0, i) < -0.1 && d.x(1, i) > 0.0 && d.x(1, i) < 0.2;
      CHECK(in_column);
      // Normals into the vessel: left wall +x, floor +y, right wall −x (elements in that order).
      REQUIRE(d.walls.size() == 3);
      CHECK((d.walls.element_normal(0) - vec<2>(1.0, 0.0)).norm() <= 1e-15);
      CHECK((d.walls.element_normal(1) - vec<2>(0.0, 1.0)).norm() <= 1e-15);
      CHECK((d.walls.element_normal(2) - vec<2>(-1.0, 0.0)).norm() <= 1e-15);
      // Probe (195 mm, 5 mm): 5 mm from the right wall and from the floor.
      CHECK((d.probe() - vec<2>(0.195, 0.005)).norm() <= 1e-15);
      CHECK(d.walls.signed_distance(d.probe()) == doctest::Approx(0.005).epsilon(1e-12));
      // Front at t = 0: the column's right face, h = h0 when L divides h0 (h* = 1, as the first sample
      // of cases/dam_break.hpp); otherwise h0 − L < h ≤ h0.
      const Eigen::VectorXd diam = d.diameters();
      const auto all = [](index_t) { return true; };
      const double h = d.front(d.x, diam, d.size(), all);
      CHECK(h <= d.h0() + 1e-12);
      CHECK(h > d.h0() - L);
      if (L == 0.001 || L == 0.0025)
        CHECK(d.front_star(d.x, diam, d.size(), all) == doctest::Approx(1.0).epsilon(1e-12));
      // Only counted particles define the front; none counted gives NaN.
      const index_t far = [&] {
        index_t k = 0;
        for (index_t i = 0; i < d.size(); ++i)
          if (d.x(0, i) > d.x(0, k)) k = i;
        return k;
      }();
      const double x_far = d.x(0, far);
      const auto not_front_column = [&](index_t i) { return d.x(0, i) < x_far - 0.5 * L; };
      CHECK(d.front(d.x, diam, d.size(), not_front_column) == doctest::Approx(h - L).epsilon(1e-12));
      CHECK(std::isnan(d.front(d.x, diam, d.size(), [](index_t) { return false; })));
      CHECK(d.t_star(0.1) == doctest::Approx(0.1 * std::sqrt(2.0 * 9.8 / 0.1)));
    }
  }

  TEST_CASE("cases: Tanaka dam break with the obstacle of §5.6.2: block walls, column, probe") {
    const double L = 0.005;
    const cases::tanaka_dam_break d = cases::make_tanaka_dam_break(cases::tanaka_obstacle_config(L));
    // Column 100 × 250 mm on the 5 mm lattice: L divides both sides, 20 × 50 particles, none in the block.
    CHECK(d.size() == 20 * 50);
    CHECK(min_signed_distance<2>(d.walls, d.x) >= 0.5 * L - 1e-12);
    // Left wall, floor, the block's left face, top, right face, floor, right wall; normals into the fluid.
    REQUIRE(d.walls.size() == 7);
    const vec<2> expected[7] = {{1, 0}, {0, 1}, {-1, 0}, {0, 1}, {1, 0}, {0, 1}, {-1, 0}};
    for (index_t k = 0; k < 7; ++k) CHECK((d.walls.element_normal(k) - expected[k]).norm() <= 1e-15);
    // Probe 5 mm above the block's top centre (0, 10 mm); a point inside the block is behind the walls.
    CHECK((d.obstacle_probe() - vec<2>(0.0, 0.015)).norm() <= 1e-15);
    CHECK(d.walls.signed_distance(d.obstacle_probe()) == doctest::Approx(0.005).epsilon(1e-12));
    CHECK(d.walls.signed_distance(vec<2>(0.0, 0.004)) < 0.0);
    CHECK(d.walls.signed_distance(vec<2>(0.1, 0.004)) == doctest::Approx(0.004).epsilon(1e-12));
    // Without an obstacle there is no block probe; half an obstacle and a block in the column are refused.
    CHECK_THROWS_WITH_AS(cases::make_tanaka_dam_break({.L = 0.01}).obstacle_probe(),
                         doctest::Contains("no obstacle"), mpskit::error);
    cases::tanaka_dam_break_config c = cases::tanaka_obstacle_config(0.01);
    c.obstacle_height = 0.0;
    CHECK_THROWS_WITH_AS(cases::make_tanaka_dam_break(c), doctest::Contains("both"), mpskit::error);
    c = cases::tanaka_obstacle_config(0.01);
    c.obstacle_centre = -0.1;
    CHECK_THROWS_WITH_AS(cases::make_tanaka_dam_break(c), doctest::Contains("inside the column"),
                         mpskit::error);
  }

  TEST_CASE("cases: Tanaka dam break refuses bad configurations") {
    cases::tanaka_dam_break_config c;
    c.L = 0.0;
    CHECK_THROWS_WITH_AS(cases::make_tanaka_dam_break(c), doctest::Contains("L = 0"), mpskit::error);
    c = {};
    c.column_height = 0.4;
    CHECK_THROWS_WITH_AS(cases::make_tanaka_dam_break(c), doctest::Contains("column_height"), mpskit::error);
    c = {};
    c.vessel_right = -0.3;
    CHECK_THROWS_WITH_AS(cases::make_tanaka_dam_break(c), doctest::Contains("vessel_right"), mpskit::error);
    const cases::tanaka_dam_break d = cases::make_tanaka_dam_break({.L = 0.01});
    CHECK_THROWS_AS(d.front(d.x, d.diameters(), d.size() + 1, [](index_t) { return true; }), mpskit::error);
  }
}
