#pragma once
/// \file geometry/generators.hpp
/// \brief Polygon meshes for common walls: rectangles/boxes, open-top tanks, circles/cylinders,
/// spheres (icospheres) and spur gears (tip/root diameters, teeth), 2D and 3D.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"

namespace mpskit::geometry {

/// Which side of a closed generated shape holds the fluid.
enum class fluid_side {
  inside,   ///< container: normals point inward
  outside,  ///< obstacle: normals point outward
};

namespace detail {
/// Builds a mesh from vertex and element lists.
template <int D>
inline polygon_mesh<D> make_mesh(const std::vector<vec<D>>& v,
                                 const std::vector<std::array<index_t, D>>& el) {
  polygon_mesh<D> m;
  m.vertices.resize(D, static_cast<index_t>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) m.vertices.col(static_cast<index_t>(i)) = v[i];
  m.elements.resize(D, static_cast<index_t>(el.size()));
  for (std::size_t e = 0; e < el.size(); ++e)
    for (int k = 0; k < D; ++k) m.elements(k, static_cast<index_t>(e)) = el[e][k];
  return m;
}
template <int D>
inline void flip_all(polygon_mesh<D>& m) {
  for (index_t e = 0; e < m.size(); ++e) m.flip(e);
}
/// Closed polygon through the points in order (counter-clockwise points → fluid inside).
inline polygon_mesh<2> closed_polygon(const std::vector<vec<2>>& p, fluid_side side) {
  std::vector<std::array<index_t, 2>> el;
  const index_t n = static_cast<index_t>(p.size());
  for (index_t i = 0; i < n; ++i) el.push_back({i, (i + 1) % n});
  polygon_mesh<2> m = make_mesh<2>(p, el);
  if (side == fluid_side::outside) flip_all(m);
  return m;
}
/// Prism of a star-shaped (about `centre`) counter-clockwise profile: side quads in `layers` layers
/// from z0 to z0 + height, optional fan caps. Outward normals; flipped for fluid inside.
inline polygon_mesh<3> extrude(const std::vector<vec<2>>& profile, const vec<2>& centre, double z0,
                               double height, int layers, bool caps, fluid_side side) {
  const index_t n = static_cast<index_t>(profile.size());
  std::vector<vec<3>> v;
  std::vector<std::array<index_t, 3>> el;
  for (int k = 0; k <= layers; ++k)
    for (index_t j = 0; j < n; ++j)
      v.push_back(vec<3>(profile[j].x(), profile[j].y(), z0 + height * k / layers));
  auto id = [n](index_t j, int k) { return static_cast<index_t>(k) * n + (j % n); };
  for (int k = 0; k < layers; ++k)
    for (index_t j = 0; j < n; ++j) {
      el.push_back({id(j, k), id(j + 1, k), id(j + 1, k + 1)});
      el.push_back({id(j, k), id(j + 1, k + 1), id(j, k + 1)});
    }
  if (caps) {
    const index_t cb = static_cast<index_t>(v.size());
    v.push_back(vec<3>(centre.x(), centre.y(), z0));
    const index_t ct = cb + 1;
    v.push_back(vec<3>(centre.x(), centre.y(), z0 + height));
    for (index_t j = 0; j < n; ++j) {
      el.push_back({cb, id(j + 1, 0), id(j, 0)});
      el.push_back({ct, id(j, layers), id(j + 1, layers)});
    }
  }
  polygon_mesh<3> m = make_mesh<3>(v, el);
  if (side == fluid_side::inside) flip_all(m);
  return m;
}
inline void check_positive(double x, const char* fn, const char* what) {
  if (!(x > 0.0) || !std::isfinite(x))
    fail("geometry::", fn, ": ", what, " = ", x, ", accepted range (0, inf)");
}
inline void check_count(index_t n, index_t min, const char* fn, const char* what) {
  if (n < min) fail("geometry::", fn, ": ", what, " = ", n, ", accepted range [", min, ", inf)");
}
}  // namespace detail

/// Closed rectangle [lo, hi] with `divisions` segments per side.
inline polygon_mesh<2> rectangle(const vec<2>& lo, const vec<2>& hi, fluid_side side, index_t divisions = 1) {
  detail::check_positive(hi.x() - lo.x(), "rectangle", "width");
  detail::check_positive(hi.y() - lo.y(), "rectangle", "height");
  detail::check_count(divisions, 1, "rectangle", "divisions");
  const std::array<vec<2>, 4> c = {lo, vec<2>(hi.x(), lo.y()), hi, vec<2>(lo.x(), hi.y())};
  std::vector<vec<2>> p;
  for (int s = 0; s < 4; ++s)
    for (index_t i = 0; i < divisions; ++i)
      p.push_back(c[s] + (c[(s + 1) % 4] - c[s]) * (static_cast<double>(i) / static_cast<double>(divisions)));
  return detail::closed_polygon(p, side);
}

/// Open-top tank in 2D: left wall, bottom, right wall of [lo, hi] (top open), fluid inside.
inline polygon_mesh<2> tank(const vec<2>& lo, const vec<2>& hi, index_t divisions = 1) {
  detail::check_positive(hi.x() - lo.x(), "tank", "width");
  detail::check_positive(hi.y() - lo.y(), "tank", "height");
  detail::check_count(divisions, 1, "tank", "divisions");
  const std::array<vec<2>, 4> c = {vec<2>(lo.x(), hi.y()), lo, vec<2>(hi.x(), lo.y()), hi};
  std::vector<vec<2>> p;
  for (int s = 0; s < 3; ++s)
    for (index_t i = 0; i < divisions; ++i)
      p.push_back(c[s] + (c[s + 1] - c[s]) * (static_cast<double>(i) / static_cast<double>(divisions)));
  p.push_back(c[3]);
  std::vector<std::array<index_t, 2>> el;
  for (index_t i = 0; i + 1 < static_cast<index_t>(p.size()); ++i) el.push_back({i, i + 1});
  return detail::make_mesh<2>(p, el);  // downward on the left wall: left normal is +x, into the tank
}

namespace detail {
/// Surface of [lo, hi] with `divisions`² quads (two triangles each) per face, outward normals;
/// `skip_top` leaves the +z face out (open tank).
inline polygon_mesh<3> box_surface(const vec<3>& lo, const vec<3>& hi, index_t n, bool skip_top) {
  std::map<std::array<index_t, 3>, index_t> ids;
  std::vector<vec<3>> v;
  std::vector<std::array<index_t, 3>> el;
  auto vid = [&](std::array<index_t, 3> g) {
    auto [it, inserted] = ids.try_emplace(g, static_cast<index_t>(v.size()));
    if (inserted) {
      vec<3> p;
      for (int a = 0; a < 3; ++a)
        p[a] = lo[a] + (hi[a] - lo[a]) * (static_cast<double>(g[a]) / static_cast<double>(n));
      v.push_back(p);
    }
    return it->second;
  };
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s) {
      if (skip_top && a == 2 && s == 1) continue;
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      for (index_t i = 0; i < n; ++i)
        for (index_t j = 0; j < n; ++j) {
          auto g = [&](index_t di, index_t dj) {
            std::array<index_t, 3> x{};
            x[a] = s == 1 ? n : 0;
            x[b] = i + di;
            x[c] = j + dj;
            return vid(x);
          };
          const index_t p00 = g(0, 0), p10 = g(1, 0), p11 = g(1, 1), p01 = g(0, 1);
          if (s == 1) {  // e_b × e_c = e_a: outward on the hi face
            el.push_back({p00, p10, p11});
            el.push_back({p00, p11, p01});
          } else {
            el.push_back({p00, p11, p10});
            el.push_back({p00, p01, p11});
          }
        }
    }
  return make_mesh<3>(v, el);
}
}  // namespace detail

/// Closed box [lo, hi] with `divisions`² quads per face.
inline polygon_mesh<3> box(const vec<3>& lo, const vec<3>& hi, fluid_side side, index_t divisions = 1) {
  for (int a = 0; a < 3; ++a) detail::check_positive(hi[a] - lo[a], "box", "edge length");
  detail::check_count(divisions, 1, "box", "divisions");
  polygon_mesh<3> m = detail::box_surface(lo, hi, divisions, false);
  if (side == fluid_side::inside) detail::flip_all(m);
  return m;
}

/// Open-top tank [lo, hi] in 3D (no +z face), fluid inside.
inline polygon_mesh<3> tank(const vec<3>& lo, const vec<3>& hi, index_t divisions = 1) {
  for (int a = 0; a < 3; ++a) detail::check_positive(hi[a] - lo[a], "tank", "edge length");
  detail::check_count(divisions, 1, "tank", "divisions");
  polygon_mesh<3> m = detail::box_surface(lo, hi, divisions, true);
  detail::flip_all(m);
  return m;
}

/// Circle of `segments` chords with vertices on the circle.
inline polygon_mesh<2> circle(const vec<2>& centre, double radius, index_t segments, fluid_side side) {
  detail::check_positive(radius, "circle", "radius");
  detail::check_count(segments, 3, "circle", "segments");
  std::vector<vec<2>> p;
  for (index_t i = 0; i < segments; ++i) {
    const double th = 2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(segments);
    p.push_back(centre + radius * vec<2>(std::cos(th), std::sin(th)));
  }
  return detail::closed_polygon(p, side);
}

/// Cylinder with axis +z from `base_centre`, `segments` around, `layers` along, optional flat caps.
inline polygon_mesh<3> cylinder(const vec<3>& base_centre, double radius, double height, index_t segments,
                                index_t layers, bool caps, fluid_side side) {
  detail::check_positive(radius, "cylinder", "radius");
  detail::check_positive(height, "cylinder", "height");
  detail::check_count(segments, 3, "cylinder", "segments");
  detail::check_count(layers, 1, "cylinder", "layers");
  std::vector<vec<2>> p;
  const vec<2> c = base_centre.head<2>();
  for (index_t i = 0; i < segments; ++i) {
    const double th = 2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(segments);
    p.push_back(c + radius * vec<2>(std::cos(th), std::sin(th)));
  }
  return detail::extrude(p, c, base_centre.z(), height, static_cast<int>(layers), caps, side);
}

/// Icosphere: an icosahedron subdivided `subdivisions` times (20·4^s triangles), vertices on the sphere.
inline polygon_mesh<3> sphere(const vec<3>& centre, double radius, int subdivisions, fluid_side side) {
  detail::check_positive(radius, "sphere", "radius");
  if (subdivisions < 0 || subdivisions > 8)
    fail("geometry::sphere: subdivisions = ", subdivisions, ", accepted range [0, 8]");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<vec<3>> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                           {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (vec<3>& x : v) x.normalize();
  std::vector<std::array<index_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                           {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                           {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                           {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<index_t, index_t>, index_t> mid;
    auto midpoint = [&](index_t a, index_t b) {
      const std::pair<index_t, index_t> key{std::min(a, b), std::max(a, b)};
      auto [it, inserted] = mid.try_emplace(key, static_cast<index_t>(v.size()));
      if (inserted) v.push_back((v[a] + v[b]).normalized());
      return it->second;
    };
    std::vector<std::array<index_t, 3>> g;
    for (const auto& tri : f) {
      const index_t ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]),
                    ca = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], ab, ca});
      g.push_back({tri[1], bc, ab});
      g.push_back({tri[2], ca, bc});
      g.push_back({ab, bc, ca});
    }
    f = std::move(g);
  }
  for (vec<3>& x : v) x = (centre + radius * x).eval();
  polygon_mesh<3> m = detail::make_mesh<3>(v, f);
  if (side == fluid_side::inside) detail::flip_all(m);
  return m;
}

/// Spur-gear outline (counter-clockwise before orientation): per tooth pitch p = 2π/teeth a root land
/// of 0.3p on the root circle, a straight flank over 0.15p, a tip land of 0.4p on the tip circle, and a
/// flank back over 0.15p. Tooth k's root land starts at angle `phase` + k p. Lands are straight chords
/// split into `land_segments` pieces.
inline std::vector<vec<2>> gear_profile(const vec<2>& centre, double tip_diameter, double root_diameter,
                                        index_t teeth, double phase = 0.0, index_t land_segments = 1) {
  detail::check_positive(root_diameter, "gear", "root_diameter");
  if (!(tip_diameter > root_diameter) || !std::isfinite(tip_diameter))
    fail("geometry::gear: tip_diameter = ", tip_diameter, ", accepted range (root_diameter = ", root_diameter,
         ", inf)");
  detail::check_count(teeth, 3, "gear", "teeth");
  detail::check_count(land_segments, 1, "gear", "land_segments");
  const double p = 2.0 * std::numbers::pi / static_cast<double>(teeth);
  const double rr = 0.5 * root_diameter, rt = 0.5 * tip_diameter;
  std::vector<vec<2>> out;
  auto at = [&](double r, double th) { return (centre + r * vec<2>(std::cos(th), std::sin(th))).eval(); };
  for (index_t k = 0; k < teeth; ++k) {
    const double th0 = phase + p * static_cast<double>(k);
    for (index_t s = 0; s <= land_segments; ++s) out.push_back(at(rr, th0 + 0.3 * p * s / land_segments));
    for (index_t s = 0; s <= land_segments; ++s)
      out.push_back(at(rt, th0 + 0.45 * p + 0.4 * p * s / land_segments));
  }
  return out;
}

/// 2D spur gear (see gear_profile); the fluid is usually outside.
inline polygon_mesh<2> gear(const vec<2>& centre, double tip_diameter, double root_diameter, index_t teeth,
                            fluid_side side = fluid_side::outside, double phase = 0.0,
                            index_t land_segments = 1) {
  return detail::closed_polygon(
      gear_profile(centre, tip_diameter, root_diameter, teeth, phase, land_segments), side);
}

/// 3D spur gear: the 2D profile extruded along +z from `base_centre` by `thickness`, with fan caps.
inline polygon_mesh<3> gear(const vec<3>& base_centre, double tip_diameter, double root_diameter,
                            index_t teeth, double thickness, fluid_side side = fluid_side::outside,
                            double phase = 0.0) {
  detail::check_positive(thickness, "gear", "thickness");
  const vec<2> c = base_centre.head<2>();
  return detail::extrude(gear_profile(c, tip_diameter, root_diameter, teeth, phase), c, base_centre.z(),
                         thickness, 1, true, side);
}

}  // namespace mpskit::geometry
