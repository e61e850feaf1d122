// wall/: imaginary wall particles on polygon walls (Tanaka 2018 §4.5.1, eqs. 75–77, issue #7 corner
// rules), the wall-crossing guard and thin-wall visibility for the neighbour search.
// Random point sets use a seed printed with each case; set MPSKIT_SEED to reproduce or vary it.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/wall_collection.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/wall/crossing_guard.hpp"
#include "mpskit/wall/imaginary.hpp"
#include "mpskit/wall/visibility.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace mpskit;
using geometry::polygon_mesh;
using geometry::polygon_set;

namespace {

std::uint64_t test_seed() {
  const char* s = std::getenv("MPSKIT_SEED");
  return s ? std::strtoull(s, nullptr, 10) : 20261122ull;
}

// An open polyline through the points (fluid on the left of each segment a→b).
polygon_mesh<2> polyline(const std::vector<vec<2>>& p) {
  polygon_mesh<2> m;
  m.vertices.resize(2, static_cast<index_t>(p.size()));
  for (std::size_t i = 0; i < p.size(); ++i) m.vertices.col(static_cast<index_t>(i)) = p[i];
  m.elements.resize(2, static_cast<index_t>(p.size()) - 1);
  for (index_t e = 0; e + 1 < static_cast<index_t>(p.size()); ++e) m.elements.col(e) << e, e + 1;
  return m;
}

template <int D>
points<D> one(const vec<D>& p) {
  points<D> x(D, 1);
  x.col(0) = p;
  return x;
}

constexpr auto all = [](index_t) { return true; };

template <int D, class Walls>
std::vector<wall::imaginary_copy<D>> copies_of(const vec<D>& p, double L, const Walls& w,
                                               wall::imaginary_report<D>* rep = nullptr,
                                               const wall::imaginary_params& prm = {}) {
  std::vector<wall::imaginary_copy<D>> out;
  const points<D> x = one<D>(p);
  const Eigen::VectorXd Lv = Eigen::VectorXd::Constant(1, L);
  const wall::imaginary_report<D> r = wall::make_imaginary<D>(x, Lv, 1, all, w, prm, out);
  if (rep) *rep = r;
  return out;
}

// Distance from a copy to the element it names (0 up to rounding if the copy lies on it).
template <int D>
double off_element(const polygon_set<D>& w, const wall::imaginary_copy<D>& c) {
  return w.closest_on(c.element, c.x).distance;
}

}  // namespace

TEST_SUITE("imaginary") {
  TEST_CASE("walls: flat floor, one copy straight below with L' = L; none beyond alpha_w L") {
    const double L = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    wall::imaginary_report<2> rep;
    const std::vector<wall::imaginary_copy<2>> c = copies_of<2>(vec<2>(0.5, 0.3 * L), L, w, &rep);
    REQUIRE(c.size() == 1);
    CHECK(rep.copies == 1);
    // eq. (75): x' = x − r n with r = 0.3 L, n = +y; rounding only (coordinates O(1), 1e-15 abs).
    CHECK(std::abs(c[0].x.x() - 0.5) < 1e-15);
    CHECK(std::abs(c[0].x.y()) < 1e-15);
    CHECK(c[0].normal.isApprox(vec<2>(0, 1), 1e-15));
    CHECK(c[0].L == L);  // eq. (76) with σ = 0 on a straight wall: exactly L
    CHECK(c[0].parent == 0);
    CHECK(c[0].wall_velocity.isZero(0.0));
    CHECK(std::abs(c[0].weights.sum() - 1.0) < 1e-15);
    CHECK(off_element(w, c[0]) < 1e-15);
    // r = 1.2 L > α_w L (α_w = 1): no copy; r = 0.99 L: a copy
    CHECK(copies_of<2>(vec<2>(0.5, 1.2 * L), L, w).empty());
    CHECK(copies_of<2>(vec<2>(0.5, 0.99 * L), L, w).size() == 1);
    wall::imaginary_params p;
    p.alpha_w = 1.5;  // the threshold is the parameter, not a constant
    CHECK(copies_of<2>(vec<2>(0.5, 1.2 * L), L, w, nullptr, p).size() == 1);
  }

  TEST_CASE("walls: a particle behind a wall gets no copy (counted)") {
    const double L = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    wall::imaginary_report<2> rep;
    CHECK(copies_of<2>(vec<2>(0.5, -0.3 * L), L, w, &rep).empty());
    CHECK(rep.wrong_side == 1);
    // behind the concave corner (outside the tank): both walls' closest point is the corner vertex
    CHECK(copies_of<2>(vec<2>(-0.3 * L, -0.3 * L), L, w, &rep).empty());
    CHECK(rep.wrong_side == 1);
  }

  TEST_CASE("walls: concave 90 degree corner gives one copy per face") {
    const double L = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    wall::imaginary_report<2> rep;
    const std::vector<wall::imaginary_copy<2>> c = copies_of<2>(vec<2>(0.4 * L, 0.5 * L), L, w, &rep);
    REQUIRE(c.size() == 2);
    CHECK(rep.convex_duplicates_removed == 0);
    CHECK(rep.smooth_duplicates_removed == 0);
    int floor = 0, side = 0;
    for (const auto& k : c) {
      CHECK(off_element(w, k) < 1e-15);  // each on its own face
      CHECK(k.L == L);
      if (k.normal.isApprox(vec<2>(0, 1), 1e-15)) {
        ++floor;
        CHECK(std::abs(k.x.x() - 0.4 * L) < 1e-15);
        CHECK(std::abs(k.x.y()) < 1e-15);
      } else if (k.normal.isApprox(vec<2>(1, 0), 1e-15)) {
        ++side;
        CHECK(std::abs(k.x.x()) < 1e-15);
        CHECK(std::abs(k.x.y() - 0.5 * L) < 1e-15);
      }
    }
    CHECK(floor == 1);
    CHECK(side == 1);
    CHECK(c[0].element < c[1].element);  // order: by element
  }

  TEST_CASE("walls: convex corner of a step gives one copy at the vertex, duplicate counted") {
    const double L = 0.01, h = 5 * L;
    // floor (−1,0)→(0,0), riser (0,0)→(0,h), top (0,h)→(1,h): fluid on the left (above / to the −x side)
    const polygon_set<2> w(polyline({vec<2>(-1, 0), vec<2>(0, 0), vec<2>(0, h), vec<2>(1, h)}));
    const vec<2> q(0, h), x(-0.3 * L, h + 0.4 * L);
    wall::imaginary_report<2> rep;
    const std::vector<wall::imaginary_copy<2>> c = copies_of<2>(x, L, w, &rep);
    REQUIRE(c.size() == 1);
    CHECK(rep.convex_duplicates_removed == 1);
    CHECK((c[0].x - q).norm() < 1e-15);
    CHECK(c[0].normal.isApprox(((x - q) / (x - q).norm()).eval(), 1e-14));  // (x − q)/|x − q|
    CHECK(c[0].L == L);  // a feature vertex has σ = 0 (docs/geometry.md)
    CHECK(c[0].element == 1);  // lower of the two elements meeting there
    // above the top face next to the edge: only the top face, no duplicate
    const std::vector<wall::imaginary_copy<2>> t = copies_of<2>(vec<2>(0.2 * L, h + 0.5 * L), L, w, &rep);
    REQUIRE(t.size() == 1);
    CHECK(rep.convex_duplicates_removed == 0);
    CHECK(rep.smooth_duplicates_removed == 0);  // the riser's end point is not a candidate at all
    CHECK(t[0].element == 2);
    CHECK(t[0].normal.isApprox(vec<2>(0, 1), 1e-15));
  }

  TEST_CASE("walls: inside a circle, L' = L / (1 - r/R) (eq. 76 with eq. 77's curvature)") {
    const double L = 0.01, R = 20 * L;
    const index_t n = 720;
    const polygon_set<2> w(geometry::circle(vec<2>(0, 0), R, n, geometry::fluid_side::inside));
    // on the ray through a segment's midpoint (segment 0 spans angles 0..2π/n)
    const double phi = std::numbers::pi / double(n);
    const double r = 0.5 * L;
    const double rho = R - r;  // distance from the centre; distance to the true circle is r
    const vec<2> x(rho * std::cos(phi), rho * std::sin(phi));
    wall::imaginary_report<2> rep;
    const std::vector<wall::imaginary_copy<2>> c = copies_of<2>(x, L, w, &rep);
    REQUIRE(c.size() == 1);
    // Reference L/(1 − r/R) on the true circle. The polyline's chord lies R(1 − cos(π/n)) = 1.9e-4 L
    // inside the circle, so the particle is r − 1.9e-4 L from its segment: relative difference
    // ≈ 1.9e-4 L/R/(1 − r/R) = 1e-5; σ itself is 1/R to 1e-13 (docs/geometry.md). Tolerance 3e-5.
    const double ref = L / (1.0 - r / R);
    CHECK(std::abs(c[0].L / ref - 1.0) < 3e-5);
    CHECK(c[0].L > L);  // and it is the enlargement, not a shrink
    CHECK(rep.small_diameter_events == 0);
    // on the ray through a vertex both neighbouring segments see the particle: the same smooth wall,
    // one copy, one smooth duplicate
    const vec<2> xv(rho, 0.0);
    const std::vector<wall::imaginary_copy<2>> cv = copies_of<2>(xv, L, w, &rep);
    CHECK(cv.size() == 1);
    CHECK(rep.smooth_duplicates_removed == 1);
    // fluid outside a circular obstacle: σ = −1/R, L' = L/(1 + r/R)
    const polygon_set<2> o(geometry::circle(vec<2>(0, 0), R, n, geometry::fluid_side::outside));
    const double rho_o = R * std::cos(phi) + r;  // r from the segment
    const std::vector<wall::imaginary_copy<2>> co =
        copies_of<2>(vec<2>(rho_o * std::cos(phi), rho_o * std::sin(phi)), L, o);
    REQUIRE(co.size() == 1);
    CHECK(std::abs(co[0].L / (L / (1.0 + r / R)) - 1.0) < 3e-5);
  }

  TEST_CASE("walls: inside a sphere (icosphere), one copy per particle and L' = L / (1 - r/R)") {
    const double L = 0.01, R = 10 * L;
    // 5120 triangles
    const polygon_set<3> w(geometry::sphere(vec<3>(0, 0, 0), R, 4, geometry::fluid_side::inside));
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed + 2);
    std::normal_distribution<double> G(0.0, 1.0);
    std::uniform_real_distribution<double> U(0.2, 0.9);
    double worst_exact = 0.0, worst_sphere = 0.0;
    for (int k = 0; k < 200; ++k) {
      const vec<3> dir = vec<3>(G(rng), G(rng), G(rng)).normalized();
      const double r = U(rng) * L;  // from the true sphere
      const vec<3> x = (R - r) * dir;
      wall::imaginary_report<3> rep;
      const std::vector<wall::imaginary_copy<3>> c = copies_of<3>(x, L, w, &rep);
      REQUIRE(c.size() == 1);  // neighbouring triangles of the smooth wall are merged, never kept twice
      CHECK(rep.convex_duplicates_removed == 0);
      const double r_tri = (x - c[0].x).norm();  // the distance eq. (76) uses
      // σ = 1/R to 1e-13 on icospheres (docs/geometry.md), so eq. (76) holds to rounding with r_tri
      worst_exact = std::max(worst_exact, std::abs(c[0].L / (L / (1.0 - r_tri / R)) - 1.0));
      worst_sphere = std::max(worst_sphere, std::abs(c[0].L / (L / (1.0 - r / R)) - 1.0));
    }
    CHECK(worst_exact < 1e-10);
    // Against the true sphere: a flat triangle's plane lies `depth` = R − (plane distance from the
    // centre) inside it, so r_tri ∈ [r − depth, r] and 1/(1 − r/R) changes by ≤ (depth/R)/(1 − r/R)² to
    // first order; with r ≤ 0.9 L = 0.09 R the bound is depth_max/R/0.91² (depth_max = 0.0114 L: bound
    // 1.44e-3 with a 5 % margin for the second order; measured 1.19e-3 at the default seed).
    double depth_max = 0.0;
    for (index_t e = 0; e < w.size(); ++e)
      depth_max = std::max(depth_max, R - std::abs(w.element_normal(e).dot(w.element(e).col(0))));
    MESSAGE("deepest triangle plane: " << depth_max / L << " L");
    CHECK(worst_sphere < 1.05 * depth_max / R / (0.91 * 0.91));
    MESSAGE("max relative L' error: " << worst_exact << " (eq. 76 with the triangle distance), "
                                      << worst_sphere << " (true sphere)");
  }

  TEST_CASE("walls: 1 - r sigma below small_ratio gives L' = 2 L and a counted event") {
    const double L = 0.01, R = 1.5 * L;
    const polygon_set<2> w(geometry::circle(vec<2>(0, 0), R, 64, geometry::fluid_side::inside));
    const double phi = std::numbers::pi / 64.0;
    const double r = 0.9 * L;  // from the segment: 1 − r σ = 1 − 0.9/1.5 = 0.4 < 0.5
    const double rho = R * std::cos(phi) - r;
    const vec<2> x(rho * std::cos(phi), rho * std::sin(phi));
    wall::imaginary_report<2> rep;
    const std::vector<wall::imaginary_copy<2>> c = copies_of<2>(x, L, w, &rep);
    REQUIRE(c.size() == 1);
    CHECK(c[0].L == 2 * L);
    CHECK(rep.small_diameter_events == 1);
    // with small_ratio = 0.3 the same particle takes eq. (76): L/(1 − rσ), σ = 1/R to 1e-13
    wall::imaginary_params p;
    p.small_ratio = 0.3;
    const std::vector<wall::imaginary_copy<2>> c2 = copies_of<2>(x, L, w, &rep, p);
    REQUIRE(c2.size() == 1);
    CHECK(rep.small_diameter_events == 0);
    CHECK(std::abs(c2[0].L / (L / (1.0 - r / R)) - 1.0) < 1e-10);
  }

  TEST_CASE("walls: 3D box, copies per face, one per face across a triangle diagonal") {
    const double L = 0.05;
    const polygon_set<3> w(geometry::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geometry::fluid_side::inside));
    // floor only, including points exactly on both diagonals of the floor's two triangles
    const std::vector<double> s = {0.25, 0.3, 0.5, 0.5 + 1e-13, 0.5 - 1e-13, 0.7, 0.75};
    for (double a : s)
      for (double b : s) {
        CAPTURE(a);
        CAPTURE(b);
        wall::imaginary_report<3> rep;
        const std::vector<wall::imaginary_copy<3>> c = copies_of<3>(vec<3>(a, b, 0.3 * L), L, w, &rep);
        REQUIRE(c.size() == 1);
        CHECK(c[0].normal.isApprox(vec<3>(0, 0, 1), 1e-12));
        CHECK((c[0].x - vec<3>(a, b, 0)).norm() < 1e-15);
        CHECK(c[0].L == L);
        CHECK(rep.convex_duplicates_removed == 0);
        CHECK(off_element(w, c[0]) < 1e-15);
      }
    // next to the edge floor / x = 0 wall, across the floor triangle's diagonal region: 2 copies
    {
      wall::imaginary_report<3> rep;
      const std::vector<wall::imaginary_copy<3>> c = copies_of<3>(vec<3>(0.4 * L, 0.5, 0.3 * L), L, w, &rep);
      REQUIRE(c.size() == 2);
      CHECK(rep.convex_duplicates_removed == 0);
      std::set<int> axes;
      for (const auto& k : c) {
        CHECK(off_element(w, k) < 1e-15);
        for (int a = 0; a < 3; ++a)
          if (std::abs(k.normal[a] - 1.0) < 1e-12) axes.insert(a);
      }
      CHECK(axes == std::set<int>{0, 2});
    }
    // concave corner (0, 0, 0): one copy on each of the three faces
    {
      wall::imaginary_report<3> rep;
      const vec<3> x(0.4 * L, 0.5 * L, 0.3 * L);
      const std::vector<wall::imaginary_copy<3>> c = copies_of<3>(x, L, w, &rep);
      REQUIRE(c.size() == 3);
      CHECK(rep.convex_duplicates_removed == 0);
      std::set<int> axes;
      for (const auto& k : c) {
        CHECK(off_element(w, k) < 1e-15);
        for (int a = 0; a < 3; ++a)
          if (std::abs(k.normal[a] - 1.0) < 1e-12) {
            axes.insert(a);
            CHECK(std::abs(k.x[a]) < 1e-15);  // the foot: x with that coordinate set to 0
            vec<3> foot = x;
            foot[a] = 0.0;
            CHECK((k.x - foot).norm() < 1e-15);
          }
      }
      CHECK(axes == std::set<int>{0, 1, 2});
    }
  }

  TEST_CASE("walls: 3D convex box corner gives one copy and counts every other triangle there") {
    const double L = 0.05;
    const polygon_mesh<3> m = geometry::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geometry::fluid_side::outside);
    const polygon_set<3> w(m);
    const vec<3> q(1, 1, 1), x(1 + 0.3 * L, 1 + 0.4 * L, 1 + 0.2 * L);
    index_t around = 0;  // triangles touching the corner, from the connectivity
    for (index_t e = 0; e < m.size(); ++e)
      for (int k = 0; k < 3; ++k)
        if (m.vertices.col(m.elements(k, e)) == q) ++around;
    REQUIRE(around >= 3);
    wall::imaginary_report<3> rep;
    const std::vector<wall::imaginary_copy<3>> c = copies_of<3>(x, L, w, &rep);
    REQUIRE(c.size() == 1);
    CHECK((c[0].x - q).norm() < 1e-15);
    CHECK(c[0].normal.isApprox(((x - q) / (x - q).norm()).eval(), 1e-14));
    CHECK(rep.convex_duplicates_removed == around - 1);
    // next to the convex edge x = y = 1 (its Voronoi region): one copy on the edge, one duplicate
    const vec<3> xe(1 + 0.3 * L, 1 + 0.4 * L, 0.5);
    const std::vector<wall::imaginary_copy<3>> ce = copies_of<3>(xe, L, w, &rep);
    REQUIRE(ce.size() == 1);
    CHECK((ce[0].x - vec<3>(1, 1, 0.5)).norm() < 1e-14);
    CHECK(rep.convex_duplicates_removed == 1);
  }

  TEST_CASE("walls: a moving wall gives the copy its velocity") {
    const double L = 0.01;
    const vec<2> U(0.3, -0.2);
    polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)), {},
                     geometry::prescribed_motion<2>::translation(U));
    w.move_to(0.5);  // floor now at y = −0.1
    const std::vector<wall::imaginary_copy<2>> c = copies_of<2>(vec<2>(0.5, -0.1 + 0.3 * L), L, w);
    REQUIRE(c.size() == 1);
    CHECK(c[0].wall_velocity.isApprox(U, 1e-15));
    CHECK(std::abs(c[0].x.y() + 0.1) < 1e-15);
    // rotation about the origin: v = ω × (x' − c)
    const double omega = 2.0;
    polygon_set<2> rw(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)), {},
                      geometry::prescribed_motion<2>::rotation(vec<2>(0, 0), omega));
    const std::vector<wall::imaginary_copy<2>> cr = copies_of<2>(vec<2>(0.5, 0.3 * L), L, rw);
    REQUIRE(cr.size() == 1);
    CHECK(cr[0].wall_velocity.isApprox(vec<2>(-omega * cr[0].x.y(), omega * cr[0].x.x()), 1e-14));
  }

  TEST_CASE("walls: copies are deterministic and independent of exec; eligibility and sets respected") {
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    const double L = 0.02;
    geometry::wall_collection<2> walls;
    walls.add(polygon_set<2>(geometry::tank(vec<2>(0, 0), vec<2>(1, 1))));
    walls.add(polygon_set<2>(geometry::circle(vec<2>(0.5, 0.3), 0.1, 90, geometry::fluid_side::outside)));
    std::uniform_real_distribution<double> U(0.001, 0.999);
    const index_t n = 6000;
    points<2> x(2, n);
    for (index_t i = 0; i < n; ++i) x.col(i) = vec<2>(U(rng), U(rng));
    const Eigen::VectorXd Lv = Eigen::VectorXd::Constant(n, L);
    auto even = [](index_t i) { return i % 2 == 0; };
    std::vector<wall::imaginary_copy<2>> a, b, c;
    const wall::imaginary_report<2> ra = wall::make_imaginary<2>(x, Lv, n, even, walls, {}, a);
    wall::make_imaginary<2>(x, Lv, n, even, walls, {}, b);
    const wall::imaginary_report<2> rc = wall::make_imaginary<2>(exec::par{}, x, Lv, n, even, walls, {}, c);
    REQUIRE(a.size() == b.size());
    REQUIRE(a.size() == c.size());
    CHECK(ra.copies == static_cast<index_t>(a.size()));
    CHECK(rc.copies == ra.copies);
    CHECK(rc.wrong_side == ra.wrong_side);
    bool same = true, ordered = true, odd = false, both_sets[2] = {false, false};
    for (std::size_t k = 0; k < a.size(); ++k) {
      for (const auto* o : {&b[k], &c[k]})
        same = same && a[k].parent == o->parent && a[k].element == o->element && a[k].set == o->set &&
               a[k].x == o->x && a[k].normal == o->normal && a[k].L == o->L && a[k].weights == o->weights;
      if (k > 0)
        ordered =
            ordered &&
            (a[k - 1].parent < a[k].parent ||
             (a[k - 1].parent == a[k].parent &&
              (a[k - 1].set < a[k].set || (a[k - 1].set == a[k].set && a[k - 1].element < a[k].element))));
      odd = odd || a[k].parent % 2 == 1;
      both_sets[a[k].set] = true;
      // every copy lies on its element of its set, within α_w L of its parent
      CHECK(walls[a[k].set].closest_on(a[k].element, a[k].x).distance < 1e-15);
      CHECK((x.col(a[k].parent) - a[k].x).norm() < L);
    }
    CHECK(same);  // bitwise
    CHECK(ordered);
    CHECK_FALSE(odd);
    CHECK(both_sets[0]);
    CHECK(both_sets[1]);
    // every eligible particle within α_w L of a wall has at least one copy (none is missed)
    std::vector<int> has(static_cast<std::size_t>(n), 0);
    for (const auto& k : a) has[static_cast<std::size_t>(k.parent)] = 1;
    index_t missed = 0;
    for (index_t i = 0; i < n; i += 2) {
      const geometry::collection_point<2> q = walls.query(x.col(i), L);
      if (q.found() && q.distance < L && q.signed_distance >= 0.0 && !has[static_cast<std::size_t>(i)])
        ++missed;
    }
    CHECK(missed == 0);
  }

  TEST_CASE("walls: write_ghosts appends copies after the real particles") {
    const double L = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    points<2> x(2, 3);
    x << 0.5, 0.4 * L, 0.5, 0.3 * L, 0.5 * L, 0.5;
    Eigen::VectorXd Lv = Eigen::VectorXd::Constant(3, L);
    std::vector<wall::imaginary_copy<2>> c;
    wall::make_imaginary<2>(x, Lv, 3, all, w, {}, c);
    REQUIRE(c.size() == 3);  // floor below 0; corner pair for 1
    wall::write_ghosts<2>(c, 3, x, Lv);
    REQUIRE(x.cols() == 6);
    REQUIRE(Lv.size() == 6);
    CHECK(x(0, 0) == 0.5);
    for (std::size_t k = 0; k < c.size(); ++k) {
      CHECK(x.col(3 + static_cast<index_t>(k)) == c[k].x);
      CHECK(Lv[3 + static_cast<index_t>(k)] == c[k].L);
    }
  }

}

TEST_SUITE("crossing_guard") {
  TEST_CASE("walls: a particle shot through a floor is put back at eps L with u.n = 0") {
    const double L = 0.01, eps = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    points<2> x0(2, 2), x1(2, 2), u(2, 2);
    x0 << 0.5, 0.5, 0.2, 0.2 * L;
    x1 << 0.6, 0.7, -0.1, 0.2 * L;  // particle 1 moves parallel to the floor: untouched
    u << 1.0, 2.0, -3.0, 0.0;
    const Eigen::VectorXd Lv = Eigen::VectorXd::Constant(2, L);
    std::vector<flag::type> flags = {flag::surface, 0u};
    const points<2> x1_before = x1;
    const index_t n = wall::guard_crossings<2>(x0, x1, u, Lv, 2, w, wall::guard_params{eps}, &flags);
    CHECK(n == 1);
    // crossing at t = 0.2/0.3 on the segment (0.5,0.2)→(0.6,−0.1): x = 0.5 + 0.1·2/3; put back ε L above
    CHECK(std::abs(x1(0, 0) - (0.5 + 0.1 * 2.0 / 3.0)) < 1e-15);
    CHECK(std::abs(x1(1, 0) - eps * L) < 1e-15);
    CHECK(u(0, 0) == 1.0);  // tangential velocity kept
    CHECK(u(1, 0) == 0.0);  // normal velocity removed (fixed wall)
    CHECK(flags[0] == (flag::surface | flag::guarded));  // other bits kept
    CHECK(flags[1] == 0u);
    CHECK(x1.col(1) == x1_before.col(1));
    CHECK(u.col(1) == vec<2>(2.0, 0.0));
  }

  TEST_CASE("walls: a move ending exactly on the wall is guarded; a move leaving a solid is not") {
    const double L = 0.01, eps = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    points<2> x0(2, 2), x1(2, 2), u = points<2>::Zero(2, 2);
    x0 << 0.5, 0.3, 0.3, -0.01;
    x1 << 0.5, 0.3, 0.0, 0.01;  // 0 ends on the floor; 1 comes back from below (exits): let through
    u(1, 0) = -1.0;
    const Eigen::VectorXd Lv = Eigen::VectorXd::Constant(2, L);
    CHECK(wall::guard_crossings<2>(x0, x1, u, Lv, 2, w, wall::guard_params{eps}) == 1);
    CHECK((x1.col(0) - vec<2>(0.5, eps * L)).norm() < 1e-15);  // closed test: touching the wall counts
    CHECK(u(1, 0) == 0.0);
    CHECK(x1.col(1) == vec<2>(0.3, 0.01));
  }

  TEST_CASE("walls: guard on a moving wall keeps the wall's normal velocity") {
    const double L = 0.01, eps = 0.01;
    const vec<2> U(0.0, 1.0);
    polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)), {},
                     geometry::prescribed_motion<2>::translation(U));
    w.move_to(0.01);  // floor at y = 0.01
    points<2> x0(2, 1), x1(2, 1), u(2, 1);
    x0 << 0.5, 0.02;
    x1 << 0.5, 0.0;
    u << 0.5, -2.0;
    CHECK(wall::guard_crossings<2>(x0, x1, u, Eigen::VectorXd::Constant(1, L), 1, w,
                                   wall::guard_params{eps}) == 1);
    CHECK(std::abs(x1(1, 0) - (0.01 + eps * L)) < 1e-15);
    CHECK(u(0, 0) == 0.5);
    CHECK(u(1, 0) == 1.0);  // (u − v_w)·n = 0
  }

  TEST_CASE("walls: moving-wall guard catches a particle at rest swept by the wall") {
    const double L = 0.01, eps = 0.01;
    polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)), {},
                     geometry::prescribed_motion<2>::translation(vec<2>(0.0, 1.0)));
    const geometry::rigid_transform<2> before = w.pose();
    w.move_to(0.02);  // the floor rises from y = 0 to y = 0.02 past a particle at rest at y = 0.01
    points<2> x0(2, 1), x1(2, 1), u = points<2>::Zero(2, 1);
    x0 << 0.5, 0.01;
    x1 = x0;
    CHECK(wall::guard_crossings<2>(x0, x1, u, Eigen::VectorXd::Constant(1, L), 1, w,
                                   wall::guard_params{eps}) == 0);
    CHECK(wall::guard_crossings_moving<2>(exec::seq{}, x0, x1, u, Eigen::VectorXd::Constant(1, L), 1, w,
                                          before, wall::guard_params{eps}) == 1);
    CHECK(std::abs(x1(1, 0) - (0.02 + eps * L)) < 1e-15);
    CHECK(std::abs(u(1, 0) - 1.0) < 1e-15);
  }

  TEST_CASE("walls: a double-sided thin wall is guarded from both sides; a one-sided one from its front") {
    const double L = 0.01, eps = 0.01;
    const polygon_mesh<2> seg = polyline({vec<2>(0, 0), vec<2>(0, 1)});  // normal −x: fluid at x < 0
    const polygon_set<2> thin(wall::double_sided(seg));
    const polygon_set<2> front_only(seg);
    points<2> x0(2, 2), x1(2, 2), u(2, 2);
    x0 << -0.1, 0.1, 0.5, 0.4;
    x1 << 0.1, -0.1, 0.5, 0.4;
    u << 4.0, -4.0, 1.0, 1.0;
    const Eigen::VectorXd Lv = Eigen::VectorXd::Constant(2, L);
    points<2> y = x1, v = u;
    CHECK(wall::guard_crossings<2>(x0, y, v, Lv, 2, thin, wall::guard_params{eps}) == 2);
    CHECK((y.col(0) - vec<2>(-eps * L, 0.5)).norm() < 1e-15);  // back on its own side
    CHECK((y.col(1) - vec<2>(eps * L, 0.4)).norm() < 1e-15);
    CHECK(v.col(0) == vec<2>(0.0, 1.0));
    CHECK(v.col(1) == vec<2>(0.0, 1.0));
    y = x1;
    v = u;
    CHECK(wall::guard_crossings<2>(x0, y, v, Lv, 2, front_only, wall::guard_params{eps}) == 1);
    CHECK((y.col(0) - vec<2>(-eps * L, 0.5)).norm() < 1e-15);
    CHECK(y.col(1) == x1.col(1));  // from behind: the exit path of a one-sided wall
  }

  TEST_CASE("walls: guard falls back to the start point in a corner narrower than eps L") {
    const double L = 0.01, eps = 0.5;
    // narrow V valley, apex at the origin, half-angle 10°, fluid inside (above the apex)
    const double t = std::tan(10.0 * std::numbers::pi / 180.0);
    const polygon_set<2> w(polyline({vec<2>(-t, 1), vec<2>(0, 0), vec<2>(t, 1)}));
    points<2> x0(2, 1), x1(2, 1), u(2, 1);
    x0 << 0.0, 0.2 * L;
    x1 << 0.0, -0.2 * L;  // through the apex
    u << 0.0, -1.0;
    CHECK(wall::guard_crossings<2>(x0, x1, u, Eigen::VectorXd::Constant(1, L), 1, w,
                                   wall::guard_params{eps}) == 1);
    CHECK(x1.col(0) == x0.col(0));
    CHECK(w.signed_distance(x1.col(0)) > 0.0);
  }

  TEST_CASE("walls: 3D guard through a box floor (across a triangle diagonal)") {
    const double L = 0.05, eps = 0.01;
    const polygon_set<3> w(geometry::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geometry::fluid_side::inside));
    points<3> x0(3, 2), x1(3, 2), u(3, 2);
    x0.col(0) = vec<3>(0.5, 0.5, 0.01);
    x1.col(0) = vec<3>(0.5, 0.5, -0.01);  // exactly through the floor's diagonal
    x0.col(1) = vec<3>(0.3, 0.6, 0.02);
    x1.col(1) = vec<3>(0.35, 0.6, 0.02);
    u.col(0) = vec<3>(0.1, 0.2, -1.0);
    u.col(1) = vec<3>(1.0, 0.0, 0.0);
    CHECK(wall::guard_crossings<3>(exec::par{}, x0, x1, u, Eigen::VectorXd::Constant(2, L), 2, w,
                                   wall::guard_params{eps}) == 1);
    CHECK((x1.col(0) - vec<3>(0.5, 0.5, eps * L)).norm() < 1e-15);
    CHECK(u.col(0) == vec<3>(0.1, 0.2, 0.0));
    CHECK(x1.col(1) == vec<3>(0.35, 0.6, 0.02));
  }

}

namespace {
// Stored rows as sets.
template <int D>
std::vector<std::set<index_t>> rows(const search::neighbour_list<D>& nl) {
  std::vector<std::set<index_t>> r(static_cast<std::size_t>(nl.rows()));
  for (index_t i = 0; i < nl.rows(); ++i)
    for (auto j : nl.neighbours(i)) r[static_cast<std::size_t>(i)].insert(j);
  return r;
}
}  // namespace

TEST_SUITE("thin_walls") {
  TEST_CASE("walls: particles on either side of a zero-thickness wall are not neighbours") {
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> J(-0.2, 0.2);
    const double L = 0.01;
    // wall x = 0, y in [0, 1]; lattice x = (k + ½ + jitter) L on both sides, y in [0.3, 0.7]
    const polygon_set<2> w(polyline({vec<2>(0, 0), vec<2>(0, 1)}));
    std::vector<vec<2>> p;
    for (int a = -8; a < 8; ++a)
      for (int b = 30; b < 70; ++b) p.push_back(vec<2>((a + 0.5 + J(rng)) * L, (b + J(rng)) * L));
    points<2> x(2, static_cast<index_t>(p.size()));
    for (std::size_t i = 0; i < p.size(); ++i) x.col(static_cast<index_t>(i)) = p[i];
    const Eigen::VectorXd Lv = Eigen::VectorXd::Constant(x.cols(), L);
    const search::per_particle_radius R{&Lv, 3.1};
    wall::wall_visibility<2> vis{&w, &x, x.cols()};
    search::neighbour_list<2> plain, seen, seen_fast;
    plain.build(exec::seq{}, x, R);
    seen.build(exec::seq{}, x, R, {}, vis);
    vis.prepare(exec::seq{}, 3.1 * L);
    seen_fast.build(exec::seq{}, x, R, {}, vis);
    const auto rp = rows(plain), rs = rows(seen), rf = rows(seen_fast);
    index_t across = 0, same = 0;
    bool exact = true;
    for (index_t i = 0; i < x.cols(); ++i)
      for (index_t j : rp[static_cast<std::size_t>(i)]) {
        const bool same_side = (x(0, i) < 0.0) == (x(0, j) < 0.0);
        (same_side ? same : across) += 1;
        exact = exact && (rs[static_cast<std::size_t>(i)].count(j) == (same_side ? 1u : 0u));
      }
    CHECK(across > 0);  // the plain list does hold pairs across the wall: the test can fail
    CHECK(same > 0);
    CHECK(exact);     // visible ⇔ same side (the wall spans every segment between the sides)
    CHECK(rs == rf);  // the clearance shortcut changes nothing
  }

  TEST_CASE("walls: copies see their side of a double-sided thin wall, not the other") {
    const double L = 0.01;
    const polygon_set<2> w(wall::double_sided(polyline({vec<2>(0, 0), vec<2>(0, 1)})));
    // two particles each side near the wall, plus one further away on the left
    points<2> x(2, 5);
    x << -0.4 * L, -0.4 * L, 0.3 * L, 0.3 * L, -2.0 * L,  //
        0.50, 0.50 + L, 0.50, 0.50 + 0.5 * L, 0.51;
    Eigen::VectorXd Lv = Eigen::VectorXd::Constant(5, L);
    std::vector<wall::imaginary_copy<2>> c;
    wall::make_imaginary<2>(x, Lv, 5, all, w, {}, c);
    REQUIRE(c.size() == 4);  // one per particle within α_w L, on its own side
    for (const auto& k : c) CHECK(k.normal.x() == (x(0, k.parent) < 0 ? -1.0 : 1.0));
    const index_t n_real = 5;
    wall::write_ghosts<2>(c, n_real, x, Lv);
    wall::wall_visibility<2> vis{&w, &x, n_real, &c};
    vis.prepare(exec::seq{}, 3.1 * 2 * L);
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::per_particle_radius{&Lv, 3.1}, {}, vis);
    const auto r = rows(nl);
    auto left = [&](index_t i) {
      return i < n_real ? x(0, i) < 0 : c[static_cast<std::size_t>(i - n_real)].normal.x() < 0;
    };
    index_t checked = 0;
    for (index_t i = 0; i < x.cols(); ++i)
      for (index_t j = 0; j < x.cols(); ++j) {
        if (i == j || (x.col(i) - x.col(j)).norm() >= 3.1 * L) continue;
        CAPTURE(i);
        CAPTURE(j);
        CHECK(r[static_cast<std::size_t>(i)].count(j) == (left(i) == left(j) ? 1u : 0u));
        ++checked;
      }
    CHECK(checked > 20);
    for (std::size_t k = 0; k < c.size(); ++k)  // a copy and its parent
      CHECK(r[static_cast<std::size_t>(n_real) + k].count(c[k].parent) == 1u);
  }

  TEST_CASE("walls: copies on one flat wall and at a concave corner see each other and their parents") {
    const double L = 0.01;
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    points<2> x(2, 4);
    x << 0.4 * L, 1.5 * L, 2.5 * L, 0.3 * L,  //
        0.5 * L, 0.5 * L, 0.2 * L, 1.5 * L;
    Eigen::VectorXd Lv = Eigen::VectorXd::Constant(4, L);
    std::vector<wall::imaginary_copy<2>> c;
    wall::make_imaginary<2>(x, Lv, 4, all, w, {}, c);
    REQUIRE(c.size() == 5);  // 2 (corner) + 1 + 1 + 1 (0.3 L from the side wall, 1.5 L > L from the floor)
    const index_t n_real = 4;
    wall::write_ghosts<2>(c, n_real, x, Lv);
    wall::wall_visibility<2> vis{&w, &x, n_real, &c};
    vis.prepare(exec::seq{}, 3.1 * L);
    search::neighbour_list<2> plain, nl;
    plain.build(exec::seq{}, x, search::per_particle_radius{&Lv, 3.1});
    nl.build(exec::seq{}, x, search::per_particle_radius{&Lv, 3.1}, {}, vis);
    CHECK(rows(plain) == rows(nl));  // nothing here is hidden by a wall
  }

  TEST_CASE("walls: visibility across a periodic seam uses the minimum image") {
    // wall x = 0.5 across the whole height; particles either side of the periodic seam x = 0 ≡ 1
    const polygon_set<2> w(polyline({vec<2>(0.5, -1), vec<2>(0.5, 2)}));
    points<2> x(2, 4);
    x << 0.005, 0.995, 0.3, 0.7,  //
        0.5, 0.5, 0.5, 0.5;
    search::domain<2> dom;
    dom.periodic = {true, false};
    dom.lo << 0.0, 0.0;
    dom.hi << 1.0, 0.0;
    wall::wall_visibility<2> plain{&w, &x, 4}, periodic{&w, &x, 4, nullptr, &dom};
    CHECK_FALSE(plain(0, 1));  // the straight segment 0.005 → 0.995 crosses the wall
    CHECK(periodic(0, 1));     // the minimum image (0.01 long, through the seam) does not
    CHECK(periodic(1, 0));
    CHECK(periodic(1, 2));        // 0.995 → 0.3: the image through the seam (0.305) is shorter
    CHECK_FALSE(plain(1, 2));
    CHECK_FALSE(periodic(2, 3));  // 0.3 → 0.7: the direct segment (0.4) is the image, through the wall
    CHECK_FALSE(periodic(3, 2));
    // a second wall at x = 0.1 is met by the seam route 0.995 → 1.3 (≡ 0.3) on j's side only
    geometry::wall_collection<2> two;
    two.add(polygon_set<2>(polyline({vec<2>(0.5, -1), vec<2>(0.5, 2)})));
    two.add(polygon_set<2>(polyline({vec<2>(0.1, -1), vec<2>(0.1, 2)})));
    wall::wall_visibility<2, geometry::wall_collection<2>> p2{&two, &x, 4, nullptr, &dom};
    CHECK(p2(0, 1));  // 0.995 → 1.005 ≡ 0.005: neither wall
    CHECK_FALSE(p2(1, 2));
    CHECK_FALSE(p2(2, 1));
    p2.prepare(exec::seq{}, 1.0);  // clearances 0.495 + 0.2 > 0.305 must not skip the image pair
    CHECK_FALSE(p2(1, 2));
    CHECK(p2(0, 1));
  }

  TEST_CASE_TEMPLATE("walls: the convex shortcut gives the segment test's answer for every pair", T,
                     std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
    // wall_visibility's convex shortcut (both ends strictly inside a convex set: visible without the segment
    // test) against the segment test itself (polygon_set::crosses on the pulled ends) for every pair of a
    // jittered cloud with its copies: particles near the walls, some beyond them (the crossing guard would
    // put those back), copies at the concave corners. Non-convex sets (a 2D floor with a step, a 3D tank with
    // a block on the floor) must not take the shortcut.
    constexpr int D = T::value;
    const double L = 0.02;
    const polygon_set<D> tank = [] {
      if constexpr (D == 2) return polygon_set<2>(geometry::tank(vec<2>(0, 0), vec<2>(0.3, 0.25)));
      else return polygon_set<3>(geometry::tank(vec<3>(0, 0, 0), vec<3>(0.2, 0.15, 0.2)));
    }();
    std::mt19937_64 rng(test_seed());
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    points<D> x(D, 400);
    for (index_t i = 0; i < x.cols(); ++i)
      for (int a = 0; a < D; ++a) {
        const double hi = D == 2 ? (a == 0 ? 0.3 : 0.25) : (a == 1 ? 0.15 : 0.2);
        x(a, i) = -0.05 * L + u01(rng) * (hi + 0.1 * L);  // a few just beyond a wall
      }
    Eigen::VectorXd Lv = Eigen::VectorXd::Constant(x.cols(), L);
    const index_t n_real = x.cols();
    std::vector<wall::imaginary_copy<D>> c;
    wall::make_imaginary<D>(x, Lv, n_real, all, tank, {}, c);
    REQUIRE(c.size() > 50);
    wall::write_ghosts<D>(c, n_real, x, Lv);
    wall::wall_visibility<D> vis{&tank, &x, n_real, &c};
    vis.prepare(exec::seq{}, 3.1 * L);
    CHECK(tank.convex());
    REQUIRE(vis.inside.size() == static_cast<std::size_t>(x.cols()));  // a tank is convex: the shortcut is on
    wall::wall_visibility<D> exact = vis;
    exact.clearance.clear();
    exact.inside.clear();  // the segment test alone
    const auto end = [&](index_t k) {
      return k < n_real ? vec<D>(x.col(k))
                        : vec<D>(x.col(k) + vis.pull * c[static_cast<std::size_t>(k - n_real)].L *
                                                c[static_cast<std::size_t>(k - n_real)].normal);
    };
    long pairs = 0, by_shortcut = 0, hidden = 0, differ = 0;
    for (index_t i = 0; i < x.cols(); ++i)
      for (index_t j = i + 1; j < x.cols(); ++j) {
        if ((x.col(i) - x.col(j)).norm() >= 3.1 * L) continue;
        ++pairs;
        const bool v = vis(i, j), e = exact(i, j);
        CHECK(e == !tank.crosses(end(i), end(j)));  // exact is the segment test
        if (vis.inside[static_cast<std::size_t>(i)] && vis.inside[static_cast<std::size_t>(j)]) ++by_shortcut;
        if (!e) ++hidden;
        if (v != e) ++differ;
      }
    MESSAGE(D << "D: " << pairs << " pairs, " << by_shortcut << " by the shortcut, " << hidden << " hidden");
    CHECK(differ == 0);
    CHECK(by_shortcut > pairs / 2);  // the shortcut does the work ...
    CHECK(hidden > 0);               // ... and the cloud has pairs the walls hide (ends outside the tank)
    // Not convex: the shortcut stays off.
    if constexpr (D == 2) {
      const polygon_set<2> step(polyline({vec<2>(0.0, 1.0), vec<2>(0.0, 0.0), vec<2>(0.5, 0.0),
                                          vec<2>(0.5, 0.1), vec<2>(1.0, 0.1), vec<2>(1.0, 1.0)}));
      CHECK_FALSE(step.convex());
      wall::wall_visibility<2> vs{&step, &x, n_real, &c};
      vs.prepare(exec::seq{}, 3.1 * L);
      CHECK(vs.inside.empty());
    } else {
      polygon_mesh<3> m = geometry::tank(vec<3>(0, 0, 0), vec<3>(0.2, 0.15, 0.2));
      polygon_mesh<3> flipped = geometry::box(vec<3>(0.05, 0.05, 0.0), vec<3>(0.1, 0.1, 0.05),
                                              geometry::fluid_side::outside);
      const index_t nv = m.vertices.cols(), ne = m.elements.cols();
      m.vertices.conservativeResize(3, nv + flipped.vertices.cols());
      m.vertices.rightCols(flipped.vertices.cols()) = flipped.vertices;
      m.elements.conservativeResize(3, ne + flipped.elements.cols());
      m.elements.rightCols(flipped.elements.cols()) = flipped.elements.array() + nv;
      const polygon_set<3> with_block(m);
      CHECK_FALSE(with_block.convex());
      wall::wall_visibility<3> vs{&with_block, &x, n_real, &c};
      vs.prepare(exec::seq{}, 3.1 * L);
      CHECK(vs.inside.empty());  // a block on the floor: the tank's corners lie behind its faces
    }
  }

  TEST_CASE("walls: 3D double-sided plate hides the other side") {
    const double L = 0.05;
    polygon_mesh<3> plate;
    plate.vertices.resize(3, 4);
    plate.vertices << 0.5, 0.5, 0.5, 0.5,  //
        0, 1, 1, 0,                        //
        0, 0, 1, 1;
    plate.elements.resize(3, 2);
    plate.elements << 0, 0, 1, 2, 2, 3;
    const polygon_set<3> w(wall::double_sided(plate));
    std::vector<vec<3>> p;
    for (int a = -3; a < 3; ++a)
      for (int b = 6; b < 14; ++b)
        for (int d = 6; d < 14; ++d) p.push_back(vec<3>(0.5 + (a + 0.5) * L, b * L, d * L));
    points<3> x(3, static_cast<index_t>(p.size()));
    for (std::size_t i = 0; i < p.size(); ++i) x.col(static_cast<index_t>(i)) = p[i];
    Eigen::VectorXd Lv = Eigen::VectorXd::Constant(x.cols(), L);
    const index_t n_real = x.cols();
    std::vector<wall::imaginary_copy<3>> c;
    wall::make_imaginary<3>(x, Lv, n_real, all, w, {}, c);
    CHECK(c.size() == 2 * 8 * 8);  // the two layers next to the plate
    wall::write_ghosts<3>(c, n_real, x, Lv);
    wall::wall_visibility<3> vis{&w, &x, n_real, &c};
    vis.prepare(exec::seq{}, 3.1 * L);
    search::neighbour_list<3> nl;
    nl.build(exec::seq{}, x, search::per_particle_radius{&Lv, 3.1}, {}, vis);
    auto side = [&](index_t i) {
      return i < n_real ? x(0, i) < 0.5 : c[static_cast<std::size_t>(i - n_real)].normal.x() < 0;
    };
    bool exact = true;
    index_t pairs = 0;
    const auto r = rows(nl);
    for (index_t i = 0; i < x.cols(); ++i)
      for (index_t j = 0; j < x.cols(); ++j) {
        if (i == j || (x.col(i) - x.col(j)).norm() >= 3.1 * L) continue;
        exact = exact && (r[static_cast<std::size_t>(i)].count(j) == (side(i) == side(j) ? 1u : 0u));
        ++pairs;
      }
    CHECK(pairs > 1000);
    CHECK(exact);
  }
}

TEST_SUITE("bad_input") {
  TEST_CASE("walls: bad imaginary parameters and diameters are refused with their range") {
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    std::vector<wall::imaginary_copy<2>> out;
    const points<2> x = one<2>(vec<2>(0.5, 0.001));
    wall::imaginary_params p;
    p.alpha_w = 0.0;
    CHECK_THROWS_WITH_AS(wall::make_imaginary<2>(x, Eigen::VectorXd::Constant(1, 0.01), 1, all, w, p, out),
                         doctest::Contains("alpha_w = 0, accepted range (0, inf)"), mpskit::error);
    p = {};
    p.small_ratio = 1.5;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("small_ratio"), mpskit::error);
    p = {};
    p.merge_angle_deg = -1;
    CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("merge_angle_deg"), mpskit::error);
    CHECK_THROWS_WITH_AS(wall::make_imaginary<2>(x, Eigen::VectorXd::Constant(1, -0.01), 1, all, w, {}, out),
                         doctest::Contains("particle 0 has diameter L = -0.01"), mpskit::error);
    CHECK_THROWS_WITH_AS(wall::make_imaginary<2>(x, Eigen::VectorXd::Constant(1, 0.01), 2, all, w, {}, out),
                         doctest::Contains("n_real = 2"), mpskit::error);
  }

  TEST_CASE("walls: bad guard input is refused with its range") {
    const polygon_set<2> w(geometry::tank(vec<2>(0, 0), vec<2>(1, 1)));
    points<2> x0 = points<2>::Zero(2, 1), x1 = points<2>::Zero(2, 1), u = points<2>::Zero(2, 1);
    CHECK_THROWS_WITH_AS(wall::guard_crossings<2>(x0, x1, u, Eigen::VectorXd::Constant(1, 0.01), 1, w,
                                                  wall::guard_params{0.0}),
                         doctest::Contains("epsilon = 0, accepted range (0, 1)"), mpskit::error);
    CHECK_THROWS_WITH_AS(wall::guard_crossings<2>(x0, x1, u, Eigen::VectorXd::Constant(1, 0.0), 1, w, {}),
                         doctest::Contains("particle 0 has diameter L = 0"), mpskit::error);
    std::vector<flag::type> flags;
    CHECK_THROWS_WITH_AS(
        wall::guard_crossings<2>(x0, x1, u, Eigen::VectorXd::Constant(1, 0.01), 1, w, {}, &flags),
        doctest::Contains("flags has 0 entries"), mpskit::error);
  }
}

TEST_SUITE("walls_threads") {
  TEST_CASE("walls: copies, guard and visible lists are identical for 1 and 2 threads") {
#ifdef _OPENMP
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed + 1);
    const double L = 0.01;
    geometry::wall_collection<2> walls;
    walls.add(polygon_set<2>(geometry::tank(vec<2>(0, 0), vec<2>(1, 1), 8)));
    walls.add(polygon_set<2>(wall::double_sided(polyline({vec<2>(0.5, 0.0), vec<2>(0.5, 0.6)}))));
    std::uniform_real_distribution<double> U(0.001, 0.999);
    std::normal_distribution<double> G(0.0, 0.5 * L);
    const index_t n = 12000;  // > parallel_min_items: exec::par really runs on two threads
    points<2> x(2, n);
    for (index_t i = 0; i < n; ++i) x.col(i) = vec<2>(U(rng), U(rng));
    Eigen::VectorXd Lv = Eigen::VectorXd::Constant(n, L);
    std::vector<wall::imaginary_copy<2>> c1, c2;
    omp_set_num_threads(1);
    wall::make_imaginary<2>(exec::par{}, x, Lv, n, all, walls, {}, c1);
    omp_set_num_threads(2);
    wall::make_imaginary<2>(exec::par{}, x, Lv, n, all, walls, {}, c2);
    REQUIRE(c1.size() == c2.size());
    bool same = true;
    for (std::size_t k = 0; k < c1.size(); ++k)
      same = same && c1[k].parent == c2[k].parent && c1[k].element == c2[k].element &&
             c1[k].set == c2[k].set && c1[k].x == c2[k].x && c1[k].normal == c2[k].normal &&
             c1[k].L == c2[k].L;
    CHECK(same);
    // guard: random moves of ~0.5 L, some through the tank walls and the baffle
    points<2> x1 = x;
    for (index_t i = 0; i < n; ++i) x1.col(i) += vec<2>(G(rng), G(rng));
    points<2> y1 = x1, y2 = x1, u1 = points<2>::Ones(2, n), u2 = points<2>::Ones(2, n);
    std::vector<flag::type> f1(static_cast<std::size_t>(n), 0u), f2 = f1;
    omp_set_num_threads(1);
    const index_t g1 = wall::guard_crossings<2>(exec::par{}, x, y1, u1, Lv, n, walls, {}, &f1);
    omp_set_num_threads(2);
    const index_t g2 = wall::guard_crossings<2>(exec::par{}, x, y2, u2, Lv, n, walls, {}, &f2);
    CHECK(g1 > 0);
    CHECK(g1 == g2);
    CHECK(y1 == y2);
    CHECK(u1 == u2);
    CHECK(f1 == f2);
    // visible lists over real + copies
    wall::write_ghosts<2>(c1, n, x, Lv);
    wall::wall_visibility<2, geometry::wall_collection<2>> v1{&walls, &x, n, &c1}, v2{&walls, &x, n, &c1};
    search::neighbour_list<2> a, b;
    omp_set_num_threads(1);
    v1.prepare(exec::par{}, 3.1 * L);
    a.build(exec::par{}, x, search::per_particle_radius{&Lv, 3.1}, {}, v1);
    omp_set_num_threads(2);
    v2.prepare(exec::par{}, 3.1 * L);
    b.build(exec::par{}, x, search::per_particle_radius{&Lv, 3.1}, {}, v2);
    CHECK(v1.clearance == v2.clearance);
    CHECK(a.offsets() == b.offsets());
    CHECK(a.indices() == b.indices());
#else
    MESSAGE("built without OpenMP: nothing to compare");
#endif
  }
}
