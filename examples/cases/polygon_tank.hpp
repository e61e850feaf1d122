#pragma once
// Hydrostatic tank with an inclined wall and a concave corner, for the LSMPS solver with polygon walls
// (issue #7, label hydrostatic_polygon). 2D: the floor runs from (0, 0) to (W, 0), the right wall is
// vertical at x = W, the left wall leans outward at `angle_deg` from the floor, from (0, 0) to
// (−T cot θ, T), so the fluid sits in a trapezoid that widens upward and the floor/incline corner at
// the origin is concave (interior angle 180° − θ). 3D: the same profile in the x–z plane (z is
// vertical: gravity acts along the last axis), extruded along y over [0, B] with closed end walls.
// The walls are the polygon (no wall particles); fluid particles sit on the lattice (k + ½) L with
// signed distance ≥ L/2 from every wall, up to depth H. See docs/regularize.md ("LSMPS wall cases").
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/wall/polygon_layers.hpp"

namespace mpskit::cases {

/// Numbers of the polygon tank (m, degrees).
struct polygon_tank_config {
  double W = 0.2;             ///< floor length, floor from x = 0 to x = W; accepted (0, inf)
  double H = 0.2;             ///< fill depth (lattice rows with centres ≤ H); accepted (0, tank_height − L]
  double tank_height = 0.3;   ///< wall height T; accepted [H + L, inf)
  double angle_deg = 60.0;    ///< incline of the left wall from the floor; accepted [30, 90] (90: vertical)
  double L = 0.01;            ///< particle diameter = lattice spacing; accepted (0, min(W, H)]
  double B = 0.1;             ///< 3D: extent along y, end walls at y = 0 and y = B; accepted [L, inf)
  bool lid = true;            ///< close the top at z = T (2D: a segment; 3D: two triangles)
  /// Throws mpskit::error listing every bad value (B is checked in 3D only).
  void validate(int dim = 3) const {
    validator v("polygon_tank_config");
    v.positive("W", W).positive("H", H).positive("L", L).positive("tank_height", tank_height);
    if (dim == 3) v.positive("B", B);
    v.in_range("angle_deg", angle_deg, 30.0, 90.0);
    if (std::isfinite(L) && std::isfinite(H) && std::isfinite(tank_height) && !(tank_height >= H + L))
      v.require(false, "tank_height",
                mpskit::detail::concat("is ", tank_height, ", must be >= H + L = ", H + L));
    if (std::isfinite(L) && L > 0.0 && !(L <= W && L <= H && (dim == 2 || L <= B)))
      v.require(false, "L",
                mpskit::detail::concat("is ", L, ", must be <= min(W, H", dim == 3 ? ", B)" : ")"));
    v.throw_if_any();
  }
};

/// Which wall an element belongs to.
enum class tank_face : int { incline = 0, floor = 1, right = 2, lid = 3, front = 4, back = 5 };

/// The tank: walls, fluid particles and the analytic hydrostatic reference.
template <int D>
struct polygon_tank {
  polygon_tank_config config;              ///< the numbers it was built from
  geometry::polygon_set<D> walls;          ///< wall polygon (normals toward the fluid)
  std::vector<tank_face> faces;            ///< faces[e]: the wall element e belongs to
  points<D> x;                             ///< fluid particle positions (m)
  double L = 0.0;                          ///< particle diameter (m), the same for all
  double H = 0.0;                          ///< requested fill depth (m)
  double surface_height = 0.0;             ///< free-surface level z_s (m) with V(z_s) = N L^D
  /// Number of fluid particles.
  index_t size() const { return x.cols(); }
  /// Per-particle diameters (all L), the array the LSMPS pieces read.
  Eigen::VectorXd diameters() const { return Eigen::VectorXd::Constant(x.cols(), L); }
  /// cot θ of the incline (0 for a vertical left wall).
  double cot() const { return cot_of(config.angle_deg); }
  /// Area of the profile below height h: W h + h² cot θ / 2 (trapezoid).
  double profile_area(double h) const { return config.W * h + 0.5 * h * h * cot(); }
  /// Fluid volume below level h (2D: area; 3D: area × B).
  double volume(double h) const { return profile_area(h) * (D == 3 ? config.B : 1.0); }
  /// Length (2D) or area (3D) of the inclined wall wetted below level h.
  double incline_wetted(double h) const {
    const double len = h / std::sin(config.angle_deg * std::numbers::pi / 180.0);
    return len * (D == 3 ? config.B : 1.0);
  }
  /// Hydrostatic pressure p = ρ g (z_s − z) with z the last coordinate (Pa); negative above z_s.
  double hydrostatic_pressure(const vec<D>& p, double rho, double g) const {
    return rho * g * (surface_height - p[D - 1]);
  }
  /// The concave corner: the 2D vertex at the origin; in 3D the midpoint (0, B/2, 0) of the corner edge.
  vec<D> corner() const {
    vec<D> c = vec<D>::Zero();
    if constexpr (D == 3) c[1] = 0.5 * config.B;
    return c;
  }
  /// True if p lies strictly inside the closed tank (analytic test, independent of the polygon).
  bool inside(const vec<D>& p) const {
    const double z = p[D - 1], xx = p[0];
    bool in = z > 0.0 && z < config.tank_height && xx < config.W && xx > -z * cot();
    if constexpr (D == 3) in = in && p[1] > 0.0 && p[1] < config.B;
    return in;
  }
  /// cot of an angle in degrees, exactly 0 at 90°.
  static double cot_of(double deg) {
    return deg == 90.0 ? 0.0 : 1.0 / std::tan(deg * std::numbers::pi / 180.0);
  }
};

namespace detail {
/// Profile corners in (horizontal, vertical): Q0 top of the incline, Q1 concave corner (origin),
/// Q2 floor/right-wall corner, Q3 top of the right wall.
inline std::array<vec<2>, 4> tank_profile(const polygon_tank_config& c) {
  const double T = c.tank_height, ct = polygon_tank<2>::cot_of(c.angle_deg);
  return {vec<2>(-T * ct, T), vec<2>(0.0, 0.0), vec<2>(c.W, 0.0), vec<2>(c.W, T)};
}

/// 2D: the polyline Q0 → Q1 → Q2 → Q3 (→ Q0 with the lid), counter-clockwise around the fluid, so the
/// left normal (−Δz, Δx) of each segment points into the tank.
inline geometry::polygon_mesh<2> tank_mesh_2d(const polygon_tank_config& c, std::vector<tank_face>& faces) {
  const std::array<vec<2>, 4> q = tank_profile(c);
  geometry::polygon_mesh<2> m;
  m.vertices.resize(2, 4);
  for (int k = 0; k < 4; ++k) m.vertices.col(k) = q[static_cast<std::size_t>(k)];
  const int ne = c.lid ? 4 : 3;
  m.elements.resize(2, ne);
  for (int e = 0; e < ne; ++e) {
    m.elements(0, e) = e;
    m.elements(1, e) = (e + 1) % 4;
    faces.push_back(static_cast<tank_face>(e));  // incline, floor, right, lid
  }
  return m;
}

/// 3D: profile Q_k at (Q_k.x, 0, Q_k.z) (vertex k) and (Q_k.x, B, Q_k.z) (vertex 4 + k). A profile edge
/// Q_k → Q_k+1 becomes the quad a b c d = (k,0) (k+1,0) (k+1,B) (k,B) split as abc, acd; its winding
/// normal (b − a) × (c − a) = B (−Δz, 0, Δx) is the 2D left normal, into the tank. End caps: the
/// trapezoid split along Q1–Q3, wound to +y at y = 0 and −y at y = B.
inline geometry::polygon_mesh<3> tank_mesh_3d(const polygon_tank_config& c, std::vector<tank_face>& faces) {
  const std::array<vec<2>, 4> q = tank_profile(c);
  geometry::polygon_mesh<3> m;
  m.vertices.resize(3, 8);
  for (int k = 0; k < 4; ++k) {
    m.vertices.col(k) = vec<3>(q[static_cast<std::size_t>(k)].x(), 0.0, q[static_cast<std::size_t>(k)].y());
    m.vertices.col(4 + k) =
        vec<3>(q[static_cast<std::size_t>(k)].x(), c.B, q[static_cast<std::size_t>(k)].y());
  }
  std::vector<std::array<index_t, 3>> tri;
  const int sides = c.lid ? 4 : 3;
  for (int k = 0; k < sides; ++k) {
    const index_t a = k, b = (k + 1) % 4, cc = 4 + (k + 1) % 4, d = 4 + k;
    tri.push_back({a, b, cc});
    tri.push_back({a, cc, d});
    faces.push_back(static_cast<tank_face>(k));
    faces.push_back(static_cast<tank_face>(k));
  }
  tri.push_back({1, 3, 2});  // y = 0: (Q3 − Q1) × (Q2 − Q1) points to +y
  tri.push_back({1, 0, 3});
  faces.push_back(tank_face::front);
  faces.push_back(tank_face::front);
  tri.push_back({5, 6, 7});  // y = B: −y
  tri.push_back({5, 7, 4});
  faces.push_back(tank_face::back);
  faces.push_back(tank_face::back);
  m.elements.resize(3, static_cast<index_t>(tri.size()));
  for (std::size_t e = 0; e < tri.size(); ++e)
    for (int k = 0; k < 3; ++k) m.elements(k, static_cast<index_t>(e)) = tri[e][static_cast<std::size_t>(k)];
  return m;
}

}  // namespace detail

/// Fluid particles on the lattice origin + (k + ½) L inside [lo, hi] (wall::polygon_fill) kept where the
/// signed distance to the walls is ≥ L/2 (a 1e-12 L rounding allowance for points exactly L/2 from a
/// wall, e.g. the first row above a lattice-aligned floor). No wall particles: the walls are polygons.
template <int D>
points<D> fill_half_spacing(const geometry::polygon_set<D>& walls, const vec<D>& lo, const vec<D>& hi,
                            double L, const vec<D>& origin = vec<D>::Zero()) {
  const wall::particle_block<D> b = wall::polygon_fill<D>(walls, lo, hi, L, origin);
  std::vector<std::size_t> keep;
  for (std::size_t k = 0; k < b.size(); ++k)
    if (walls.signed_distance(b.x[k]) >= 0.5 * L * (1.0 - 1e-12)) keep.push_back(k);
  points<D> x(D, static_cast<index_t>(keep.size()));
  for (std::size_t k = 0; k < keep.size(); ++k) x.col(static_cast<index_t>(k)) = b.x[keep[k]];
  return x;
}

/// Builds the tank: walls, fluid particles at spacing L below depth H with signed distance ≥ L/2, and
/// the free-surface level z_s solving V(z_s) = N L^D (the particles' volume), which sets the
/// reference pressure ρ g (z_s − z). With W, H, B multiples of L the floor, right and end walls and the
/// surface are matched exactly; the incline loses about half a layer (particles with s < L/2), so
/// z_s < H by a fraction of L.
template <int D>
  requires(D == 2 || D == 3)
polygon_tank<D> make_polygon_tank(const polygon_tank_config& c = {}) {
  c.validate(D);
  std::vector<tank_face> faces;
  geometry::polygon_mesh<D> mesh;
  if constexpr (D == 2)
    mesh = detail::tank_mesh_2d(c, faces);
  else
    mesh = detail::tank_mesh_3d(c, faces);
  geometry::polygon_set<D> walls(std::move(mesh));
  const double ct = polygon_tank<D>::cot_of(c.angle_deg);
  vec<D> lo = vec<D>::Zero(), hi = vec<D>::Zero();
  lo[0] = -c.H * ct - c.L;
  hi[0] = c.W;
  hi[D - 1] = c.H;
  if constexpr (D == 3) hi[1] = c.B;
  points<D> x = fill_half_spacing<D>(walls, lo, hi, c.L);
  if (x.cols() == 0)
    fail("make_polygon_tank: no fluid particle fits (L = ", c.L, ", H = ", c.H, ", W = ", c.W, ")");
  polygon_tank<D> t{c, std::move(walls), std::move(faces), std::move(x), c.L, c.H, 0.0};
  // z_s from W z + z² cot θ / 2 = A (A = N L^D, divided by B in 3D); the stable root 2A/(W + √(W² + 2A cot
  // θ)).
  const double A = static_cast<double>(t.size()) * std::pow(c.L, D) / (D == 3 ? c.B : 1.0);
  t.surface_height = 2.0 * A / (c.W + std::sqrt(c.W * c.W + 2.0 * A * ct));
  return t;
}

}  // namespace mpskit::cases
