// Tests of the geometry area (issue 6): polygon sets, closest points, signed distance, curvature,
// motion, segment crossing, readers/writers, generators. Label: geometry.
// Random queries use a seed printed with each case; set MPSKIT_SEED to reproduce or vary it.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "mpskit/geometry/concepts.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/obj.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/polyline_io.hpp"
#include "mpskit/geometry/stl.hpp"
#include "mpskit/geometry/wall_collection.hpp"

#ifndef MPSKIT_TEST_DATA_DIR
#define MPSKIT_TEST_DATA_DIR "tests/data"
#endif

namespace geo = mpskit::geometry;
using mpskit::index_t;
using mpskit::vec;

namespace {

std::uint64_t test_seed() {
  const char* s = std::getenv("MPSKIT_SEED");
  return s ? std::strtoull(s, nullptr, 10) : 20260611ull;
}

std::string data(const std::string& name) { return std::string(MPSKIT_TEST_DATA_DIR) + "/geometry/" + name; }

std::filesystem::path temp_dir() {
  const std::filesystem::path p = std::filesystem::temp_directory_path() / "mpskit_test_geometry";
  std::filesystem::create_directories(p);
  return p;
}

std::string write_temp(const std::string& name, const std::string& content) {
  const std::string p = (temp_dir() / name).string();
  std::ofstream(p, std::ios::binary) << content;
  return p;
}

/// The message of the mpskit::error thrown by f ("" if none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const mpskit::error& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

template <int D>
vec<D> uniform_point(std::mt19937_64& rng, const vec<D>& lo, const vec<D>& hi) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  vec<D> p;
  for (int k = 0; k < D; ++k) p[k] = lo[k] + (hi[k] - lo[k]) * u(rng);
  return p;
}

/// Independent inside test, 2D: crossing number over the segments (Jordan curve theorem).
bool inside_2d(const geo::polygon_mesh<2>& m, const vec<2>& p) {
  bool in = false;
  for (index_t e = 0; e < m.size(); ++e) {
    const vec<2> a = m.vertices.col(m.elements(0, e)), b = m.vertices.col(m.elements(1, e));
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (p.x() < x) in = !in;
    }
  }
  return in;
}

/// Independent inside test, 3D: generalised winding number, solid angles by Van Oosterom & Strackee
/// (IEEE TBME 1983): ≈ +1 inside an outward-oriented closed mesh, 0 outside.
double winding_3d(const geo::polygon_mesh<3>& m, const vec<3>& p) {
  double w = 0.0;
  for (index_t e = 0; e < m.size(); ++e) {
    const vec<3> a = m.vertices.col(m.elements(0, e)) - p, b = m.vertices.col(m.elements(1, e)) - p,
                 c = m.vertices.col(m.elements(2, e)) - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(geo::detail::cross3(b, c));
    const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    w += 2.0 * std::atan2(num, den);
  }
  return w / (4.0 * std::numbers::pi);
}

/// Compares the hierarchy's closest point with brute force on random queries in a box.
template <int D>
void check_closest_against_brute_force(const geo::polygon_set<D>& s, const vec<D>& lo, const vec<D>& hi,
                                       int n, std::mt19937_64& rng) {
  const double tol = 1e-12 * s.scale();  // both evaluate the same per-element kernel: rounding only
  for (int i = 0; i < n; ++i) {
    const vec<D> x = uniform_point<D>(rng, lo, hi);
    const geo::closest_point<D> a = s.closest(x), b = s.closest_brute_force(x);
    CAPTURE(i);
    REQUIRE(a.found());
    CHECK(std::abs(a.distance - b.distance) <= tol);
    CHECK((a.point - b.point).norm() <= 1e-9 * s.scale());  // equal unless two elements tie at rounding level
    // barycentric weights reproduce the point and sum to 1
    CHECK(std::abs(a.weights.sum() - 1.0) <= 1e-12);
    CHECK((s.element(a.element) * a.weights - a.point).norm() <= 1e-12 * s.scale());
    CHECK(a.weights.minCoeff() >= 0.0);
  }
}

}  // namespace

// Archetype: the least a type must offer to model WallGeometry (kept here: tests/archetypes is the
// lead's file).
namespace geometry_archetypes {
struct wall_result {
  bool found() const { return false; }
  vec<2> point, normal, velocity;
  double signed_distance = 0, curvature = 0;
  index_t element = 0;
};
struct wall {
  static constexpr int dimension = 2;
  using vector_type = vec<2>;
  wall_result query(const vec<2>&, double) const { return {}; }
  bool crosses(const vec<2>&, const vec<2>&) const { return false; }
  std::optional<int> first_crossing(const vec<2>&, const vec<2>&) const { return std::nullopt; }
  double signed_distance(const vec<2>&) const { return 0; }
  vec<2> velocity(const vec<2>&) const { return vec<2>::Zero(); }
  void move_to(double) {}
};
}  // namespace geometry_archetypes

static_assert(geo::WallGeometry<geo::polygon_set<2>>);
static_assert(geo::WallGeometry<geo::polygon_set<3>>);
static_assert(geo::WallGeometry<geo::wall_collection<2>>);
static_assert(geo::WallGeometry<geo::wall_collection<3>>);
static_assert(geo::WallGeometry<geometry_archetypes::wall>);
static_assert(!geo::WallGeometry<int>);

TEST_SUITE("geometry") {
  TEST_CASE("geometry: closest point matches brute force in 2D (convex and concave corners)") {
    const std::uint64_t seed = test_seed();
    MESSAGE("seed = " << seed << " (MPSKIT_SEED)");
    std::mt19937_64 rng(seed);
    // gear: concave root corners and convex tip corners; tank: open polyline
    const geo::polygon_set<2> gear(
        geo::gear(vec<2>(0.1, -0.2), 2.0, 1.5, 17, geo::fluid_side::outside, 0.3, 3));
    check_closest_against_brute_force<2>(gear, vec<2>(-1.5, -1.7), vec<2>(1.7, 1.3), 4000, rng);
    const geo::polygon_set<2> tank(geo::tank(vec<2>(0, 0), vec<2>(1.0, 0.6), 7));
    check_closest_against_brute_force<2>(tank, vec<2>(-0.3, -0.3), vec<2>(1.3, 0.9), 2000, rng);
  }

  TEST_CASE("geometry: closest point matches brute force in 3D (box, gear, sphere)") {
    const std::uint64_t seed = test_seed() + 1;
    MESSAGE("seed = " << seed);
    std::mt19937_64 rng(seed);
    const geo::polygon_set<3> box(geo::box(vec<3>(0, 0, 0), vec<3>(1, 2, 0.5), geo::fluid_side::inside, 3));
    check_closest_against_brute_force<3>(box, vec<3>(-0.5, -0.5, -0.5), vec<3>(1.5, 2.5, 1.0), 2000, rng);
    const geo::polygon_set<3> gear(geo::gear(vec<3>(0, 0, 0), 2.0, 1.6, 11, 0.4));
    check_closest_against_brute_force<3>(gear, vec<3>(-1.3, -1.3, -0.3), vec<3>(1.3, 1.3, 0.7), 2000, rng);
    const geo::polygon_set<3> ball(geo::sphere(vec<3>(0.2, 0, 0), 0.7, 3, geo::fluid_side::outside));
    check_closest_against_brute_force<3>(ball, vec<3>(-1, -1, -1), vec<3>(1, 1, 1), 1000, rng);
  }

  TEST_CASE("geometry: points on the medial axis get the true distance and a consistent sign") {
    // Box [0,1]^3, fluid inside: on the diagonal planes through the centre, several faces are equally
    // near; the distance is min(x, 1 - x, ...) analytically and the point must be inside (d > 0).
    const geo::polygon_set<3> box(geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::inside, 2));
    for (double t : {0.05, 0.2, 0.37, 0.5}) {
      for (const vec<3>& x :
           {vec<3>(t, t, 0.5), vec<3>(t, t, t), vec<3>(0.5, 0.5, 0.5), vec<3>(1 - t, t, 0.3)}) {
        CAPTURE(x.transpose());
        const double exact = std::min({x.x(), x.y(), x.z(), 1 - x.x(), 1 - x.y(), 1 - x.z()});
        // analytic reference; rounding of a few flops on O(1) numbers
        CHECK(box.signed_distance(x) == doctest::Approx(exact).epsilon(1e-12));
        const geo::wall_point<3> w = box.query(x);
        CHECK((x - w.point - w.signed_distance * w.normal).norm() <= 1e-12);  // eq. (75) identity
      }
    }
    // 2D square, fluid outside: points on the outward diagonals of the corners (closest = the corner
    // vertex; the pseudo-normal there must give "outside").
    const geo::polygon_set<2> sq(geo::rectangle(vec<2>(0, 0), vec<2>(1, 1), geo::fluid_side::outside));
    for (double t : {0.01, 0.3, 2.0}) {
      const vec<2> x(1 + t, 1 + t);
      const geo::wall_point<2> w = sq.query(x);
      CHECK(w.kind == geo::feature_kind::vertex);
      CHECK(w.signed_distance == doctest::Approx(std::sqrt(2.0) * t).epsilon(1e-12));
      CHECK(sq.signed_distance(vec<2>(0.5, 0.5 - 0.1 * t)) < 0.0);  // inside the solid: negative
    }
  }

  TEST_CASE("geometry: signed distance sign matches an independent inside test") {
    const std::uint64_t seed = test_seed() + 2;
    MESSAGE("seed = " << seed);
    std::mt19937_64 rng(seed);
    {  // 2D gear with fluid outside: positive outside the gear outline
      const geo::polygon_mesh<2> m = geo::gear(vec<2>(0, 0), 2.0, 1.4, 9, geo::fluid_side::outside, 0.1, 2);
      const geo::polygon_set<2> s(m);
      int checked = 0;
      for (int i = 0; i < 5000; ++i) {
        const vec<2> x = uniform_point<2>(rng, vec<2>(-1.2, -1.2), vec<2>(1.2, 1.2));
        const geo::closest_point<2> c = s.closest(x);
        if (c.distance < 1e-9) continue;  // on the wall the sign is a convention
        ++checked;
        CAPTURE(x.transpose());
        CHECK((s.signed_distance(x) > 0.0) == !inside_2d(m, x));
      }
      CHECK(checked > 4900);
    }
    {  // 3D gear (concave root edges) and box with fluid inside
      const geo::polygon_mesh<3> g =
          geo::gear(vec<3>(0, 0, 0), 2.0, 1.5, 8, 0.5, geo::fluid_side::outside, 0.2);
      const geo::polygon_set<3> s(g);
      for (int i = 0; i < 600; ++i) {
        const vec<3> x = uniform_point<3>(rng, vec<3>(-1.1, -1.1, -0.2), vec<3>(1.1, 1.1, 0.7));
        if (s.closest(x).distance < 1e-9) continue;
        const double w = winding_3d(g, x);  // outward mesh: 1 inside the solid, 0 outside
        CAPTURE(x.transpose());
        REQUIRE(std::min(std::abs(w), std::abs(w - 1.0)) < 1e-6);  // a closed mesh gives an integer
        CHECK((s.signed_distance(x) > 0.0) == (w < 0.5));
      }
      const geo::polygon_mesh<3> b =
          geo::box(vec<3>(-1, -1, -1), vec<3>(1, 1, 1), geo::fluid_side::inside, 2);
      const geo::polygon_set<3> sb(b);
      for (int i = 0; i < 600; ++i) {
        const vec<3> x = uniform_point<3>(rng, vec<3>(-1.5, -1.5, -1.5), vec<3>(1.5, 1.5, 1.5));
        const bool in = x.cwiseAbs().maxCoeff() < 1.0;  // analytic
        if (std::abs(x.cwiseAbs().maxCoeff() - 1.0) < 1e-9) continue;
        CHECK((sb.signed_distance(x) > 0.0) == in);
      }
    }
  }

  TEST_CASE("geometry: signed distance is right at acute spikes and notches (pseudo-normals needed)") {
    // A random star polygon (radii in [0.15, 1]) has acute convex spikes and sharp concave notches:
    // near them the closest point is a vertex or an edge whose single face normal gives the wrong
    // sign (Bærentzen & Aanæs 2005, Fig. 1), while the angle-weighted pseudo-normal is right.
    const std::uint64_t seed = test_seed() + 6;
    MESSAGE("seed = " << seed);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> rad(0.15, 1.0);
    std::vector<vec<2>> star;
    const int n = 30;
    for (int i = 0; i < n; ++i) {
      const double th = 2 * std::numbers::pi * i / n;
      star.push_back(rad(rng) * vec<2>(std::cos(th), std::sin(th)));
    }
    const geo::polygon_mesh<2> m2 = geo::detail::closed_polygon(star, geo::fluid_side::outside);
    const geo::polygon_set<2> s2(m2);
    int vertex_hits = 0;
    for (int i = 0; i < 20000; ++i) {
      const vec<2> x = uniform_point<2>(rng, vec<2>(-1.1, -1.1), vec<2>(1.1, 1.1));
      const geo::closest_point<2> c = s2.closest(x);
      if (c.distance < 1e-9) continue;
      vertex_hits += c.kind == geo::feature_kind::vertex;
      CAPTURE(x.transpose());
      CHECK((s2.signed_distance(x) > 0.0) == !inside_2d(m2, x));
    }
    CHECK(vertex_hits > 1000);  // the test exercises vertex features, not only faces
    const geo::polygon_mesh<3> m3 =
        geo::detail::extrude(star, vec<2>(0, 0), 0.0, 0.3, 1, true, geo::fluid_side::outside);
    const geo::polygon_set<3> s3(m3);
    int edge_or_vertex = 0;
    for (int i = 0; i < 3000; ++i) {
      const vec<3> x = uniform_point<3>(rng, vec<3>(-1.1, -1.1, -0.2), vec<3>(1.1, 1.1, 0.5));
      const geo::closest_point<3> c = s3.closest(x);
      if (c.distance < 1e-9) continue;
      edge_or_vertex += c.kind != geo::feature_kind::face;
      const double w = winding_3d(m3, x);
      CAPTURE(x.transpose());
      REQUIRE(std::min(std::abs(w), std::abs(w - 1.0)) < 1e-6);
      CHECK((s3.signed_distance(x) > 0.0) == (w < 0.5));
    }
    CHECK(edge_or_vertex > 300);
  }

  TEST_CASE("geometry: curvature of a circle and a sphere within 1 percent (Tanaka eq. 77)") {
    const std::uint64_t seed = test_seed() + 3;
    MESSAGE("seed = " << seed);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> ang(0.0, 2 * std::numbers::pi);
    const double r = 0.3;
    for (const index_t n : {index_t{24}, index_t{64}}) {  // 15° and 5.6° between neighbours: below 30°
      CAPTURE(n);
      const geo::polygon_set<2> in(geo::circle(vec<2>(1, 2), r, n, geo::fluid_side::inside));
      const geo::polygon_set<2> out(geo::circle(vec<2>(1, 2), r, n, geo::fluid_side::outside));
      for (int i = 0; i < 200; ++i) {
        const double th = ang(rng);
        const vec<2> d(std::cos(th), std::sin(th));
        // reference 1/R; sign convention: + when the wall bends around the fluid (eq. 76 then enlarges
        // the imaginary particle, L' = L/(1 - r σ) > L); 1 % is the tolerance
        CHECK(in.query(vec<2>(1, 2) + 0.8 * r * d).curvature == doctest::Approx(1.0 / r).epsilon(0.01));
        CHECK(out.query(vec<2>(1, 2) + 1.3 * r * d).curvature == doctest::Approx(-1.0 / r).epsilon(0.01));
      }
    }
    for (int sub : {2, 3}) {  // 320 and 1280 triangles
      CAPTURE(sub);
      const geo::polygon_set<3> in(geo::sphere(vec<3>(0, 0, 1), r, sub, geo::fluid_side::inside));
      const geo::polygon_set<3> out(geo::sphere(vec<3>(0, 0, 1), r, sub, geo::fluid_side::outside));
      std::normal_distribution<double> nd;
      for (int i = 0; i < 200; ++i) {
        const vec<3> d = vec<3>(nd(rng), nd(rng), nd(rng)).normalized();
        CHECK(in.query(vec<3>(0, 0, 1) + 0.85 * r * d).curvature == doctest::Approx(1.0 / r).epsilon(0.01));
        CHECK(out.query(vec<3>(0, 0, 1) + 1.2 * r * d).curvature == doctest::Approx(-1.0 / r).epsilon(0.01));
      }
    }
  }

  TEST_CASE("geometry: curvature is zero on flat faces, at box corners and next to feature edges") {
    const geo::polygon_set<3> box(geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::inside, 4));
    // exact zero by construction (flat corner normals, or feature-adjacent elements): no tolerance
    for (const vec<3>& x :
         {vec<3>(0.5, 0.5, 0.1), vec<3>(0.3, 0.6, 0.9), vec<3>(0.05, 0.05, 0.05), vec<3>(0.02, 0.5, 0.03)})
      CHECK(box.query(x).curvature == 0.0);
    // a tilted box: face normals of coplanar triangles differ by rounding, σ must still be exactly 0
    geo::polygon_mesh<3> tilted = geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::inside, 5);
    const Eigen::Matrix3d rot = geo::rotation_matrix(vec<3>(0.3, -0.7, 0.45));
    tilted.vertices = (rot * tilted.vertices).eval();
    const geo::polygon_set<3> tb(tilted);
    for (const vec<3>& x : {vec<3>(0.5, 0.5, 0.1), vec<3>(0.33, 0.61, 0.93), vec<3>(0.71, 0.12, 0.44)})
      CHECK(tb.query((rot * x).eval()).curvature == 0.0);
    const geo::polygon_set<2> sq(geo::rectangle(vec<2>(0, 0), vec<2>(1, 1), geo::fluid_side::inside, 5));
    for (const vec<2>& x : {vec<2>(0.5, 0.1), vec<2>(0.02, 0.03)}) CHECK(sq.query(x).curvature == 0.0);
    // cylinder: side elements touching the caps' 90° rim are feature-adjacent (σ = 0); in the middle
    // band the side is curved in one direction only, so eq. (77) gives a weight-dependent value in
    // (0, 1/R]: check its sign and bound
    const geo::polygon_set<3> cyl(
        geo::cylinder(vec<3>(0, 0, 0), 0.5, 1.0, 48, 8, true, geo::fluid_side::inside));
    CHECK(cyl.query(vec<3>(0.45, 0.0, 0.05)).curvature == 0.0);
    const double mid = cyl.query(vec<3>(0.45, 0.01, 0.5)).curvature;
    CHECK(mid > 0.0);
    CHECK(mid <= 2.0 + 1e-9);  // at most 1/R (R = 0.5): a cylinder's normal turns in one direction
    // octagon: 45° between neighbours; default 30° makes every vertex a feature (σ = 0), 60° does not
    geo::polygon_options<2> wide;
    wide.feature_angle_deg = 60.0;
    const geo::polygon_set<2> oct(geo::circle(vec<2>(0, 0), 1.0, 8, geo::fluid_side::inside));
    const geo::polygon_set<2> oct60(geo::circle(vec<2>(0, 0), 1.0, 8, geo::fluid_side::inside), wide);
    CHECK(oct.query(vec<2>(0.5, 0.1)).curvature == 0.0);
    CHECK(oct60.query(vec<2>(0.5, 0.1)).curvature == doctest::Approx(1.0).epsilon(1e-12));  // exact on chords
    CHECK(contains(error_of([] {
                     geo::polygon_options<2> bad;
                     bad.feature_angle_deg = 200.0;
                     geo::polygon_set<2> s(geo::circle(vec<2>(0, 0), 1.0, 8, geo::fluid_side::inside), bad);
                   }),
                   "feature_angle_deg = 200, accepted range [0, 180]"));
  }

  TEST_CASE("geometry: segment crossing on thin walls") {
    {  // 2D thin wall: one open segment x = 0, y in [0, 1], fluid on both sides
      geo::polygon_mesh<2> m;
      m.vertices.resize(2, 2);
      m.vertices << 0, 0, 0, 1;
      m.elements.resize(2, 1);
      m.elements << 0, 1;
      const geo::polygon_set<2> w(m);
      CHECK(w.crosses(vec<2>(-0.01, 0.5), vec<2>(0.01, 0.5)));    // across, 2 cm apart
      CHECK(!w.crosses(vec<2>(-0.01, 0.5), vec<2>(-0.02, 0.7)));  // same side
      CHECK(!w.crosses(vec<2>(-0.01, 1.2), vec<2>(0.01, 1.2)));   // beyond the wall's end
      CHECK(w.crosses(vec<2>(-0.01, 0.99), vec<2>(0.01, 1.01)));  // through the end point (closed test)
      const std::optional<geo::crossing<2>> c = w.first_crossing(vec<2>(0.3, 0.2), vec<2>(-0.1, 0.6));
      REQUIRE(c.has_value());
      CHECK(c->t == doctest::Approx(0.75).epsilon(1e-14));  // analytic: x = 0.3 - 0.4 t = 0
      CHECK((c->point - vec<2>(0, 0.5)).norm() <= 1e-15);
      // segment (0,0)→(0,1): left normal (-1, 0); moving in −x goes along it: leaving the fluid side? no:
      CHECK(c->normal.isApprox(vec<2>(-1, 0)));
      CHECK(!c->entering);  // moving with the normal (from the solid side toward the fluid side)
      CHECK(w.first_crossing(vec<2>(-0.1, 0.6), vec<2>(0.3, 0.2))->entering);
    }
    {  // 3D thin plate z = 0 over [0,1]^2 as two triangles; a segment through the shared diagonal
      geo::polygon_mesh<3> m;
      m.vertices.resize(3, 4);
      m.vertices << 0, 1, 1, 0, 0, 0, 1, 1, 0, 0, 0, 0;
      m.elements.resize(3, 2);
      m.elements << 0, 0, 1, 2, 2, 3;
      const geo::polygon_set<3> w(m);
      CHECK(w.crosses(vec<3>(0.3, 0.6, -1e-3), vec<3>(0.3, 0.6, 1e-3)));
      CHECK(w.crosses(vec<3>(0.5, 0.5, -1e-3), vec<3>(0.5, 0.5, 1e-3)));  // exactly through the diagonal
      CHECK(w.crosses(vec<3>(0.25, 0.25, -1), vec<3>(0.75, 0.75, 1)));
      CHECK(!w.crosses(vec<3>(0.3, 0.6, 1e-3), vec<3>(0.4, 0.1, 2e-3)));
      CHECK(!w.crosses(vec<3>(1.1, 0.5, -1), vec<3>(1.1, 0.5, 1)));
      // sweep across the diagonal: no ray slips between the two triangles
      int missed = 0;
      for (int i = 0; i <= 1000; ++i) {
        const double s = 0.001 * i;
        missed += !w.crosses(vec<3>(s, s, -0.5), vec<3>(s, s, 0.5));
      }
      CHECK(missed == 0);
      const std::optional<geo::crossing<3>> c =
          w.first_crossing(vec<3>(0.2, 0.3, 0.5), vec<3>(0.2, 0.3, -1.5));
      REQUIRE(c.has_value());
      CHECK(c->t == doctest::Approx(0.25).epsilon(1e-14));
      CHECK(c->normal.isApprox(vec<3>(0, 0, 1)));
      CHECK(c->entering);  // moving against +z, the fluid side normal
    }
  }

  TEST_CASE("geometry: rotated gear matches analytic positions, closest points and wall velocity") {
    const vec<2> centre(0.3, -0.1);
    const double omega = 2.5, t = 0.37;  // rad/s, s
    geo::polygon_set<2> g(geo::gear(centre, 1.0, 0.8, 12), {},
                          geo::prescribed_motion<2>::rotation(centre, omega));
    const geo::polygon_mesh<2> ref = g.mesh();
    g.move_to(t);
    const Eigen::Matrix2d rot = geo::rotation_matrix(omega * t);
    double err = 0.0;
    for (index_t i = 0; i < ref.vertices.cols(); ++i)
      err = std::max(err, (g.vertices().col(i) - (rot * (ref.vertices.col(i) - centre) + centre)).norm());
    CHECK(err <= 1e-14);  // analytic rotation about the centre, rounding only
    // the moved set equals a gear generated with phase ω t
    const geo::polygon_set<2> analytic(geo::gear(centre, 1.0, 0.8, 12, geo::fluid_side::outside, omega * t));
    std::mt19937_64 rng(test_seed() + 4);
    for (int i = 0; i < 500; ++i) {
      const vec<2> x = uniform_point<2>(rng, vec<2>(-0.4, -0.8), vec<2>(1.0, 0.6));
      const geo::wall_point<2> a = g.query(x), b = analytic.query(x);
      CHECK(a.signed_distance == doctest::Approx(b.signed_distance).epsilon(1e-12).scale(1.0));
      CHECK((a.point - g.closest_brute_force(x).point).norm() <= 1e-12);  // refitted hierarchy
      // v = ω × (x − c) at the closest point (rigid rotation)
      const vec<2> r = a.point - centre;
      CHECK((a.velocity - omega * vec<2>(-r.y(), r.x())).norm() <= 1e-12);
    }
    // 3D: gear about the z axis through (0.3, -0.1, 0), translating along z as well
    geo::polygon_set<3> g3(
        geo::gear(vec<3>(0.3, -0.1, 0), 1.0, 0.8, 10, 0.2), {},
        geo::prescribed_motion<3>::rigid(vec<3>(0.3, -0.1, 0), vec<3>(0, 0, 0.5), vec<3>(0, 0, omega)));
    g3.move_to(t);
    const geo::polygon_set<3> a3(
        geo::gear(vec<3>(0.3, -0.1, 0.5 * t), 1.0, 0.8, 10, 0.2, geo::fluid_side::outside, omega * t));
    for (int i = 0; i < 300; ++i) {
      const vec<3> x = uniform_point<3>(rng, vec<3>(-0.4, -0.8, -0.2), vec<3>(1.0, 0.6, 0.6));
      const geo::wall_point<3> a = g3.query(x);
      CHECK(a.signed_distance == doctest::Approx(a3.signed_distance(x)).epsilon(1e-12).scale(1.0));
      const vec<3> r = a.point - vec<3>(0.3, -0.1, 0.5 * t);
      CHECK((a.velocity - (vec<3>(0, 0, 0.5) + geo::detail::cross3(vec<3>(0, 0, omega), r))).norm() <= 1e-12);
    }
    // a particle at rest swept by a rotating tooth: caught only by the moving-wall overload
    {
      geo::polygon_set<2> g2(geo::gear(vec<2>(0, 0), 1.0, 0.6, 6), {},
                             geo::prescribed_motion<2>::rotation(vec<2>(0, 0), 1.0));
      // tooth 0 spans angles [0.31, 1.05] (tip land [0.47, 0.89]); angle 1.2 at r = 0.45 is in the gap
      // that the counter-clockwise rotation sweeps the tooth into
      const vec<2> p = 0.45 * vec<2>(std::cos(1.2), std::sin(1.2));
      REQUIRE(g2.signed_distance(p) > 0.0);
      double t1 = 0.0;  // advance until p is inside the solid
      while (g2.signed_distance(p) > 0.0 && t1 < 2.0) g2.move_to(t1 += 0.01);
      REQUIRE(g2.signed_distance(p) < 0.0);
      const geo::rigid_transform<2> prev = (g2.move_to(t1 - 0.01), g2.pose());
      g2.move_to(t1);
      CHECK(!g2.first_crossing(p, p).has_value());  // a zero-length move sees nothing
      const std::optional<geo::crossing<2>> c = g2.first_crossing(p, p, prev);
      REQUIRE(c.has_value());
      CHECK(c->entering);
    }
    // a user callable velocity (conveyor belt: fixed geometry, tangential wall velocity)
    geo::polygon_set<2> belt(
        geo::tank(vec<2>(0, 0), vec<2>(1, 1)), {},
        geo::prescribed_motion<2>::callable({}, [](const vec<2>&, double) { return vec<2>(0.2, 0); }));
    belt.move_to(1.0);
    CHECK(belt.query(vec<2>(0.5, 0.1)).velocity.isApprox(vec<2>(0.2, 0)));
    CHECK(belt.vertices().isApprox(geo::tank(vec<2>(0, 0), vec<2>(1, 1)).vertices));
  }

  TEST_CASE("geometry: orientation repair from winding and from a fluid seed point") {
    geo::polygon_mesh<3> m = geo::sphere(vec<3>(0, 0, 0), 1.0, 2, geo::fluid_side::outside);
    for (index_t e = 0; e < m.size(); e += 7) m.flip(e);  // 46 of 320 flipped
    CHECK(!geo::analyse(m).inconsistent.empty());
    const geo::polygon_set<3> s(m);  // orient_consistently by default: the majority (outward) wins
    CHECK(s.quality().inconsistent.empty());
    CHECK(s.quality().flipped == 46);
    CHECK(s.signed_distance(vec<3>(0, 0, 0)) < 0.0);  // centre is in the solid (fluid outside)
    geo::polygon_options<3> seeded;
    seeded.fluid_seed = vec<3>(0.1, 0.2, 0.0);  // the user says: fluid inside
    const geo::polygon_set<3> t(m, seeded);
    CHECK(t.signed_distance(vec<3>(0, 0, 0)) > 0.0);
    CHECK(t.query(vec<3>(0.5, 0, 0)).curvature == doctest::Approx(1.0).epsilon(0.01));  // fluid inside: +1/R
    // an open 2D tank written clockwise (fluid outside) is turned inward by a seed
    geo::polygon_mesh<2> tank = geo::tank(vec<2>(0, 0), vec<2>(1, 1));
    for (index_t e = 0; e < tank.size(); ++e) tank.flip(e);
    geo::polygon_options<2> seed2;
    seed2.fluid_seed = vec<2>(0.5, 0.5);
    CHECK(geo::polygon_set<2>(tank, seed2).signed_distance(vec<2>(0.5, 0.2)) == doctest::Approx(0.2));
    CHECK(contains(error_of([&] {
                     geo::polygon_options<2> on;
                     on.fluid_seed = vec<2>(0.0, 0.5);
                     geo::polygon_set<2> bad(tank, on);
                   }),
                   "seed point lies on element"));
  }

  TEST_CASE("geometry: quality report counts open, non-manifold, duplicate and degenerate elements") {
    const geo::quality_report q = geo::analyse(geo::tank(vec<3>(0, 0, 0), vec<3>(1, 1, 1), 2));
    CHECK(q.open.size() == 8);  // top rim: 4 sides × 2 divisions (analytic)
    CHECK(q.non_manifold.empty());
    CHECK(q.inconsistent.empty());
    CHECK(q.components == 1);
    geo::polygon_mesh<3> m = geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::outside);
    CHECK(geo::analyse(m).clean());
    // add a fin sharing an edge of the box (non-manifold), and a duplicate of element 0
    m.vertices.conservativeResize(3, m.vertices.cols() + 1);
    m.vertices.col(m.vertices.cols() - 1) = vec<3>(0.5, -1, 0.5);
    const index_t a = m.elements(0, 0), b = m.elements(1, 0);
    m.elements.conservativeResize(3, m.size() + 2);
    m.elements.col(m.size() - 2) << a, b, m.vertices.cols() - 1;
    m.elements.col(m.size() - 1) = m.elements.col(0);
    const geo::quality_report r = geo::analyse(m);
    CHECK(r.duplicate.size() == 1);
    CHECK(r.duplicate.front() == std::pair<index_t, index_t>(m.size() - 1, 0));
    CHECK(r.non_manifold.size() >= 1);
    CHECK(!r.closed());
    // degenerate: polygon_set refuses it and names the element
    geo::polygon_mesh<2> d = geo::rectangle(vec<2>(0, 0), vec<2>(1, 1), geo::fluid_side::inside);
    d.elements(1, 2) = d.elements(0, 2);
    CHECK(contains(error_of([&] { geo::polygon_set<2> s(d); }), "element 2 is degenerate"));
    geo::polygon_mesh<2> n = geo::rectangle(vec<2>(0, 0), vec<2>(1, 1), geo::fluid_side::inside);
    n.vertices(1, 3) = std::nan("");
    CHECK(contains(error_of([&] { geo::polygon_set<2> s(n); }), "vertex 3 has a non-finite coordinate"));
    // a NaN query position is not silently mapped to a wall: NaN distance, nothing found
    const geo::polygon_set<2> ok(geo::rectangle(vec<2>(0, 0), vec<2>(1, 1), geo::fluid_side::inside));
    CHECK(std::isnan(ok.signed_distance(vec<2>(std::nan(""), 0.5))));
    CHECK(!ok.query(vec<2>(0.5, std::nan(""))).found());
  }

  TEST_CASE("geometry: readers accept the valid sample files") {
    const geo::read_result<2> p = geo::read_polyline(data("tank.poly"));
    CHECK(p.mesh.size() == 3);
    CHECK(p.quality.open.size() == 2);  // an open tank: its two top ends
    CHECK(geo::polygon_set<2>(p.mesh).signed_distance(vec<2>(0.5, 0.1)) == doctest::Approx(0.1));
    const geo::read_result<3> c = geo::read_stl(data("cube_ascii.stl"));
    CHECK(c.mesh.size() == 12);
    CHECK(c.mesh.vertices.cols() == 8);
    CHECK(c.quality.merged_vertices == 36 - 8);  // every corner stored once per triangle in STL
    CHECK(c.quality.clean());
    // outward winding
    CHECK(geo::polygon_set<3>(c.mesh).signed_distance(vec<3>(0.5, 0.5, 0.2)) == doctest::Approx(-0.2));
    const geo::read_result<3> o = geo::read_obj(data("pyramid.obj"));
    CHECK(o.mesh.size() == 6);  // quad base fan-triangulated into 2 + 4 sides
    CHECK(o.quality.closed());
    CHECK(o.quality.inconsistent.empty());
  }

  TEST_CASE("geometry: readers report orientation defects and handle STL variants") {
    const geo::polygon_mesh<3> cube = geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::outside);
    // one flipped triangle: its 3 edges are each traversed twice in the same direction
    geo::polygon_mesh<3> flipped = cube;
    flipped.flip(4);
    const geo::read_result<3> r = geo::parse_stl(geo::format_stl(flipped, geo::stl_format::ascii), "f.stl");
    CHECK(r.quality.inconsistent.size() == 3);
    CHECK(geo::polygon_set<3>(r.mesh).quality().flipped == 1);  // majority orientation restored
    // two solids in one ASCII file; a binary file whose 80-byte header starts with "solid"
    std::string two = geo::format_stl(geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::outside),
                                      geo::stl_format::ascii, "a") +
                      geo::format_stl(geo::box(vec<3>(2, 0, 0), vec<3>(3, 1, 1), geo::fluid_side::outside),
                                      geo::stl_format::ascii, "b");
    const geo::read_result<3> t = geo::parse_stl(two, "two.stl");
    CHECK(t.mesh.size() == 24);
    CHECK(t.quality.components == 2);
    std::string bin = geo::format_stl(cube, geo::stl_format::binary);
    bin.replace(0, 12, "solid header");
    CHECK(geo::parse_stl(bin, "b.stl").mesh.size() == 12);
    // a duplicated facet is reported, kept by default and dropped on request
    const std::string dup = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 2 3 1\n";
    CHECK(geo::parse_obj(dup, "d.obj").quality.duplicate.size() == 1);
    geo::read_options drop;
    drop.drop_duplicates = true;
    const geo::read_result<3> d = geo::parse_obj(dup, "d.obj", drop);
    CHECK(d.mesh.size() == 1);
    CHECK(d.quality.dropped_duplicate == 1);
  }

  TEST_CASE("geometry: readers refuse broken files naming file, line or element") {
    struct bad_case {
      const char* name;
      std::string text;
      const char* expected;
    };
    const std::string tri =
        "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n      vertex 0 1 0\n  "
        "  endloop\n  endfacet\n";
    const std::vector<bad_case> cases = {
        {"short.poly", "mpskit_polyline 1\nvertices 3\n0 0\n1 0\n",
         "short.poly:5: file ends after 2 of 3 vertices"},
        {"count.poly", "mpskit_polyline 1\nvertices 2\n0 0\n1 0\nsegments 2\n0 1\n",
         "file ends after 1 of 2 segments"},
        {"extra.poly", "mpskit_polyline 1\nvertices 2\n0 0\n1 0\nsegments 1\n0 1\n1 0\n",
         "extra.poly:7: unexpected content"},
        {"fewer.poly", "mpskit_polyline 1\nvertices 3\n0 0\n1 0\nsegments 1\n0 1\n",
         "fewer.poly:5: found 'segments' after 2 of 3 vertices"},
        {"nan.poly", "mpskit_polyline 1\nvertices 2\n0 nan\n1 0\nsegments 1\n0 1\n",
         "nan.poly:3: vertex coordinate: 'nan' is not a finite number"},
        {"index.poly", "mpskit_polyline 1\nvertices 2\n0 0\n1 0\nsegments 1\n0 2\n",
         "index.poly:6: segment 0 refers to vertex 2, accepted range [0, 1]"},
        {"degenerate.poly", "mpskit_polyline 1\nvertices 2\n0 0\n0 0\nsegments 1\n0 1\n",
         "degenerate.poly: line 6: element 0 is degenerate"},
        {"header.poly", "polyline\n", "header.poly:1: expected header 'mpskit_polyline 1'"},
        {"trunc.stl", "solid t\n" + tri + "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n",
         "trunc.stl:11: file ends where 'vertex' was expected (truncated)"},
        {"noend.stl", "solid t\n" + tri, "file ends before 'endsolid'"},
        {"nan.stl",
         "solid t\n  facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 NaN 0\n vertex 0 1 0\n "
         "endloop\n endfacet\nendsolid t\n",
         "nan.stl:5: vertex coordinate: 'NaN' is not a finite number"},
        {"quad.stl",
         "solid t\n facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n vertex 1 1 0\n vertex 0 "
         "1 0\n endloop\n endfacet\nendsolid\n",
         "quad.stl:7: facet has more than 3 vertices"},
        {"degenerate.stl",
         "solid t\n" + tri +
             " facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n vertex 2 0 0\n endloop\n "
             "endfacet\nendsolid\n",
         "degenerate.stl: line 9: element 1 is degenerate"},
        {"range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
         "range.obj:4: face refers to vertex 4, but 3 vertices are defined so far"},
        {"nan.obj", "v 0 0 0\nv 1 inf 0\n", "nan.obj:2: vertex coordinate: 'inf' is not a finite number"},
        {"short.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "short.obj:4: face needs at least 3 vertices"},
        {"degenerate.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 3\n",
         "degenerate.obj: line 5: element 1 is degenerate"},
        {"empty.obj", "# nothing\n", "empty.obj: no elements"},
        {"garbage.stl", "not an stl", "too short for binary STL"},
    };
    for (const bad_case& b : cases) {
      CAPTURE(b.name);
      const std::string path = write_temp(b.name, b.text);
      const std::string ext = std::filesystem::path(b.name).extension().string();
      const std::string msg = error_of([&] {
        if (ext == ".poly") geo::read_polyline(path);
        if (ext == ".stl") geo::read_stl(path);
        if (ext == ".obj") geo::read_obj(path);
      });
      CAPTURE(msg);
      CHECK(contains(msg, b.expected));
      CHECK(contains(msg, "mpskit: "));
    }
    // binary STL: truncated (one byte missing) and wrong count
    const std::string bin =
        geo::format_stl(geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::outside));
    CHECK(
        contains(error_of([&] { geo::read_stl(write_temp("trunc_bin.stl", bin.substr(0, bin.size() - 1))); }),
                 "binary STL declares 12 triangles (684 bytes) but the file has 683 bytes"));
    std::string wrong = bin;
    wrong[80] = 13;
    CHECK(contains(error_of([&] { geo::read_stl(write_temp("count_bin.stl", wrong)); }),
                   "declares 13 triangles"));
    std::string nanbin = bin;
    const float nanf = std::nanf("");
    std::memcpy(nanbin.data() + 84 + 50 * 5 + 16, &nanf, 4);
    CHECK(contains(error_of([&] { geo::read_stl(write_temp("nan_bin.stl", nanbin)); }),
                   "triangle 5 (byte offset 334): non-finite"));
    CHECK(contains(error_of([] { geo::read_stl("/nonexistent/mpskit.stl"); }),
                   "/nonexistent/mpskit.stl: cannot open"));
    // drop_degenerate removes and counts instead of refusing
    geo::read_options drop;
    drop.drop_degenerate = true;
    const geo::read_result<3> r =
        geo::parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 3\n", "x.obj", drop);
    CHECK(r.mesh.size() == 1);
    CHECK(r.quality.dropped_degenerate == 1);
  }

  TEST_CASE("geometry: writers round-trip through the readers") {
    const geo::polygon_mesh<2> g2 =
        geo::gear(vec<2>(0.1, 0.2), 1.0, 0.7, 13, geo::fluid_side::outside, 0.05, 2);
    const geo::read_result<2> p = geo::read_polyline(
        (write_temp("rt.poly", ""), geo::write_polyline((temp_dir() / "rt.poly").string(), g2),
         (temp_dir() / "rt.poly").string()));
    CHECK(p.mesh.vertices == g2.vertices);  // 17 digits: exact
    CHECK(p.mesh.elements == g2.elements);
    const geo::polygon_mesh<3> g3 = geo::gear(vec<3>(0.1, 0.2, 0.3), 1.0, 0.7, 13, 0.25);
    const std::string obj = (temp_dir() / "rt.obj").string();
    geo::write_obj(obj, g3);
    const geo::read_result<3> o = geo::read_obj(obj);
    CHECK(o.mesh.vertices == g3.vertices);
    CHECK(o.mesh.elements == g3.elements);
    const std::string ascii = (temp_dir() / "rt_ascii.stl").string();
    geo::write_stl(ascii, g3, geo::stl_format::ascii);
    const geo::read_result<3> a = geo::read_stl(ascii);
    CHECK(a.mesh.size() == g3.size());
    CHECK(a.mesh.vertices.cols() == g3.vertices.cols());  // welding recovers the shared vertices
    double err = 0.0;
    for (index_t e = 0; e < g3.size(); ++e)
      err = std::max(err, (a.mesh.element(e) - g3.element(e)).cwiseAbs().maxCoeff());
    CHECK(err == 0.0);  // ASCII with 17 digits is exact
    const std::string binary = (temp_dir() / "rt_binary.stl").string();
    geo::write_stl(binary, g3, geo::stl_format::binary);
    const geo::read_result<3> b = geo::read_stl(binary);
    CHECK(b.mesh.size() == g3.size());
    err = 0.0;
    for (index_t e = 0; e < g3.size(); ++e)
      err = std::max(err, (b.mesh.element(e) - g3.element(e)).cwiseAbs().maxCoeff());
    CHECK(err <= 1e-7);  // float32 storage: relative 6e-8 on coordinates of order 1
    CHECK(b.quality.closed());
  }

  TEST_CASE("geometry: generators produce closed, consistently oriented sets") {
    const geo::quality_report a = geo::analyse(geo::gear(vec<3>(0, 0, 0), 1.0, 0.8, 20, 0.1));
    CHECK(a.clean());
    CHECK(geo::analyse(geo::cylinder(vec<3>(0, 0, 0), 1, 2, 32, 3, true, geo::fluid_side::inside)).clean());
    CHECK(geo::analyse(geo::sphere(vec<3>(0, 0, 0), 1, 3, geo::fluid_side::inside)).clean());
    CHECK(geo::analyse(geo::box(vec<3>(0, 0, 0), vec<3>(1, 1, 1), geo::fluid_side::inside, 3)).clean());
    CHECK(geo::analyse(geo::circle(vec<2>(0, 0), 1, 40, geo::fluid_side::outside)).clean());
    // tip and root radii of the gear (analytic: every vertex on one of the two circles)
    const geo::polygon_mesh<2> g = geo::gear(vec<2>(1, 1), 2.0, 1.6, 15);
    for (index_t i = 0; i < g.vertices.cols(); ++i) {
      const double r = (g.vertices.col(i) - vec<2>(1, 1)).norm();
      CHECK((std::abs(r - 1.0) <= 1e-14 || std::abs(r - 0.8) <= 1e-14));
    }
    CHECK(contains(error_of([] { geo::gear(vec<2>(0, 0), 1.0, 1.2, 10); }),
                   "tip_diameter = 1, accepted range (root_diameter = 1.2"));
    CHECK(contains(error_of([] { geo::circle(vec<2>(0, 0), 1.0, 2, geo::fluid_side::inside); }),
                   "segments = 2, accepted range [3, inf)"));
  }
  TEST_CASE("geometry: a wall collection answers for a fixed tank and a rotating gear") {
    geo::wall_collection<2> walls;
    walls.add(geo::polygon_set<2>(geo::tank(vec<2>(-2, -2), vec<2>(2, 1))));
    walls.add(geo::polygon_set<2>(geo::gear(vec<2>(0, 0), 1.0, 0.8, 8), {},
                                  geo::prescribed_motion<2>::rotation(vec<2>(0, 0), 1.5)));
    walls.move_to(0.2);
    std::mt19937_64 rng(test_seed() + 5);
    MESSAGE("seed = " << test_seed() + 5);
    for (int i = 0; i < 500; ++i) {
      const vec<2> x = uniform_point<2>(rng, vec<2>(-1.9, -1.9), vec<2>(1.9, 0.9));
      const geo::collection_point<2> c = walls.query(x);
      const geo::closest_point<2> t = walls[0].closest(x), g = walls[1].closest(x);
      CHECK(c.distance == std::min(t.distance, g.distance));  // same kernels: exact
      CHECK(c.set == (g.distance < t.distance ? 1 : 0));
      if (c.set == 0) CHECK(c.velocity.norm() == 0.0);  // the tank does not move
      if (c.set == 1) CHECK((c.velocity - 1.5 * vec<2>(-c.point.y(), c.point.x())).norm() <= 1e-12);
    }
    // a move from the fluid into the gear crosses set 1; into the bottom crosses set 0
    CHECK(walls.first_crossing(vec<2>(0, 0.95), vec<2>(0, 0))->set == 1);
    CHECK(walls.first_crossing(vec<2>(1.5, -1.9), vec<2>(1.5, -2.1))->set == 0);
    CHECK(!walls.crosses(vec<2>(1.5, -1.5), vec<2>(1.6, -1.6)));
    CHECK(!walls.query(vec<2>(1.5, -1.5), 0.1).found());  // nothing within 0.1
  }
}
