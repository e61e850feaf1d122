#pragma once
/// \file geometry/detail/primitives.hpp
/// \brief Closest point on a segment / triangle (Voronoi-region tests) and segment–element
/// intersection; the exact-arithmetic-free kernels under polygon_set.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "mpskit/core/dimension.hpp"

namespace mpskit::geometry {

/// Which feature of an element a closest point lies on.
enum class feature_kind : int {
  face = 0,    ///< interior of the segment (2D) or of the triangle (3D)
  edge = 1,    ///< 3D only: edge k joins local vertices k and (k+1)%3
  vertex = 2,  ///< local vertex k
};

namespace detail {

/// a × b written out (keeps the area on <Eigen/Core>; MatrixBase::cross lives in <Eigen/Geometry>).
inline vec<3> cross3(const vec<3>& a, const vec<3>& b) {
  return vec<3>(a.y() * b.z() - a.z() * b.y(), a.z() * b.x() - a.x() * b.z(), a.x() * b.y() - a.y() * b.x());
}

/// Closest point of one element; weights are barycentric (D entries: 2 for a segment, 3 for a triangle).
template <int D>
struct element_closest {
  vec<D> point;
  vec<D> weights;
  feature_kind kind = feature_kind::face;
  int local = -1;  ///< vertex or edge index inside the element; -1 for the face
};

/// Closest point on segment ab (standard clamp, ERP notes §3.1 / Ericson 2005 §5.1.2).
inline element_closest<2> closest_on_segment(const vec<2>& p, const vec<2>& a, const vec<2>& b) {
  element_closest<2> r;
  const vec<2> ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? (p - a).dot(ab) / len2 : 0.0;
  if (s <= 0.0) {
    r.point = a;
    r.weights << 1.0, 0.0;
    r.kind = feature_kind::vertex;
    r.local = 0;
  } else if (s >= 1.0) {
    r.point = b;
    r.weights << 0.0, 1.0;
    r.kind = feature_kind::vertex;
    r.local = 1;
  } else {
    r.point = a + s * ab;
    r.weights << 1.0 - s, s;
  }
  return r;
}

/// Closest point on triangle abc with barycentric weights: Voronoi-region tests of Ericson,
/// Real-Time Collision Detection (2005) pp. 136–142, as written out in /work/shared/methods/erp.md §3.1.
inline element_closest<3> closest_on_triangle(const vec<3>& p, const vec<3>& a, const vec<3>& b,
                                              const vec<3>& c) {
  element_closest<3> r;
  const vec<3> ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    r.point = a;
    r.weights << 1, 0, 0;
    r.kind = feature_kind::vertex;
    r.local = 0;
    return r;
  }
  const vec<3> bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    r.point = b;
    r.weights << 0, 1, 0;
    r.kind = feature_kind::vertex;
    r.local = 1;
    return r;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double t = d1 / (d1 - d3);
    r.point = a + t * ab;
    r.weights << 1.0 - t, t, 0.0;
    r.kind = feature_kind::edge;
    r.local = 0;
    return r;
  }
  const vec<3> cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    r.point = c;
    r.weights << 0, 0, 1;
    r.kind = feature_kind::vertex;
    r.local = 2;
    return r;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double t = d2 / (d2 - d6);
    r.point = a + t * ac;
    r.weights << 1.0 - t, 0.0, t;
    r.kind = feature_kind::edge;
    r.local = 2;  // edge 2 joins local vertices 2 and 0
    return r;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    r.point = b + t * (c - b);
    r.weights << 0.0, 1.0 - t, t;
    r.kind = feature_kind::edge;
    r.local = 1;
    return r;
  }
  const double s = 1.0 / (va + vb + vc);
  const double v = vb * s, w = vc * s;
  r.point = a + v * ab + w * ac;
  r.weights << 1.0 - v - w, v, w;
  return r;
}

/// Closest point on element with vertices given as the columns of `v` (D×D: segment in 2D, triangle in 3D).
template <int D>
inline element_closest<D> closest_on_element(const vec<D>& p, const mat<D>& v) {
  if constexpr (D == 2) {
    return closest_on_segment(p, v.col(0), v.col(1));
  } else {
    return closest_on_triangle(p, v.col(0), v.col(1), v.col(2));
  }
}

inline double cross2(const vec<2>& a, const vec<2>& b) { return a.x() * b.y() - a.y() * b.x(); }

/// Parameter t in [0,1] where segment p→q meets segment a→b, or a negative value if it does not.
/// Endpoints and touching count as a meeting (closed test, conservative for visibility); a collinear
/// overlap returns the first overlap parameter.
inline double segment_hits_segment(const vec<2>& p, const vec<2>& q, const vec<2>& a, const vec<2>& b) {
  const vec<2> d = q - p, e = b - a;
  const double o1 = cross2(e, p - a), o2 = cross2(e, q - a);  // sides of p and q w.r.t. line ab
  const double o3 = cross2(d, a - p), o4 = cross2(d, b - p);  // sides of a and b w.r.t. line pq
  if ((o1 > 0.0 && o2 > 0.0) || (o1 < 0.0 && o2 < 0.0)) return -1.0;
  if ((o3 > 0.0 && o4 > 0.0) || (o3 < 0.0 && o4 < 0.0)) return -1.0;
  if (o1 != o2) return o1 / (o1 - o2);
  // collinear (or p == q on the line): overlap of parameters of a and b along pq
  const double dd = d.squaredNorm();
  if (dd == 0.0) {
    const double ee = e.squaredNorm();
    const double s = ee > 0.0 ? (p - a).dot(e) / ee : 0.0;
    return (s >= 0.0 && s <= 1.0 && (a + s * e - p).squaredNorm() == 0.0) ? 0.0 : -1.0;
  }
  const double ta = (a - p).dot(d) / dd, tb = (b - p).dot(d) / dd;
  const double lo = std::max(0.0, std::min(ta, tb)), hi = std::min(1.0, std::max(ta, tb));
  return lo <= hi ? lo : -1.0;
}

/// Parameter t in [0,1] where segment p→q meets triangle abc (Möller & Trumbore 1997), or a negative
/// value. Barycentric bounds are widened by `tol` so that a segment through a shared edge cannot slip
/// between two triangles through rounding; a segment lying in the triangle's plane is not counted.
inline double segment_hits_triangle(const vec<3>& p, const vec<3>& q, const vec<3>& a, const vec<3>& b,
                                    const vec<3>& c, double tol = 1e-12) {
  const vec<3> dir = q - p, e1 = b - a, e2 = c - a;
  const vec<3> h = cross3(dir, e2);
  const double det = e1.dot(h);
  const double scale = dir.norm() * e1.norm() * e2.norm();
  if (!(std::abs(det) > 1e-14 * scale)) return -1.0;
  const double inv = 1.0 / det;
  const vec<3> s = p - a;
  const double u = s.dot(h) * inv;
  if (u < -tol || u > 1.0 + tol) return -1.0;
  const vec<3> qv = cross3(s, e1);
  const double v = dir.dot(qv) * inv;
  if (v < -tol || u + v > 1.0 + tol) return -1.0;
  const double t = e2.dot(qv) * inv;
  if (t < 0.0 || t > 1.0) return -1.0;
  return t;
}

/// Segment p→q against an element (columns of v are its vertices).
template <int D>
inline double segment_hits_element(const vec<D>& p, const vec<D>& q, const mat<D>& v) {
  if constexpr (D == 2) {
    return segment_hits_segment(p, q, v.col(0), v.col(1));
  } else {
    return segment_hits_triangle(p, q, v.col(0), v.col(1), v.col(2));
  }
}

/// Unnormalised element normal from the winding: 2D segment a→b gives the left normal (-dy, dx);
/// 3D triangle abc gives (b−a)×(c−a). Its length is the segment length or twice the triangle area.
template <int D>
inline vec<D> winding_normal(const mat<D>& v) {
  if constexpr (D == 2) {
    const vec<2> d = v.col(1) - v.col(0);
    return vec<2>(-d.y(), d.x());
  } else {
    const vec<3> e1 = v.col(1) - v.col(0), e2 = v.col(2) - v.col(0);
    return cross3(e1, e2);
  }
}

}  // namespace detail
}  // namespace mpskit::geometry
