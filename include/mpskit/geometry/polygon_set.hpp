#pragma once
/// \file geometry/polygon_set.hpp
/// \brief polygon_set<D>: segments (D = 2) or triangles (D = 3) with a bounding-volume hierarchy,
/// closest points, signed distance (angle-weighted pseudo-normals), Tanaka's wall curvature, rigid
/// motion with a wall velocity field, and segment-crossing tests.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/geometry/detail/bvh.hpp"
#include "mpskit/geometry/detail/primitives.hpp"
#include "mpskit/geometry/motion.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"

namespace mpskit::geometry {

/// Construction options of a polygon set.
template <int D>
struct polygon_options {
  /// Angle (degrees) between the normals of two elements sharing a facet above which the facet is a
  /// feature edge (2D: feature vertex): corner normals are not averaged across it and elements next
  /// to it get curvature 0. Accepted range [0, 180].
  double feature_angle_deg = 30.0;
  /// Make orientation consistent inside each connected component (majority of elements wins).
  bool orient_consistently = true;
  /// Optional point in the fluid: each component is flipped so that it lies on the fluid side.
  std::optional<vec<D>> fluid_seed;
};

/// Result of a closest-point query.
template <int D>
struct closest_point {
  vec<D> point = vec<D>::Zero();    ///< closest point on the walls (m)
  index_t element = npos;           ///< element holding it; npos if nothing within the search radius
  vec<D> weights = vec<D>::Zero();  ///< barycentric weights of the element's D vertices (sum 1)
  double distance = std::numeric_limits<double>::infinity();  ///< unsigned distance (m)
  feature_kind kind = feature_kind::face;                     ///< face, edge (3D) or vertex the point lies on
  int local = -1;  ///< local edge/vertex index of that feature, -1 for the face
  /// True if an element was found.
  bool found() const { return element != npos; }
};

/// Everything a polygon wall model needs at one fluid particle (imaginary particles, Tanaka 2018
/// §4.5.1; ERP, Mitsume 2015 §3.1 notes).
template <int D>
struct wall_point : closest_point<D> {
  /// Signed distance (m): positive on the fluid side (pseudo-normal sign test).
  double signed_distance = std::numeric_limits<double>::infinity();
  /// Unit normal toward the fluid with x = point + signed_distance · normal (Tanaka eq. 75 with
  /// r_iw = signed_distance); the pseudo-normal when x lies on the wall.
  vec<D> normal = vec<D>::Zero();
  /// Curvature σ at the closest point (Tanaka 2018 eq. 77; +1/R for fluid inside a circle/sphere).
  double curvature = 0.0;
  /// Wall velocity at the closest point (m/s).
  vec<D> velocity = vec<D>::Zero();
};

/// A segment a→b meeting the walls (first hit along the segment).
template <int D>
struct crossing {
  double t = 0.0;                  ///< parameter in [0, 1]: point = a + t (b − a)
  vec<D> point = vec<D>::Zero();   ///< crossing point (m)
  index_t element = npos;          ///< element crossed
  vec<D> normal = vec<D>::Zero();  ///< unit element normal, pointing to the fluid side
  bool entering = false;           ///< moving against the normal: from the fluid side into the wall
};

/// Segments (D = 2) or triangles (D = 3) describing walls, with the fluid on the side of the winding
/// normal (2D: left of a→b; 3D: (b−a)×(c−a)). See docs/geometry.md.
template <int D>
requires Dimension<D>
class polygon_set final {
 /// spatial dimension
 public: static constexpr int dimension = D;
  using vector_type = vec<D>;          ///< point type

  /// Builds the set: validates (finite coordinates, indices in range, no degenerate element),
  /// orients (options), computes normals and topology, builds the hierarchy.
  explicit polygon_set(polygon_mesh<D> mesh, const polygon_options<D>& options = {},
                       prescribed_motion<D> motion = {})
      : motion_(std::move(motion)) {
    if (!(options.feature_angle_deg >= 0.0 && options.feature_angle_deg <= 180.0))
      fail("geometry::polygon_options: feature_angle_deg = ", options.feature_angle_deg,
           ", accepted range [0, 180]");
    validate(mesh);
    if (mesh.size() == 0) fail("geometry::polygon_set: no elements");
    {
      const quality_report q0 = analyse(mesh);
      if (!q0.degenerate.empty())
        fail("geometry::polygon_set: element ", q0.degenerate.front(),
             " is degenerate (zero length/area or repeated vertex; ", q0.degenerate.size(),
             " in total); drop it before building (reader option drop_degenerate)");
    }
    index_t flipped = 0;
    if (options.orient_consistently) flipped += orient_consistently(mesh);
    if (options.fluid_seed) flipped += orient_towards(mesh, *options.fluid_seed);
    quality_ = analyse(mesh);
    quality_.flipped = flipped;
    cos_feature_ = std::cos(options.feature_angle_deg * std::numbers::pi / 180.0);
    ref_vertices_ = mesh.vertices;
    vertices_ = mesh.vertices;
    elements_ = std::move(mesh.elements);
    scale_ = detail::bbox_diagonal<D>(ref_vertices_);
    compute_normals_and_topology();
    convex_ = compute_convex();
    hierarchy_.build(size(), [this](index_t e) { return element_box(e); });
    if (motion_.moves()) move_to(0.0);
  }

  /// Number of elements.
  index_t size() const { return elements_.cols(); }
  /// Current vertex coordinates.
  const points<D>& vertices() const { return vertices_; }
  /// Connectivity (after orientation).
  const element_indices<D>& elements() const { return elements_; }
  /// The D vertices of element e (current pose) as matrix columns.
  mat<D> element(index_t e) const {
    mat<D> m;
    for (int k = 0; k < D; ++k) m.col(k) = vertices_.col(elements_(k, e));
    return m;
  }
  /// Current mesh (vertices in the current pose).
  polygon_mesh<D> mesh() const { return {vertices_, elements_}; }
  /// Quality report of the (oriented) set.
  const quality_report& quality() const { return quality_; }
  /// Unit normal of element e, toward the fluid.
  vec<D> element_normal(index_t e) const { return normals_.col(e); }
  /// Corner normal of element e at local vertex k: averaged over the elements around the vertex that
  /// are reachable without crossing a feature facet (used by the curvature, Tanaka eq. 77).
  vec<D> corner_normal(index_t e, int k) const { return corner_normals_.col(e * D + k); }
  /// True if a vertex of element e lies on a feature facet (or a non-manifold one): its curvature is 0.
  bool feature_adjacent(index_t e) const { return feature_adjacent_[e] != 0; }
  /// Bounding-box diagonal of the reference geometry (m).
  double scale() const { return scale_; }
  /// True when every vertex lies on the fluid side of every element's plane (to 1e-12 scale()): the fluid
  /// side ∩ {y : (y − v_e)·n_e ≥ 0} is then convex with every element on its boundary (tanks, boxes, prisms,
  /// ducts; not a tank with an obstacle, a step or a thin plate). Checked once at construction for sets of up
  /// to convex_check_max_elements elements (larger: false); poses are rigid, so it holds in every pose.
  bool convex() const { return convex_; }
  static constexpr index_t convex_check_max_elements = 4096;

  /// Closest point within max_distance (default: anywhere); ties within a relative 1e-12 of the
  /// squared distance go to the lower element index so results are deterministic (ERP notes §3.1).
  closest_point<D> closest(const vec<D>& x,
                           double max_distance = std::numeric_limits<double>::infinity()) const {
    closest_point<D> best;
    double best2 = max_distance * max_distance;
    hierarchy_.nearest(
        x, [&](index_t e) { consider(x, e, best, best2); },
        [&]() { return best2 * (1.0 + tie_tol) + tiny2; });
    if (best.found()) best.distance = std::sqrt(best2);
    return best;
  }

  /// The same query by testing every element (reference for tests).
  closest_point<D> closest_brute_force(const vec<D>& x) const {
    closest_point<D> best;
    double best2 = std::numeric_limits<double>::infinity();
    for (index_t e = 0; e < size(); ++e) consider(x, e, best, best2);
    best.distance = std::sqrt(best2);
    return best;
  }

  /// Angle-weighted pseudo-normal (unit) of the feature holding a closest point (Bærentzen & Aanæs,
  /// IEEE TVCG 11(3) 2005, Theorem 1): face normal, edge normal (sum of the adjacent face normals) or
  /// vertex normal (angle-weighted sum; 2D: sum of the two segment normals).
  vec<D> pseudo_normal(const closest_point<D>& c) const {
    MPSKIT_ASSERT(c.found());
    switch (c.kind) {
      case feature_kind::vertex:
        return vertex_normals_.col(elements_(c.local, c.element));
      case feature_kind::edge:
        return edge_normals_.col(c.element * D + c.local);
      default:
        return normals_.col(c.element);
    }
  }

  /// Signed distance (m): positive on the fluid side. Inside/outside is exact for closed, consistently
  /// oriented sets; near open edges it follows the pseudo-normal of the closest feature.
  /// A non-finite x gives NaN (nothing is found), so a broken particle position stays visible.
  double signed_distance(const vec<D>& x) const {
    const closest_point<D> c = closest(x);
    if (!c.found()) return std::numeric_limits<double>::quiet_NaN();
    return (x - c.point).dot(pseudo_normal(c)) < 0.0 ? -c.distance : c.distance;
  }

  /// Wall curvature at a closest point, Tanaka 2018 eq. (77):
  /// σ = −Σ_v w_v (n_t − n_v)·(n_t − n_v) / Σ_v w_v (x_t − x_v)·(n_t − n_v), with x_t, n_t the means of
  /// the element's vertices and corner normals and w_v the barycentric weights of the closest point.
  /// Sign: +1/R on a circle/sphere with the fluid inside, −1/R with the fluid outside. Elements with a
  /// vertex on a feature facet, and elements whose corner normals agree to 1e-10 (flat), return 0.
  double curvature(const closest_point<D>& c) const {
    MPSKIT_ASSERT(c.found());
    const index_t e = c.element;
    if (feature_adjacent_[e]) return 0.0;
    vec<D> xt = vec<D>::Zero(), nt = vec<D>::Zero();
    for (int k = 0; k < D; ++k) {
      xt += vertices_.col(elements_(k, e));
      nt += corner_normals_.col(e * D + k);
    }
    xt /= D;
    nt /= D;
    double num = 0.0, den = 0.0, dn_max = 0.0;
    for (int k = 0; k < D; ++k) {
      const vec<D> dn = nt - corner_normals_.col(e * D + k);
      const vec<D> dx = xt - vertices_.col(elements_(k, e));
      num += c.weights[k] * dn.squaredNorm();
      den += c.weights[k] * dx.dot(dn);
      dn_max = std::max(dn_max, dn.norm());
    }
    if (dn_max < 1e-10 || den == 0.0) return 0.0;
    return -num / den;
  }

  /// Wall velocity v_wall(x) at the current time (m/s).
  vec<D> velocity(const vec<D>& x) const { return motion_.velocity(x, time_); }

  /// Closest point, signed distance, normal, curvature and wall velocity for a particle at x; only
  /// walls within max_distance are considered (result.found() is false otherwise).
  wall_point<D> query(const vec<D>& x, double max_distance = std::numeric_limits<double>::infinity()) const {
    wall_point<D> r;
    static_cast<closest_point<D>&>(r) = closest(x, max_distance);
    if (!r.found()) return r;
    const vec<D> pn = pseudo_normal(r);
    const vec<D> d = x - r.point;
    const bool fluid_side = d.dot(pn) >= 0.0;
    r.signed_distance = fluid_side ? r.distance : -r.distance;
    r.normal = r.distance > 1e-12 * scale_ ? (d / r.signed_distance).eval() : pn;
    r.curvature = curvature(r);
    r.velocity = velocity(r.point);
    return r;
  }

  /// True if the closed segment a–b touches any element (pair visibility across thin walls).
  bool crosses(const vec<D>& a, const vec<D>& b) const {
    const vec<D> d = b - a;
    return hierarchy_.segment(
        a, d, [&](index_t e) { return detail::segment_hits_element<D>(a, b, element(e)) >= 0.0; });
  }

  /// First element met moving from a to b (smallest t; ties to the lower element), with the crossing
  /// point, the element's fluid-side normal and whether the move enters the wall (wall-crossing guard).
  std::optional<crossing<D>> first_crossing(const vec<D>& a, const vec<D>& b) const {
    return first_hit(a, b, false);
  }

  /// First crossing of a move a → b while the set itself moved rigidly from `previous_pose` to the
  /// current pose (moving walls): a is carried with the wall, a' = T_now(T_prev⁻¹(a)), and a'→b is
  /// tested against the current geometry, so a particle at rest swept by a wall is caught.
  std::optional<crossing<D>> first_crossing(const vec<D>& a, const vec<D>& b,
                                            const rigid_transform<D>& previous_pose) const {
    const vec<D> a_ref = previous_pose.rotation.transpose() * (a - previous_pose.translation);
    return first_crossing(pose_.apply(a_ref), b);
  }

  /// Calls f(c) for every element whose closest point to x lies within max_distance (closed:
  /// distance <= max_distance), with c the element's closest point (point, element, barycentric
  /// weights, unsigned distance, feature kind). Order: the hierarchy's traversal order, which depends
  /// on x only (deterministic); sort by c.element if an order is needed. Used by wall::make_imaginary
  /// (one imaginary copy per face, Tanaka 2018 §4.5.1 as extended by issue #7).
  template <class F>
  void for_each_element_within(const vec<D>& x, double max_distance, F&& f) const {
    if (!(max_distance >= 0.0)) return;
    const double bound2 = max_distance * max_distance;
    hierarchy_.nearest(
        x,
        [&](index_t e) {
          const detail::element_closest<D> ec = detail::closest_on_element<D>(x, element(e));
          const double d2 = (x - ec.point).squaredNorm();
          if (!(d2 <= bound2)) return;
          closest_point<D> c;
          c.point = ec.point;
          c.element = e;
          c.weights = ec.weights;
          c.distance = std::sqrt(d2);
          c.kind = ec.kind;
          c.local = ec.local;
          f(static_cast<const closest_point<D>&>(c));
        },
        [bound2]() { return bound2; });
  }

  /// Closest point of one element e to x (point, weights, unsigned distance, feature kind).
  closest_point<D> closest_on(index_t e, const vec<D>& x) const {
    MPSKIT_ASSERT(e >= 0 && e < size());
    const detail::element_closest<D> ec = detail::closest_on_element<D>(x, element(e));
    closest_point<D> c;
    c.point = ec.point;
    c.element = e;
    c.weights = ec.weights;
    c.distance = (x - ec.point).norm();
    c.kind = ec.kind;
    c.local = ec.local;
    return c;
  }

  /// First element *entered* moving from a to b: the smallest t among the elements the closed segment
  /// touches while moving against their fluid-side normal (ties to the lower element). Unlike
  /// first_crossing, a leaving hit at a smaller t (from behind an element) does not hide a later
  /// entering one; with a double-sided thin wall (two coincident elements of opposite orientation)
  /// every crossing enters one of the two (wall-crossing guard, docs/walls.md).
  std::optional<crossing<D>> first_entering_crossing(const vec<D>& a, const vec<D>& b) const {
    return first_hit(a, b, true);
  }

  /// first_entering_crossing for a set that moved rigidly from `previous_pose` to the current pose:
  /// a is carried with the wall (as in the three-argument first_crossing).
  std::optional<crossing<D>> first_entering_crossing(const vec<D>& a, const vec<D>& b,
                                                     const rigid_transform<D>& previous_pose) const {
    const vec<D> a_ref = previous_pose.rotation.transpose() * (a - previous_pose.translation);
    return first_entering_crossing(pose_.apply(a_ref), b);
  }

  /// Sets the pose from the prescribed motion at time t and refits the hierarchy.
  void move_to(double t) {
    time_ = t;
    if (motion_.moves()) apply_pose(motion_.pose(t));
  }
  /// Sets the pose directly (rigid bodies coupled to the fluid) and refits; the time is unchanged.
  void set_pose(const rigid_transform<D>& pose) { apply_pose(pose); }
  /// Current pose relative to the reference geometry.
  const rigid_transform<D>& pose() const { return pose_; }
  /// Current time of the motion (s).
  double time() const { return time_; }
  /// Replaces the prescribed motion (the pose is not changed until move_to()).
  void set_motion(prescribed_motion<D> motion) { motion_ = std::move(motion); }
  /// The prescribed motion.
  const prescribed_motion<D>& motion() const { return motion_; }

 private:
  static constexpr double tie_tol = 1e-12;
  static constexpr double tiny2 = 1e-300;

  /// The element the closed segment a→b meets first (smallest t, ties to the lower element); with
  /// entering_only, elements the move leaves (d·n ≥ 0) are skipped.
  std::optional<crossing<D>> first_hit(const vec<D>& a, const vec<D>& b, bool entering_only) const {
    const vec<D> d = b - a;
    double best_t = std::numeric_limits<double>::infinity();
    index_t best_e = npos;
    hierarchy_.segment(a, d, [&](index_t e) {
      if (entering_only && !(d.dot(normals_.col(e)) < 0.0)) return false;
      const double t = detail::segment_hits_element<D>(a, b, element(e));
      if (t >= 0.0 && (t < best_t || (t == best_t && e < best_e))) {
        best_t = t;
        best_e = e;
      }
      return false;
    });
    if (best_e == npos) return std::nullopt;
    crossing<D> c;
    c.t = best_t;
    c.point = a + best_t * d;
    c.element = best_e;
    c.normal = normals_.col(best_e);
    c.entering = d.dot(c.normal) < 0.0;
    return c;
  }

  bool compute_convex() const {
    if (size() == 0 || size() > convex_check_max_elements) return false;
    const double tol = 1e-12 * scale_;
    for (index_t e = 0; e < size(); ++e) {
      const vec<D> q = ref_vertices_.col(elements_(0, e)), n = normals_.col(e);
      for (index_t k = 0; k < ref_vertices_.cols(); ++k)
        if ((ref_vertices_.col(k) - q).dot(n) < -tol) return false;
    }
    return true;
  }

  void consider(const vec<D>& x, index_t e, closest_point<D>& best, double& best2) const {
    const detail::element_closest<D> c = detail::closest_on_element<D>(x, element(e));
    const double d2 = (x - c.point).squaredNorm();
    const bool better = best.element == npos ? d2 <= best2
                                             : (d2 < best2 * (1.0 - tie_tol) ||
                                                (d2 <= best2 * (1.0 + tie_tol) + tiny2 && e < best.element));
    if (!better) return;
    best2 = d2;
    best.point = c.point;
    best.element = e;
    best.weights = c.weights;
    best.kind = c.kind;
    best.local = c.local;
  }

  detail::aabb<D> element_box(index_t e) const {
    detail::aabb<D> b;
    for (int k = 0; k < D; ++k) b.grow(vertices_.col(elements_(k, e)));
    return b;
  }

  void apply_pose(const rigid_transform<D>& pose) {
    if (!pose.rotation.allFinite() || !pose.translation.allFinite())
      fail("geometry::polygon_set: pose has a non-finite entry");
    pose_ = pose;
    vertices_ = (pose.rotation * ref_vertices_).colwise() + pose.translation;
    normals_ = pose.rotation * ref_normals_;
    corner_normals_ = pose.rotation * ref_corner_normals_;
    vertex_normals_ = pose.rotation * ref_vertex_normals_;
    if constexpr (D == 3) edge_normals_ = pose.rotation * ref_edge_normals_;
    hierarchy_.refit([this](index_t e) { return element_box(e); });
  }

  void compute_normals_and_topology() {
    const index_t n = size(), nv = ref_vertices_.cols();
    const polygon_mesh<D> m{ref_vertices_, elements_};
    ref_normals_.resize(D, n);
    for (index_t e = 0; e < n; ++e)
      ref_normals_.col(e) = detail::winding_normal<D>(m.element(e)).normalized();
    // vertex pseudo-normals: angle-weighted (Bærentzen & Aanæs 2005 eq. 2; 2D: equal weights)
    ref_vertex_normals_ = points<D>::Zero(D, nv);
    for (index_t e = 0; e < n; ++e) {
      const mat<D> v = m.element(e);
      for (int k = 0; k < D; ++k)
        ref_vertex_normals_.col(elements_(k, e)) += detail::corner_weight<D>(v, k) * ref_normals_.col(e);
    }
    normalise_columns(ref_vertex_normals_);
    feature_adjacent_.assign(static_cast<std::size_t>(n), 0);
    std::vector<char> feature_vertex(static_cast<std::size_t>(nv), 0);
    const std::vector<detail::facet_use> uses = detail::facet_uses(m);
    detail::disjoint_sets corners(n * D);
    if constexpr (D == 3) ref_edge_normals_ = points<D>::Zero(D, n * D);
    detail::for_each_facet(uses, [&](std::size_t i, std::size_t j) {
      if constexpr (D == 3) {
        vec<D> s = vec<D>::Zero();
        for (std::size_t k = i; k < j; ++k) s += ref_normals_.col(uses[k].element);
        if (s.norm() < 1e-12) s = ref_normals_.col(uses[i].element);  // folded sheet: no preferred side
        for (std::size_t k = i; k < j; ++k)
          ref_edge_normals_.col(uses[k].element * D + uses[k].local) = s.normalized();
      }
      const std::size_t uses_n = j - i;
      if (uses_n == 1) return;  // open facet: not a feature
      bool feature = uses_n > 2;
      if (uses_n == 2) {
        const double c = ref_normals_.col(uses[i].element).dot(ref_normals_.col(uses[i + 1].element));
        feature = c < cos_feature_ || uses[i].dir == uses[i + 1].dir;
      }
      if (feature) {
        for (int s = 0; s < D - 1; ++s)
          feature_vertex[elements_((uses[i].local + s) % D, uses[i].element)] = 1;
        return;
      }
      const index_t e1 = uses[i].element, e2 = uses[i + 1].element;
      for (int s = 0; s < D - 1; ++s) {  // the facet's vertices: 1 in 2D, 2 in 3D
        const index_t vid = elements_((uses[i].local + s) % D, e1);
        int k2 = 0;
        while (elements_(k2, e2) != vid) ++k2;
        corners.unite(e1 * D + (uses[i].local + s) % D, e2 * D + k2);
      }
    });
    // elements with a vertex on a feature facet get σ = 0 (Tanaka's eq. 77 assumes a smooth wall)
    for (index_t e = 0; e < n; ++e)
      for (int k = 0; k < D; ++k)
        if (feature_vertex[elements_(k, e)]) feature_adjacent_[e] = 1;
    // corner normals: Max (1999) weighted sum over each smooth group of corners
    points<D> group_sum = points<D>::Zero(D, n * D);
    for (index_t e = 0; e < n; ++e) {
      const mat<D> v = m.element(e);
      for (int k = 0; k < D; ++k)
        group_sum.col(corners.find(e * D + k)) += detail::max_weight<D>(v, k) * ref_normals_.col(e);
    }
    ref_corner_normals_.resize(D, n * D);
    for (index_t c = 0; c < n * D; ++c)
      ref_corner_normals_.col(c) = group_sum.col(corners.find(c)).normalized();
    normals_ = ref_normals_;
    vertex_normals_ = ref_vertex_normals_;
    corner_normals_ = ref_corner_normals_;
    edge_normals_ = ref_edge_normals_;
  }

  static void normalise_columns(points<D>& p) {
    for (index_t i = 0; i < p.cols(); ++i) {
      const double l = p.col(i).norm();
      if (l > 0.0) p.col(i) /= l;
    }
  }

  points<D> ref_vertices_, vertices_;
  element_indices<D> elements_;
  points<D> ref_normals_, normals_;                // per element
  points<D> ref_corner_normals_, corner_normals_;  // per element corner (e * D + k)
  points<D> ref_vertex_normals_, vertex_normals_;  // per vertex (pseudo-normals)
  points<D> ref_edge_normals_, edge_normals_;      // 3D: per element edge (e * D + k)
  std::vector<char> feature_adjacent_;
  quality_report quality_;
  detail::bvh<D> hierarchy_;
  prescribed_motion<D> motion_;
  rigid_transform<D> pose_;
  double time_ = 0.0;
  double cos_feature_ = 0.0;
  double scale_ = 0.0;
  bool convex_ = false;
};

}  // namespace mpskit::geometry
