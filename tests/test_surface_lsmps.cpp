// surface/ for LSMPS scenes (Tanaka, Cardoso & Bahai 2018, seed 000 §4.1, §4.6): packing ratio and isolated
// flags (label packing_ratio), normals and geometric surface detection (label geometric_surface).
// Random cases print their seed; set MPSKIT_SEED to reproduce or vary it.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/geometric.hpp"
#include "mpskit/surface/normals.hpp"
#include "mpskit/surface/packing_ratio.hpp"
#include "support/support.hpp"

using namespace mpskit;
using namespace mpskit::surface;

namespace {

constexpr double l0 = 0.01;  // particle diameter (m)
constexpr double pi = std::numbers::pi;

std::uint64_t test_seed() {
  const char* s = std::getenv("MPSKIT_SEED");
  return s ? std::strtoull(s, nullptr, 10) : 20180601u;
}

const auto everyone = [](index_t) { return true; };
const auto nobody = [](index_t) { return false; };

/// A particle set with per-particle diameters and the list the scene would build (3.1 L, pair rule read
/// by the consumers). Columns [0, nf) are fluid; [nf, size) wall copies (IsWall true).
template <int D>
struct scene {
  points<D> x;
  Eigen::VectorXd L;
  index_t nf = 0;
  search::domain<D> dom{};
  search::neighbour_list<D> nl;
  void build(double skin = 0.0) {
    L = Eigen::VectorXd::Constant(x.cols(), l0);
    nl.build(exec::seq{}, x, search::per_particle_radius{&L, 3.1}, search::build_options<D>{skin, dom});
  }
  bool is_wall(index_t j) const { return j >= nf; }
  index_t size() const { return x.cols(); }
};

/// Slab periodic on x (and z): layers b = 0..ny−1 at y = (b + 1/2) L, m columns per periodic axis; with
/// `wall`, a row of copies on y = 0 below every bottom-layer particle. Index of (a, b, c) = (c·ny + b)·m + a.
template <int D>
scene<D> slab(int m, int ny, bool wall, double jitter = 0.0, std::uint64_t seed = 0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(-jitter, jitter);
  const int mz = D == 3 ? m : 1;
  scene<D> s;
  s.nf = static_cast<index_t>(m) * ny * mz;
  const index_t nw = wall ? static_cast<index_t>(m) * mz : 0;
  s.x.resize(D, s.nf + nw);
  index_t k = 0;
  for (int c = 0; c < mz; ++c)
    for (int b = 0; b < ny; ++b)
      for (int a = 0; a < m; ++a, ++k) {
        s.x(0, k) = (a + 0.5 + U(rng)) * l0;
        s.x(1, k) = (b + 0.5 + U(rng)) * l0;
        if constexpr (D == 3) s.x(2, k) = (c + 0.5 + U(rng)) * l0;
      }
  for (int c = 0; c < mz && wall; ++c)
    for (int a = 0; a < m; ++a, ++k) {
      s.x(0, k) = (a + 0.5) * l0;
      s.x(1, k) = 0.0;
      if constexpr (D == 3) s.x(2, k) = (c + 0.5) * l0;
    }
  s.dom.periodic[0] = true;
  s.dom.hi[0] = m * l0;
  if constexpr (D == 3) {
    s.dom.periodic[2] = true;
    s.dom.hi[2] = m * l0;
  }
  s.build();
  return s;
}
/// Layer b of slab particle k.
template <int D>
int layer_of(index_t k, int m, int ny) {
  return static_cast<int>((k / m) % ny);
}

/// Free block of n^D lattice points (a + 1/2) L, no periodic axis.
template <int D>
scene<D> block(int n) {
  scene<D> s;
  const int nz = D == 3 ? n : 1;
  s.nf = static_cast<index_t>(n) * n * nz;
  s.x.resize(D, s.nf);
  index_t k = 0;
  for (int c = 0; c < nz; ++c)
    for (int b = 0; b < n; ++b)
      for (int a = 0; a < n; ++a, ++k) {
        s.x(0, k) = (a + 0.5) * l0;
        s.x(1, k) = (b + 0.5) * l0;
        if constexpr (D == 3) s.x(2, k) = (c + 0.5) * l0;
      }
  s.build();
  return s;
}

/// Disc (2D) of concentric rings: ring k ≥ 1 at radius k L with round(2πk) equally spaced particles
/// (offset by half a step on odd rings), plus the centre. Sphere (3D) of shells k ≥ 1 at radius k L
/// with round(4πk²) Fibonacci points. `ring` receives each particle's ring/shell index.
template <int D>
scene<D> round_body(int rings, std::vector<int>& ring) {
  std::vector<vec<D>> pts{vec<D>::Zero()};
  ring.assign(1, 0);
  for (int k = 1; k <= rings; ++k) {
    if constexpr (D == 2) {
      const int nk = static_cast<int>(std::lround(2.0 * pi * k));
      for (int q = 0; q < nk; ++q) {
        const double t = 2.0 * pi * (q + 0.5 * (k % 2)) / nk;
        pts.push_back(vec<D>(k * l0 * std::cos(t), k * l0 * std::sin(t)));
        ring.push_back(k);
      }
    } else {
      const int nk = static_cast<int>(std::lround(4.0 * pi * k * k));
      const double golden = pi * (3.0 - std::sqrt(5.0));
      for (int q = 0; q < nk; ++q) {
        const double z = 1.0 - (2.0 * q + 1.0) / nk;
        const double rho = std::sqrt(1.0 - z * z);
        const double t = golden * q + k;  // shells rotated against each other
        pts.push_back(vec<D>(k * l0 * rho * std::cos(t), k * l0 * rho * std::sin(t), k * l0 * z));
        ring.push_back(k);
      }
    }
  }
  scene<D> s;
  s.nf = static_cast<index_t>(pts.size());
  s.x.resize(D, s.nf);
  for (index_t i = 0; i < s.nf; ++i) s.x.col(i) = pts[static_cast<std::size_t>(i)];
  s.build();
  return s;
}

/// Oracle for c of an interior particle of the perfect square/cubic lattice: eqs. 35, 39 and the
/// least-squares eq. 40 summed over lattice offsets directly (no neighbour list), in units of L.
template <int D>
double lattice_interior_c(int A, double Re) {
  std::vector<double> Ra(static_cast<std::size_t>(A)), Na(static_cast<std::size_t>(A), 0.0);
  for (int a = 0; a < A; ++a) Ra[static_cast<std::size_t>(a)] = 0.5 + a * (Re - 1.0) / (A - 1);
  const int m = static_cast<int>(std::ceil(Re)) + 1, mz = D == 3 ? m : 0;
  for (int k = -mz; k <= mz; ++k)
    for (int j = -m; j <= m; ++j)
      for (int i = -m; i <= m; ++i) {
        const double r = std::sqrt(double(i * i + j * j + k * k));
        for (int a = 0; a < A; ++a) {
          const double R = Ra[static_cast<std::size_t>(a)];
          Na[static_cast<std::size_t>(a)] += R < r - 0.5 ? 0.0 : (R > r + 0.5 ? 1.0 : R - r + 0.5);
        }
      }
  double num = 0.0, den = 0.0;
  for (int a = 0; a < A; ++a) {
    const double V = sphere_volume<D>(Ra[static_cast<std::size_t>(a)]);
    num += Na[static_cast<std::size_t>(a)] * V;
    den += V * V;
  }
  return num / den;
}

/// Continuum reference for a flat free surface: the fluid fills the half-space below a plane L/2 above
/// the particle (its own top face), so ⟨N⟩_a is the volume of the ball of radius R_a cut by that plane
/// (2D: πR²/2 + R² asin(h/R) + h√(R²−h²); 3D: 2πR³/3 + π(R²h − h³/3); the full ball when R ≤ h), with
/// unit packing; c from the least-squares eq. 40, in units of L.
template <int D>
double half_space_c(int A, double Re) {
  const double h = 0.5;
  double num = 0.0, den = 0.0;
  for (int a = 0; a < A; ++a) {
    const double R = 0.5 + a * (Re - 1.0) / (A - 1);
    const double V = sphere_volume<D>(R);
    double cut = V;
    if (R > h) {
      if constexpr (D == 2)
        cut = 0.5 * pi * R * R + R * R * std::asin(h / R) + h * std::sqrt(R * R - h * h);
      else
        cut = 2.0 / 3.0 * pi * R * R * R + pi * (R * R * h - h * h * h / 3.0);
    }
    num += cut * V;
    den += V * V;
  }
  return num / den;
}

template <int D>
Eigen::VectorXd packing(const scene<D>& s, const packing_ratio_params& p = {}) {
  Eigen::VectorXd c;
  packing_ratio(
      exec::seq{}, s.x, s.L, s.nl, everyone, [&](index_t j) { return s.is_wall(j); }, p, c);
  return c;
}

constexpr double c_min = 0.95, c_max = 1.2;  // Tanaka 2018 parameter table

}  // namespace

TEST_SUITE("packing_ratio") {
  TEST_CASE_TEMPLATE(
      "surface: packing ratio of a lattice interior equals the lattice sum and lies in [c_min, c_max]", Dim,
      dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const int m = 10, ny = 10;
    const scene<D> s = slab<D>(m, ny, false);
    const Eigen::VectorXd c = packing(s);
    const double ref = lattice_interior_c<D>(8, 3.1);
    MESSAGE("D = " << D << ": interior c = " << ref);
    // Measured while writing: 1.014417 (2D), 1.042116 (3D); |c − 1| ≤ 0.02 / 0.05 leaves ~30 % margin.
    CHECK(std::abs(ref - 1.0) < (D == 2 ? 0.02 : 0.05));
    index_t checked = 0, bad = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      const int b = layer_of<D>(k, m, ny);
      if (b < 3 || b > ny - 4) continue;  // 3 layers ≥ R_e L − L/2 = 2.6 L from both free surfaces
      ++checked;
      // Same formula and arithmetic up to summation order: 1e-12 is rounding.
      bad += !(std::abs(c[k] - ref) < 1e-12 && c[k] > c_min && c[k] < c_max);
    }
    CHECK(checked == static_cast<index_t>(ny - 6) * m * (D == 3 ? m : 1));
    CHECK(bad == 0);
  }

  TEST_CASE_TEMPLATE("surface: packing ratio at a flat free surface matches the half-space continuum", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const int m = 10, ny = 10;
    const scene<D> s = slab<D>(m, ny, false);
    const Eigen::VectorXd c = packing(s);
    const double interior = lattice_interior_c<D>(8, 3.1), cont = half_space_c<D>(8, 3.1);
    MESSAGE("D = " << D << ": top row c = " << c[s.nf - 1] << ", c/c_interior = " << c[s.nf - 1] / interior
                   << ", half-space continuum = " << cont);
    // "About half" (issue 7): the particle sits L/2 below the free plane, so its balls hold more than half;
    // the continuum value is 0.6436 (2D), 0.6574 (3D); measured lattice ratios 0.6432, 0.6555. Band ±0.01
    // around the continuum (the lattice's discreteness: 0.0004 and 0.0019 measured).
    index_t bad = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      const int b = layer_of<D>(k, m, ny);
      if (b != 0 && b != ny - 1) continue;
      bad += !(std::abs(c[k] / interior - cont) < 0.01 && c[k] < c_min);
    }
    CHECK(bad == 0);
    CHECK(cont > 0.6);
    CHECK(cont < 0.7);
  }

  TEST_CASE_TEMPLATE("surface: packing ratio next to a flat wall of copies stays in [c_min, c_max]", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const int m = 10, ny = 10;
    const scene<D> s = slab<D>(m, ny, true);
    const Eigen::VectorXd c = packing(s);
    const scene<D> bare = slab<D>(m, ny, false);
    const Eigen::VectorXd c0 = packing(bare);
    MESSAGE("D = " << D << ": first fluid layer c = " << c[0] << " (without the wall " << c0[0]
                   << "), second " << c[m] << ", third " << c[2 * m] << ", copy " << c[s.nf]);
    // Measured while writing: layers 1–3 c = 1.0838, 1.1204, 1.0500 (2D); 1.0923, 1.1495, 1.0689 (3D) —
    // W* (eq. 36) has no cap, so each copy also counts the half-diameter above the wall that the first
    // fluid layer holds. Asserted: inside [c_min, c_max] for every layer not reached by the free surface,
    // the first layer within 0.1 of 1 (measured 0.084, 0.092), and all copies equal (translation invariance).
    index_t bad = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      const int b = layer_of<D>(k, m, ny);
      if (b > ny - 4) continue;
      bad += !(c[k] > c_min && c[k] < c_max);
      if (b == 0) bad += !(std::abs(c[k] - 1.0) < 0.1);
    }
    CHECK(bad == 0);
    for (index_t k = s.nf; k < s.size(); ++k) CHECK(c[k] == doctest::Approx(c[s.nf]).epsilon(1e-12));
    // Without the copies the bottom layer is a free surface (c ≈ 0.65): the copies are what lifts it.
    CHECK(c0[0] < 0.7);
  }

  TEST_CASE_TEMPLATE("surface: packing ratio of a jittered lattice interior stays in [c_min, c_max]", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const std::uint64_t seed = test_seed() + D;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED), D = " << D);
    const int m = D == 2 ? 16 : 8, ny = D == 2 ? 16 : 10;
    const double jitter = 0.1;  // ±0.1 L per coordinate
    const scene<D> s = slab<D>(m, ny, false, jitter, seed);
    const Eigen::VectorXd c = packing(s);
    double lo = 1e300, hi = -1e300;
    for (index_t k = 0; k < s.nf; ++k) {
      const int b = layer_of<D>(k, m, ny);
      if (b < 3 || b > ny - 4) continue;
      lo = std::min(lo, c[k]);
      hi = std::max(hi, c[k]);
    }
    MESSAGE("interior c in [" << lo << ", " << hi << "]");
    // Measured over MPSKIT_SEED = 1..50 while writing: 2D [0.980, 1.061], 3D [1.018, 1.076]; margins to the
    // paper's band [0.95, 1.2] are ≥ 0.03 below and ≥ 0.12 above.
    CHECK(lo > c_min);
    CHECK(hi < c_max);
  }

  TEST_CASE_TEMPLATE(
      "surface: packing ratio equals a brute-force sum of eqs. 35–36 for mixed sizes and wall copies", Dim,
      dim<2>, dim<3>) {
    // Checks the O(1)-per-neighbour evaluation and the list coverage claim (the `max` read of a 3.1 L list
    // holds every contributing pair, r < (R_e − 1/2) L_i + L_j/2, for any mix of sizes): the oracle loops
    // over all pairs with volume_function, no list. Diameters L, 2L and L/2 at random, positions random in
    // a box, every 5th particle a wall copy, every 7th not participating.
    constexpr int D = Dim::value;
    const std::uint64_t seed = test_seed() + 20 + D;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED), D = " << D);
    std::mt19937_64 rng(seed);
    const index_t np = D == 2 ? 600 : 800;
    const double box = D == 2 ? 0.25 : 0.09;
    std::uniform_real_distribution<double> U(0.0, box);
    std::uniform_int_distribution<int> pick(0, 2);
    scene<D> s;
    s.nf = np;
    s.x.resize(D, np);
    s.L.resize(np);
    for (index_t i = 0; i < np; ++i) {
      for (int a = 0; a < D; ++a) s.x(a, i) = U(rng);
      const int k = pick(rng);
      s.L[i] = k == 0 ? l0 : (k == 1 ? 2.0 * l0 : 0.5 * l0);
    }
    s.nl.build(exec::seq{}, s.x, search::per_particle_radius{&s.L, 3.1});
    const auto wall = [](index_t j) { return j % 5 == 0; };
    const auto part = [](index_t j) { return j % 7 != 0; };
    for (int A : {2, 8, 13}) {
      CAPTURE(A);
      packing_ratio_params p;
      p.radii = A;
      Eigen::VectorXd c;
      packing_ratio(exec::seq{}, s.x, s.L, s.nl, part, wall, p, c);
      double worst = 0.0;
      for (index_t i = 0; i < np; ++i) {
        const double Li = s.L[i], Ri = 3.1 * Li;
        double num = 0.0, den = 0.0;
        for (int a = 0; a < A; ++a) {
          const double R = 0.5 * Li + a * (Ri - Li) / (A - 1);  // eq. 39
          double N = 0.0;
          for (index_t j = 0; j < np; ++j) {
            if (j != i && !part(j)) continue;
            const double Lj = s.L[j];
            N += volume_function(R, (s.x.col(j) - s.x.col(i)).norm(), Lj, std::pow(Lj, D), wall(j));
          }
          const double V = sphere_volume<D>(R);
          num += N * V;
          den += V * V;
        }
        worst = std::max(worst, std::abs(c[i] - num / den) / (num / den));
      }
      MESSAGE("A = " << A << ": largest relative difference to the brute-force sum " << worst);
      // Same formula summed differently (difference arrays vs direct): rounding only, ~1e-15 measured.
      CHECK(worst < 1e-12);
    }
  }

  TEST_CASE(
      "surface: isolated flags from c < alpha_c; a lone particle is isolated, a lattice particle is not") {
    scene<2> s = slab<2>(10, 10, false);
    // Append a lone particle far from the slab (> 3.1 L from everyone).
    s.x.conservativeResize(2, s.nf + 1);
    s.x.col(s.nf) = vec<2>(0.05, 0.5);
    ++s.nf;
    s.build();
    const Eigen::VectorXd c = packing(s);
    // Lone particle: only its own volume, ⟨N⟩_a = L² for every radius; c = L² Σ V_a / Σ V_a² (closed form).
    packing_ratio_params p;
    double num = 0.0, den = 0.0;
    for (int a = 0; a < p.radii; ++a) {
      const double V = sphere_volume<2>(0.5 * l0 + a * 2.1 * l0 / (p.radii - 1));
      num += l0 * l0 * V;
      den += V * V;
    }
    CHECK(c[s.nf - 1] == doctest::Approx(num / den).epsilon(1e-12));
    std::vector<flag::type> flags(static_cast<std::size_t>(s.size()), flag::surface);
    flags[0] |= flag::isolated;  // a stale bit must be cleared (a particle rejoins)
    const index_t n_iso = isolated_flags(c, p.alpha_c, flags);
    CHECK(n_iso == 1);
    CHECK((flags[static_cast<std::size_t>(s.nf - 1)] & flag::isolated) != 0);
    CHECK(flags[0] == flag::surface);  // isolated cleared, surface bit untouched
    CHECK((flags[55] & flag::isolated) == 0);
    // Only the first c.size() entries are touched.
    std::vector<flag::type> f2(static_cast<std::size_t>(s.size()), 0);
    CHECK(isolated_flags(c.head(s.nf - 1), p.alpha_c, f2) == 0);
    // A non-participating neighbourhood makes everyone isolated except through its own volume.
    Eigen::VectorXd c_alone;
    packing_ratio(
        exec::seq{}, s.x, s.L, s.nl, nobody, [](index_t) { return false; }, p, c_alone);
    CHECK(c_alone.maxCoeff() == doctest::Approx(num / den).epsilon(1e-12));
  }

  TEST_CASE("surface: packing ratio and isolated flags refuse bad input") {
    const scene<2> s = slab<2>(8, 6, false);
    Eigen::VectorXd c;
    const auto run = [&](const packing_ratio_params& p) {
      packing_ratio(exec::seq{}, s.x, s.L, s.nl, everyone, nobody, p, c);
    };
    packing_ratio_params p;
    p.radii = 1;
    CHECK_THROWS_WITH_AS(run(p), doctest::Contains("radii"), mpskit::error);
    p.radii = 65;
    CHECK_THROWS_WITH_AS(run(p), doctest::Contains("[2, 64]"), mpskit::error);
    p = {};
    p.re_ratio = 1.0;
    CHECK_THROWS_WITH_AS(run(p), doctest::Contains("re_ratio"), mpskit::error);
    p.re_ratio = std::nan("");
    CHECK_THROWS_WITH_AS(run(p), doctest::Contains("re_ratio"), mpskit::error);
    p = {};
    p.alpha_c = -0.1;
    CHECK_THROWS_WITH_AS(run(p), doctest::Contains("alpha_c"), mpskit::error);
    p.alpha_c = 1.5;
    CHECK_THROWS_WITH_AS(run(p), doctest::Contains("alpha_c"), mpskit::error);
    Eigen::VectorXd Lbad = s.L;
    Lbad[7] = 0.0;
    CHECK_THROWS_WITH_AS(
        packing_ratio(exec::seq{}, s.x, Lbad, s.nl, everyone, nobody, packing_ratio_params{}, c),
        doctest::Contains("particle 7"), mpskit::error);
    CHECK_THROWS_WITH_AS(packing_ratio(exec::seq{}, s.x, Eigen::VectorXd(s.L.head(3)), s.nl, everyone, nobody,
                                       packing_ratio_params{}, c),
                         doctest::Contains("L has 3 entries"), mpskit::error);
    std::vector<flag::type> flags(3, 0);
    CHECK_THROWS_WITH_AS(isolated_flags(Eigen::VectorXd::Ones(5), 0.3, flags),
                         doctest::Contains("flags has 3"), mpskit::error);
    CHECK_THROWS_WITH_AS(isolated_flags(Eigen::VectorXd::Ones(3), 2.0, flags), doctest::Contains("alpha_c"),
                         mpskit::error);
    CHECK_THROWS_WITH_AS(isolated_flags(Eigen::VectorXd::Constant(3, std::nan("")), 0.3, flags),
                         doctest::Contains("particle 0"), mpskit::error);
  }
}

namespace {

template <int D>
struct normal_field {
  points<D> n;
  std::vector<std::uint8_t> degenerate;
};

template <int D, class Participates = decltype(everyone)>
normal_field<D> compute_normals(const scene<D>& s, const Participates& participates = everyone) {
  normal_field<D> f;
  normals(exec::seq{}, s.x, s.L, s.nl, participates, f.n, f.degenerate, [&](index_t i) { return i < s.nf; });
  return f;
}

template <int D, class Participates = decltype(everyone)>
std::vector<std::uint8_t> detect(const scene<D>& s, const points<D>& n,
                                 const Participates& participates = everyone) {
  std::vector<std::uint8_t> surface;
  geometric(exec::seq{}, s.x, s.L, s.nl, participates, n, geometric_params{}, surface,
            [&](index_t i) { return i < s.nf; });
  return surface;
}

/// True when lattice point k of an n^D block lies on its boundary layer.
template <int D>
bool on_block_boundary(index_t k, int n) {
  for (int a = 0; a < D; ++a) {
    const index_t c = k % n;
    k /= n;
    if (c == 0 || c == n - 1) return true;
  }
  return false;
}

}  // namespace

TEST_SUITE("geometric_surface") {
  TEST_CASE_TEMPLATE("surface: normals of a flat free surface are ±e_y; a symmetric interior is degenerate",
                     Dim, dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const int m = 8, ny = 10;
    const scene<D> s = slab<D>(m, ny, false);
    const normal_field<D> f = compute_normals(s);
    vec<D> ey = vec<D>::Zero();
    ey[1] = 1.0;
    index_t bad = 0, vanishing = 0, unit = 0;
    std::vector<double> worst(3, 0.0);
    for (index_t k = 0; k < s.nf; ++k) {
      const int b = layer_of<D>(k, m, ny);
      const normal_result<D> r = normal_of<D>(s.x, s.L, s.nl, everyone, normals_params{}, k);
      if (k < static_cast<index_t>(m) * ny && k % m == 0)
        MESSAGE("D = " << D << " layer " << b << ": |n*| = " << r.n_star.norm());
      if (f.degenerate[static_cast<std::size_t>(k)] == degenerate_normal::none) {
        ++unit;
        // Exact mirror symmetry in x (and z) of a periodic lattice: the tangential part is rounding only.
        const vec<D> expect = b < ny / 2 ? vec<D>(-ey) : ey;
        const double err = (f.n.col(k) - expect).norm();
        worst[static_cast<std::size_t>(std::min(b, ny - 1 - b))] =
            std::max(worst[static_cast<std::size_t>(std::min(b, ny - 1 - b))], err);
        // Tangential rounding of n̂* (~1e-16) divided by |n̂*|: 1e-12 on the surface layer (|n̂*| ≈ 0.75),
        // 1e-10 on the third layer (|n̂*| ≈ 3e-4 and 7e-4).
        bad += !(err < (b == 0 || b == ny - 1 ? 1e-12 : 1e-10));
      } else {
        vanishing += f.degenerate[static_cast<std::size_t>(k)] == degenerate_normal::vanishing;
        bad += f.n.col(k).norm() != 0.0;
        // Degenerate only where the 3.1 L support is symmetric: ≥ 3 layers from both end layers.
        bad += !(b >= 3 && b <= ny - 4);
      }
    }
    MESSAGE("D = " << D << ": largest |n − (±e_y)| on layers 1, 2, 3 from a surface: " << worst[0] << ", "
                   << worst[1] << ", " << worst[2]);
    CHECK(bad == 0);
    // Top and bottom 3 layers non-degenerate (measured |n̂*| = 0.77, 0.15, 2.7e-4 in 3D from the surface
    // inwards), the ny − 6 middle layers vanishing (|n̂*| ~ 1e-16, rounding of the lattice coordinates).
    CHECK(unit == static_cast<index_t>(6) * m * (D == 3 ? m : 1));
    CHECK(vanishing == static_cast<index_t>(ny - 6) * m * (D == 3 ? m : 1));
  }

  TEST_CASE(
      "surface: a particle without neighbours or with collinear neighbours has a singular (degenerate) "
      "normal") {
    scene<2> s;
    s.nf = 6;
    s.x.resize(2, 6);
    s.x.col(0) = vec<2>(0.5, 0.5);                                 // lone
    for (int q = 1; q < 6; ++q) s.x.col(q) = vec<2>(q * l0, 0.0);  // a line of five
    s.build();
    const normal_field<2> f = compute_normals(s);
    for (int q = 0; q < 6; ++q) {
      CAPTURE(q);
      CHECK(f.degenerate[static_cast<std::size_t>(q)] == degenerate_normal::singular);
      CHECK(f.n.col(q).norm() == 0.0);
    }
    // geometric: the lone particle is surface (no neighbour), the line is inside (zero normal with
    // neighbours).
    const geometric_result<2> lone =
        geometric_of<2>(s.x, s.L, s.nl, everyone, vec<2>::Zero(), geometric_params{}, 0);
    CHECK(lone.step == geometric_step::no_neighbour);
    const geometric_result<2> line =
        geometric_of<2>(s.x, s.L, s.nl, everyone, vec<2>::Zero(), geometric_params{}, 3);
    CHECK(line.step == geometric_step::inside);
  }

  TEST_CASE_TEMPLATE("surface: normals on the outer layer of a disc / ball are radial", Dim, dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    std::vector<int> ring;
    const int rings = D == 2 ? 8 : 5;
    const scene<D> s = round_body<D>(rings, ring);
    const normal_field<D> f = compute_normals(s);
    double worst = 0.0;
    index_t outer = 0, degenerate_outer = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      if (ring[static_cast<std::size_t>(k)] != rings) continue;
      ++outer;
      degenerate_outer += f.degenerate[static_cast<std::size_t>(k)] != degenerate_normal::none;
      const vec<D> radial = s.x.col(k).normalized();
      worst = std::max(worst, std::acos(std::min(1.0, f.n.col(k).dot(radial))));
    }
    MESSAGE("D = " << D << ": " << outer << " outer particles, largest angle to the radial direction "
                   << worst * 180.0 / pi << " deg");
    CHECK(degenerate_outer == 0);
    // Measured while writing: 2D 0.082° (8 rings, spacing L), 3D 1.06° (5 Fibonacci shells, quasi-uniform
    // only); bounds 0.5° / 3°.
    CHECK(worst < (D == 2 ? 0.5 : 3.0) * pi / 180.0);
  }

  TEST_CASE_TEMPLATE("surface: geometric detection flags exactly the boundary layer of a free block", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const int n = D == 2 ? 14 : 8;
    const scene<D> s = block<D>(n);
    const normal_field<D> f = compute_normals(s);
    const std::vector<std::uint8_t> surf = detect(s, f.n);
    index_t wrong = 0, flagged = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      flagged += surf[static_cast<std::size_t>(k)];
      wrong += (surf[static_cast<std::size_t>(k)] != 0) != on_block_boundary<D>(k, n);
    }
    CHECK(wrong == 0);
    const index_t inner = D == 2 ? (n - 2) * (n - 2) : (n - 2) * (n - 2) * (n - 2);
    CHECK(flagged == s.nf - inner);
  }

  TEST_CASE_TEMPLATE("surface: geometric detection on a jittered slab flags exactly its two free layers", Dim,
                     dim<2>, dim<3>) {
    // ±0.15 L per coordinate. While writing: 0 errors in 200 (2D) / 50 (3D) seeds at ±0.02 … ±0.25 L; at
    // ±0.3 L 4/200 (2D) and 14/50 (3D) runs miss or over-flag a particle (docs/surface.md).
    constexpr int D = Dim::value;
    const std::uint64_t seed = test_seed() + 30 + D;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED), D = " << D);
    const int m = D == 2 ? 16 : 8, ny = 10;
    const scene<D> s = slab<D>(m, ny, false, 0.15, seed);
    const normal_field<D> f = compute_normals(s);
    const std::vector<std::uint8_t> surf = detect(s, f.n);
    index_t missed = 0, extra = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      const int b = layer_of<D>(k, m, ny);
      const bool outer = b == 0 || b == ny - 1;
      missed += outer && !surf[static_cast<std::size_t>(k)];
      extra += !outer && surf[static_cast<std::size_t>(k)];
    }
    CHECK(missed == 0);
    CHECK(extra == 0);
  }

  TEST_CASE_TEMPLATE("surface: a slab resting on a row of wall copies is flagged on its top row only", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    const int m = 8, ny = 8;
    const scene<D> s = slab<D>(m, ny, true);
    const normal_field<D> f = compute_normals(s);
    const std::vector<std::uint8_t> surf = detect(s, f.n);
    index_t wrong = 0;
    for (index_t k = 0; k < s.nf; ++k)
      wrong += (surf[static_cast<std::size_t>(k)] != 0) != (layer_of<D>(k, m, ny) == ny - 1);
    CHECK(wrong == 0);
    // The copies are what blocks the bottom cone: when they do not participate the bottom layer is a surface.
    const auto fluid_only = [&](index_t j) { return j < s.nf; };
    const normal_field<D> f0 = compute_normals(s, fluid_only);
    const std::vector<std::uint8_t> surf0 = detect(s, f0.n, fluid_only);
    index_t bottom = 0;
    for (index_t k = 0; k < s.nf; ++k)
      bottom += layer_of<D>(k, m, ny) == 0 && surf0[static_cast<std::size_t>(k)] != 0;
    CHECK(bottom == static_cast<index_t>(m) * (D == 3 ? m : 1));
  }

  TEST_CASE_TEMPLATE("surface: geometric detection on a disc / ball flags the outer layer and nothing inside",
                     Dim, dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    std::vector<int> ring;
    const int rings = D == 2 ? 8 : 5;
    const scene<D> s = round_body<D>(rings, ring);
    const normal_field<D> f = compute_normals(s);
    const std::vector<std::uint8_t> surf = detect(s, f.n);
    index_t missed = 0, extra = 0;
    for (index_t k = 0; k < s.nf; ++k) {
      const bool outer = ring[static_cast<std::size_t>(k)] == rings;
      missed += outer && !surf[static_cast<std::size_t>(k)];
      extra += !outer && surf[static_cast<std::size_t>(k)];
    }
    CHECK(missed == 0);
    CHECK(extra == 0);
  }

  TEST_CASE("surface: the reflected cone (third step) catches a surface particle whose normal is tilted") {
    // Top row of a 2D slab; the normal of one top particle tilted 50° from +e_y towards +e_x (direction 40°
    // from the x axis), as a corner would tilt it. Its 45° cone spans −5°…85° and holds the same-row
    // neighbours at 0°, so eq. 88 finds N_θ > 0 (inside). m_i points along the half-space neighbours (to
    // the right and slightly down); its reflection about n_i points ≈ 95°, into empty space: N′_θ = 0.
    const int m = 12, ny = 8;
    const scene<2> s = slab<2>(m, ny, false);
    const index_t i = static_cast<index_t>(ny - 1) * m + 5;
    const double t = 40.0 * pi / 180.0;
    const vec<2> tilted(std::cos(t), std::sin(t));
    const geometric_result<2> r = geometric_of<2>(s.x, s.L, s.nl, everyone, tilted, geometric_params{}, i);
    MESSAGE("N_theta = " << r.n_theta << ", N'_theta = " << r.n_theta_prime << ", n' = (" << r.n_prime[0]
                         << ", " << r.n_prime[1] << ")");
    CHECK(r.n_theta > 0);         // eq. 88 alone would call it inside
    CHECK(r.n_theta_prime == 0);  // eq. 89 catches it
    CHECK(r.step == geometric_step::reflected_cone);
    CHECK(r.n_prime.norm() == doctest::Approx(1.0).epsilon(1e-12));  // a reflection keeps unit length
    CHECK(r.n_prime[1] > std::cos(pi / 4));                          // n′ points up (within 45° of +e_y)
    // With the computed normal (+e_y) the first cone decides; an interior particle stays inside with the
    // tilt.
    CHECK(geometric_of<2>(s.x, s.L, s.nl, everyone, vec<2>(0.0, 1.0), geometric_params{}, i).step ==
          geometric_step::cone);
    const index_t deep = static_cast<index_t>(ny / 2) * m + 5;
    CHECK(geometric_of<2>(s.x, s.L, s.nl, everyone, tilted, geometric_params{}, deep).step ==
          geometric_step::inside);
  }

  TEST_CASE(
      "surface: counts of a particle with more than 128 neighbours inside alpha_theta L equal brute force") {
    // geometric_of keeps up to 128 neighbours for the third step and walks the list again beyond that; a
    // particle of diameter 5 L among L particles has ≈ π (10.5)² ≈ 350 of them (2.1 · 5 L radius).
    scene<2> s = slab<2>(40, 30, false);
    const index_t big = 15 * 40 + 20;  // layer 15, column 20
    s.L[big] = 5.0 * l0;
    s.nl.build(exec::seq{}, s.x, search::per_particle_radius{&s.L, 3.1},
               search::build_options<2>{0.0, s.dom});
    const double t = 60.0 * pi / 180.0;
    const vec<2> ni(std::cos(t), std::sin(t));
    const geometric_result<2> r = geometric_of<2>(s.x, s.L, s.nl, everyone, ni, geometric_params{}, big);
    index_t inside = 0, cone = 0, cone_prime = 0;
    for (index_t j = 0; j < s.nf; ++j) {
      if (j == big) continue;
      vec<2> d = s.x.col(j) - s.x.col(big);
      s.dom.minimum_image(d);
      const double rr = d.norm();
      if (!(rr < 2.1 * s.L[big])) continue;
      ++inside;
      cone += ni.dot(d) > rr * std::cos(pi / 4);
      cone_prime += r.n_prime.dot(d) > rr * std::cos(pi / 4);
    }
    MESSAGE(inside << " neighbours inside 2.1 L_i; N_theta = " << r.n_theta
                   << ", N'_theta = " << r.n_theta_prime);
    CHECK(inside > 128);
    CHECK(r.n_theta == cone);
    CHECK(r.n_theta_prime == cone_prime);
    CHECK(r.step == geometric_step::inside);
  }

  TEST_CASE("surface: at a 2:1 resolution interface the pair-mean radius removes interior surface flags") {
    // Fine lattice (L) on [0, 10 L] × [0, 12 L] beside a coarse one (2 L) on [10 L, 20 L] × [0, 12 L], all
    // free. Eq. 88 as printed (radius α_θ L_i = 2.1 L for a fine particle) sees the coarse column 1.5 L away
    // only through its particles' gaps: fine particles at the interface are flagged although they are
    // interior. With α_θ L_ij the coarse neighbours are inside the radius and only the outer layer is
    // flagged.
    scene<2> s;
    std::vector<vec<2>> pts;
    std::vector<double> Ls;
    for (int b = 0; b < 12; ++b)
      for (int a = 0; a < 10; ++a) {
        pts.push_back(vec<2>((a + 0.5) * l0, (b + 0.5) * l0));
        Ls.push_back(l0);
      }
    for (int b = 0; b < 6; ++b)
      for (int a = 0; a < 5; ++a) {
        pts.push_back(vec<2>(0.1 + (a + 0.5) * 2 * l0, (b + 0.5) * 2 * l0));
        Ls.push_back(2 * l0);
      }
    s.nf = static_cast<index_t>(pts.size());
    s.x.resize(2, s.nf);
    s.L.resize(s.nf);
    for (index_t i = 0; i < s.nf; ++i) {
      s.x.col(i) = pts[static_cast<std::size_t>(i)];
      s.L[i] = Ls[static_cast<std::size_t>(i)];
    }
    s.nl.build(exec::seq{}, s.x, search::per_particle_radius{&s.L, 3.1});
    const normal_field<2> f = compute_normals(s);
    const auto outer = [&](index_t i) {  // centre within one own diameter of the box [0, 20 L] × [0, 12 L]
      const double d = std::min({s.x(0, i), 0.2 - s.x(0, i), s.x(1, i), 0.12 - s.x(1, i)});
      return d < s.L[i];
    };
    for (search::radius_rule rule : {search::radius_rule::own, search::radius_rule::pair_mean}) {
      geometric_params gp;
      gp.radius = rule;
      std::vector<std::uint8_t> surf;
      geometric(exec::seq{}, s.x, s.L, s.nl, everyone, f.n, gp, surf);
      index_t interior_flagged = 0, outer_missed = 0;
      for (index_t i = 0; i < s.nf; ++i) {
        interior_flagged += !outer(i) && surf[static_cast<std::size_t>(i)];
        outer_missed += outer(i) && !surf[static_cast<std::size_t>(i)];
      }
      MESSAGE("rule " << search::name(rule) << ": interior flagged " << interior_flagged << ", outer missed "
                      << outer_missed);
      CHECK(outer_missed == 0);
      // the limitation of eq. 88 as printed (docs/surface.md)
      if (rule == search::radius_rule::own) CHECK(interior_flagged > 0);
      else
        CHECK(interior_flagged == 0);
    }
  }

  TEST_CASE("surface: only wanted particles are written; results of exec::par equal exec::seq bitwise") {
    const std::uint64_t seed = test_seed() + 11;
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    const int m = 64, ny = 72;  // 4608 particles: above parallel_min_items, so exec::par really threads
    const scene<2> s = slab<2>(m, ny, false, 0.1, seed);
    const auto odd = [](index_t i) { return i % 2 == 1; };
    points<2> n1 = points<2>::Constant(2, s.size(), 7.0), n2;
    std::vector<std::uint8_t> d1(static_cast<std::size_t>(s.size()), 9), d2;
    normals(exec::seq{}, s.x, s.L, s.nl, everyone, n1, d1, odd);
    normals(exec::par{}, s.x, s.L, s.nl, everyone, n2, d2, odd);
    CHECK(n1.col(0) == vec<2>(7.0, 7.0));  // not wanted: untouched
    CHECK(d1[0] == 9);
    n1.col(0).setZero();
    d1[0] = 0;
    for (index_t i = 0; i < s.size(); i += 2) {  // n2/d2 were created by the call: zero where not wanted
      n1.col(i).setZero();
      d1[static_cast<std::size_t>(i)] = 0;
    }
    CHECK((n1.array() == n2.array()).all());
    CHECK(d1 == d2);
    std::vector<std::uint8_t> s1(static_cast<std::size_t>(s.size()), 5), s2;
    geometric(exec::seq{}, s.x, s.L, s.nl, everyone, n1, geometric_params{}, s1, odd);
    geometric(exec::par{}, s.x, s.L, s.nl, everyone, n1, geometric_params{}, s2, odd);
    CHECK(s1[0] == 5);
    for (index_t i = 0; i < s.size(); i += 2) s1[static_cast<std::size_t>(i)] = 0;
    CHECK(s1 == s2);
    Eigen::VectorXd c1, c2;
    packing_ratio(exec::seq{}, s.x, s.L, s.nl, everyone, nobody, packing_ratio_params{}, c1);
    packing_ratio(exec::par{}, s.x, s.L, s.nl, everyone, nobody, packing_ratio_params{}, c2);
    CHECK((c1.array() == c2.array()).all());
  }

  TEST_CASE("surface: normals and geometric detection refuse bad input") {
    const scene<2> s = slab<2>(8, 6, false);
    points<2> n;
    std::vector<std::uint8_t> deg, surf;
    normals_params np;
    np.re_ratio = -1.0;
    CHECK_THROWS_WITH_AS(normals(exec::seq{}, s.x, s.L, s.nl, everyone, n, deg, all_particles{}, np),
                         doctest::Contains("re_ratio"), mpskit::error);
    np = {};
    np.zero_tol = -1.0;
    CHECK_THROWS_WITH_AS(normals(exec::seq{}, s.x, s.L, s.nl, everyone, n, deg, all_particles{}, np),
                         doctest::Contains("zero_tol"), mpskit::error);
    np = {};
    np.singular_tol = 1.0;
    CHECK_THROWS_WITH_AS(normals(exec::seq{}, s.x, s.L, s.nl, everyone, n, deg, all_particles{}, np),
                         doctest::Contains("singular_tol"), mpskit::error);
    Eigen::VectorXd Lbad = s.L;
    Lbad[4] = -l0;
    CHECK_THROWS_WITH_AS(normals(exec::seq{}, s.x, Lbad, s.nl, everyone, n, deg),
                         doctest::Contains("particle 4"), mpskit::error);
    normals(exec::seq{}, s.x, s.L, s.nl, everyone, n, deg);
    geometric_params gp;
    gp.alpha_theta = 0.0;
    CHECK_THROWS_WITH_AS(geometric(exec::seq{}, s.x, s.L, s.nl, everyone, n, gp, surf),
                         doctest::Contains("alpha_theta"), mpskit::error);
    gp = {};
    gp.theta1 = 0.0;
    CHECK_THROWS_WITH_AS(geometric(exec::seq{}, s.x, s.L, s.nl, everyone, n, gp, surf),
                         doctest::Contains("theta1"), mpskit::error);
    gp.theta1 = pi;
    CHECK_THROWS_WITH_AS(geometric(exec::seq{}, s.x, s.L, s.nl, everyone, n, gp, surf),
                         doctest::Contains("theta1"), mpskit::error);
    gp = {};
    gp.radius = search::radius_rule::max;
    CHECK_THROWS_WITH_AS(geometric(exec::seq{}, s.x, s.L, s.nl, everyone, n, gp, surf),
                         doctest::Contains("radius"), mpskit::error);
    gp = {};
    gp.theta2 = 4.0;
    CHECK_THROWS_WITH_AS(geometric(exec::seq{}, s.x, s.L, s.nl, everyone, n, gp, surf),
                         doctest::Contains("theta2"), mpskit::error);
    const points<2> short_n = n.leftCols(3);
    CHECK_THROWS_WITH_AS(geometric(exec::seq{}, s.x, s.L, s.nl, everyone, short_n, geometric_params{}, surf),
                         doctest::Contains("n has 3 columns"), mpskit::error);
  }
}
