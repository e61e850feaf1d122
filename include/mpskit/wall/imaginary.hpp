#pragma once
/// \file wall/imaginary.hpp
/// \brief Imaginary wall particles on polygon walls (Tanaka, Cardoso & Bahai 2018 §4.5.1, eqs. 75–77,
/// with the corner rules of issue #7): every eligible fluid particle within α_w L_i of a wall is copied
/// onto the wall each step. One copy per face at concave corners, one copy at convex corners
/// (duplicates removed and counted), L′ from the wall curvature (eq. 76) with a guarded small-denominator
/// case. See docs/walls.md for the rules and the readings of the paper.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/wall_collection.hpp"
#include "mpskit/wall/detail/wall_sets.hpp"

namespace mpskit::wall {

/// Parameters of the imaginary-particle generation (Tanaka 2018 Table 1: α_w = 1.0).
struct imaginary_params {
  /// α_w: a particle is copied onto each wall closer than α_w L_i (Tanaka eq. 75 text). Range (0, ∞).
  double alpha_w = 1.0;
  /// When 1 − r σ < small_ratio, eq. (76) is replaced by L′ = 2 L and the event is counted (issue #7).
  /// Range (0, 1].
  double small_ratio = 0.5;
  /// Copies whose normals differ by less than this angle (degrees) are one wall seen twice (the two
  /// triangles of a face, neighbouring segments of a smooth polyline): only the nearest is kept.
  /// Faces meeting at a larger angle (concave corners) each keep their copy. Range [0, 90].
  double merge_angle_deg = 30.0;

  /// Throws mpskit::error naming the first bad value and its accepted range.
  void validate() const {
    if (!(std::isfinite(alpha_w) && alpha_w > 0.0))
      fail("wall::imaginary_params: alpha_w = ", alpha_w, ", accepted range (0, inf)");
    if (!(small_ratio > 0.0 && small_ratio <= 1.0))
      fail("wall::imaginary_params: small_ratio = ", small_ratio, ", accepted range (0, 1]");
    if (!(merge_angle_deg >= 0.0 && merge_angle_deg <= 90.0))
      fail("wall::imaginary_params: merge_angle_deg = ", merge_angle_deg, ", accepted range [0, 90]");
  }
};

/// One imaginary wall particle (a ghost: role ghost_role::imaginary, regenerated every step).
/// The scene policy naming polygon walls with imaginary particles (`using walls = mpskit::wall::imaginary;`),
/// run by scheme::lsmps_semi_implicit; the numbers are in imaginary_params.
struct imaginary final {
  using params_type = imaginary_params;
};

template <int D>
struct imaginary_copy {
  index_t parent = npos;              ///< real particle it was copied from
  index_t element = npos;             ///< wall element holding the copy (lowest index at a corner)
  vec<D> weights = vec<D>::Zero();    ///< barycentric weights of x on the element (sum 1)
  vec<D> x = vec<D>::Zero();          ///< position on the wall (m), Tanaka eq. (75)
  vec<D> normal = vec<D>::Zero();     ///< unit normal toward the fluid
  double L = 0.0;                     ///< diameter L′ (m), Tanaka eq. (76)
  vec<D> wall_velocity = vec<D>::Zero();  ///< wall velocity at x (m/s); zero for fixed walls
  index_t set = 0;                    ///< polygon set of the element (0 for a single polygon_set)
};

/// Counters of one generation pass.
template <int D>
struct imaginary_report {
  index_t copies = 0;                     ///< copies written
  index_t small_diameter_events = 0;      ///< copies with 1 − r σ < small_ratio (L′ = 2 L used)
  index_t convex_duplicates_removed = 0;  ///< extra elements giving the same convex corner point
  index_t smooth_duplicates_removed = 0;  ///< copies dropped as the same wall seen twice (merge angle)
  index_t wrong_side = 0;                 ///< eligible particles near a wall but behind it (no copy)
};

namespace detail {

template <int D>
struct candidate {
  index_t set = 0;
  geometry::closest_point<D> c;
  vec<D> normal = vec<D>::Zero();
  index_t group = 1;  // elements merged into this candidate at a corner point
  bool convex = false;
};

/// Copies of one particle (appends to `out`, adds to `rep`). See docs/walls.md §imaginary for the rules.
template <int D>
void copies_of(index_t i, const vec<D>& x, double L, const set_view<D>& sets, const imaginary_params& p,
               std::vector<candidate<D>>& cand, std::vector<candidate<D>>& keep,
               std::vector<imaginary_copy<D>>& out, imaginary_report<D>& rep) {
  const double r_max = p.alpha_w * L;  // Tanaka §4.5.1: a copy when r_iw < α_w L_i
  const double tol = 1e-9 * L;         // geometric coincidence (points shared by elements)
  cand.clear();
  keep.clear();
  for (index_t k = 0; k < sets.size(); ++k)
    sets[k].for_each_element_within(x, r_max, [&](const geometry::closest_point<D>& c) {
      if (c.distance < r_max) cand.push_back({k, c, vec<D>::Zero(), 1, false});
    });
  if (cand.empty()) return;
  std::sort(cand.begin(), cand.end(), [](const candidate<D>& a, const candidate<D>& b) {
    return a.set < b.set || (a.set == b.set && a.c.element < b.c.element);
  });

  // "Seen from the front": (x − q)·n ≥ 0 with n the element normal for a face point and the
  // angle-weighted pseudo-normal (Bærentzen & Aanæs 2005) of the edge or vertex otherwise — unless that
  // pseudo-normal points away from the element's own normal (pn·n_e < 0: the folded edge of a
  // double-sided sheet, whose pseudo-normal is one side's), where the element normal decides.
  auto front = [&](const candidate<D>& c) {
    const geometry::polygon_set<D>& s = sets[c.set];
    const vec<D> ne = s.element_normal(c.c.element);
    vec<D> n = ne;
    if (c.c.kind != geometry::feature_kind::face) {
      const vec<D> pn = s.pseudo_normal(c.c);
      if (pn.dot(ne) >= 0.0) n = pn;
    }
    return (x - c.c.point).dot(n) >= 0.0;
  };
  // Side test at the closest point(s): the particle is on the fluid side if one of the elements
  // closest to it (ties within tol) sees it from the front. The tie keeps double-sided thin walls (two
  // coincident elements of opposite orientation) working from both sides.
  double d_min = cand.front().c.distance;
  for (const candidate<D>& c : cand) d_min = std::min(d_min, c.c.distance);
  bool fluid_side = false;
  for (const candidate<D>& c : cand)
    if (c.c.distance <= d_min + tol && front(c)) fluid_side = true;
  if (!fluid_side) {
    ++rep.wrong_side;
    return;
  }

  // 1. Faces seen from the front: one copy per face (concave corners), at the foot of the
  //    perpendicular, normal = element normal (Tanaka eq. 75: x′ = x − r n).
  for (candidate<D>& c : cand) {
    if (c.c.kind != geometry::feature_kind::face) continue;
    if (!front(c)) continue;  // seen from behind: the other side of a thin wall
    c.normal = sets[c.set].element_normal(c.c.element);
    keep.push_back(c);
  }
  // 2. Edge/vertex points: kept only if no element through that point has a closer point or a face
  //    point at the same distance (otherwise the point is the end of a face whose own foot is nearer
  //    or equal: a floor split into segments, the diagonal of a quad). Kept points are grouped by position:
  //    one copy per point, normal (x − q)/|x − q|; the extra elements are convex duplicates (counted) when
  //    the group's normals span the merge angle, else the same smooth wall.
  const std::size_t n_faces = keep.size();
  for (std::size_t a = 0; a < cand.size(); ++a) {
    const candidate<D>& c = cand[a];
    if (c.c.kind == geometry::feature_kind::face) continue;
    const geometry::polygon_set<D>& s = sets[c.set];
    bool genuine = true;
    for (std::size_t b = 0; b < cand.size() && genuine; ++b) {
      if (b == a || cand[b].set != c.set) continue;
      // a closer element through q, or a face through q at the same distance (x above the shared
      // diagonal of two triangles: the face's own foot is the copy)
      const bool face_tie =
          cand[b].c.kind == geometry::feature_kind::face && cand[b].c.distance <= c.c.distance + tol;
      if (!(cand[b].c.distance < c.c.distance - tol) && !face_tie) continue;
      if (s.closest_on(cand[b].c.element, c.c.point).distance <= tol) genuine = false;
    }
    if (!genuine) continue;
    if (!front(c)) continue;  // behind this corner
    bool merged = false;
    for (std::size_t g = n_faces; g < keep.size(); ++g) {
      candidate<D>& k = keep[g];
      if (k.set != c.set || (k.c.point - c.c.point).norm() > tol) continue;
      ++k.group;
      if (s.element_normal(k.c.element).dot(s.element_normal(c.c.element)) <
          std::cos(p.merge_angle_deg * std::numbers::pi / 180.0) - 1e-12)
        k.convex = true;
      merged = true;
      break;
    }
    if (merged) continue;
    candidate<D> k = c;
    const vec<D> d = x - c.c.point;
    const double dn = d.norm();
    k.normal = dn > tol ? (d / dn).eval() : s.pseudo_normal(c.c);
    keep.push_back(k);
  }
  for (std::size_t g = n_faces; g < keep.size(); ++g) {
    if (keep[g].convex)
      rep.convex_duplicates_removed += keep[g].group - 1;
    else
      rep.smooth_duplicates_removed += keep[g].group - 1;
  }

  // 3. Merge copies of the same wall seen twice (normals within the merge angle): nearest first, ties
  //    to the lower (set, element), so the result does not depend on the traversal order.
  std::sort(keep.begin(), keep.end(), [](const candidate<D>& a, const candidate<D>& b) {
    if (a.c.distance != b.c.distance) return a.c.distance < b.c.distance;
    return a.set < b.set || (a.set == b.set && a.c.element < b.c.element);
  });
  const double cos_merge = std::cos(p.merge_angle_deg * std::numbers::pi / 180.0) - 1e-12;
  const std::size_t first = out.size();
  std::size_t accepted = 0;
  for (std::size_t a = 0; a < keep.size(); ++a) {
    bool dup = false;
    for (std::size_t b = 0; b < accepted && !dup; ++b) dup = keep[b].normal.dot(keep[a].normal) >= cos_merge;
    if (dup) {
      ++rep.smooth_duplicates_removed;
      continue;
    }
    keep[accepted++] = keep[a];
  }
  keep.resize(accepted);
  std::sort(keep.begin(), keep.end(), [](const candidate<D>& a, const candidate<D>& b) {
    return a.set < b.set || (a.set == b.set && a.c.element < b.c.element);
  });
  for (const candidate<D>& k : keep) {
    const geometry::polygon_set<D>& s = sets[k.set];
    imaginary_copy<D> cp;
    cp.parent = i;
    cp.element = k.c.element;
    cp.set = k.set;
    cp.weights = k.c.weights;
    cp.x = k.c.point;  // = x − r n (eq. 75) up to rounding: the foot itself lies on the element
    cp.normal = k.normal;
    // Tanaka eq. (76) L′ = L / (1 − r σ) with σ from eq. (77) at the copy's element and weights;
    // issue #7: L′ = 2 L (counted) when 1 − r σ < small_ratio (r σ → 1 near a tight concave bend).
    const double sigma = s.curvature(k.c);
    const double den = 1.0 - k.c.distance * sigma;
    if (den < p.small_ratio) {
      cp.L = 2.0 * L;
      ++rep.small_diameter_events;
    } else {
      cp.L = L / den;
    }
    cp.wall_velocity = s.velocity(cp.x);
    out.push_back(cp);
  }
  rep.copies += static_cast<index_t>(out.size() - first);
}

template <int D, Execution E, class Eligible>
imaginary_report<D> make_imaginary(E e, const points<D>& x, const Eigen::VectorXd& L, index_t n_real,
                                   const Eligible& eligible, const set_view<D>& sets,
                                   const imaginary_params& p, std::vector<imaginary_copy<D>>& out) {
  p.validate();
  if (n_real < 0 || n_real > x.cols())
    fail("wall::make_imaginary: n_real = ", n_real, ", accepted range [0, ", x.cols(), "] (columns of x)");
  if (L.size() < n_real)
    fail("wall::make_imaginary: L has ", L.size(), " entries, needs at least n_real = ", n_real);
  constexpr index_t block = 1024;
  const index_t nb = (n_real + block - 1) / block;
  std::vector<std::vector<imaginary_copy<D>>> parts(static_cast<std::size_t>(nb));
  std::vector<imaginary_report<D>> reps(static_cast<std::size_t>(nb));
  std::vector<index_t> bad(static_cast<std::size_t>(nb), npos);
  for_each_block(e, n_real, block, [&](index_t b, index_t lo, index_t hi) {
    std::vector<candidate<D>> cand, keep;
    std::vector<imaginary_copy<D>>& part = parts[static_cast<std::size_t>(b)];
    for (index_t i = lo; i < hi; ++i) {
      if (!eligible(i)) continue;
      const double Li = L[i];
      if (!(std::isfinite(Li) && Li > 0.0)) {
        bad[static_cast<std::size_t>(b)] = i;
        return;
      }
      const vec<D> xi = x.col(i);
      copies_of<D>(i, xi, Li, sets, p, cand, keep, part, reps[static_cast<std::size_t>(b)]);
    }
  });
  for (index_t b = 0; b < nb; ++b)
    if (bad[static_cast<std::size_t>(b)] != npos) {
      const index_t i = bad[static_cast<std::size_t>(b)];
      fail("wall::make_imaginary: particle ", i, " has diameter L = ", L[i], ", accepted range (0, inf)");
    }
  imaginary_report<D> rep;
  out.clear();
  for (index_t b = 0; b < nb; ++b) {
    const auto& part = parts[static_cast<std::size_t>(b)];
    out.insert(out.end(), part.begin(), part.end());
    const imaginary_report<D>& r = reps[static_cast<std::size_t>(b)];
    rep.copies += r.copies;
    rep.small_diameter_events += r.small_diameter_events;
    rep.convex_duplicates_removed += r.convex_duplicates_removed;
    rep.smooth_duplicates_removed += r.smooth_duplicates_removed;
    rep.wrong_side += r.wrong_side;
  }
  return rep;
}

}  // namespace detail

/// Imaginary wall particles (Tanaka 2018 §4.5.1, eqs. 75–77; corner rules of issue #7) for the real
/// particles [0, n_real) with eligible(i) true (non-isolated fluid). `out` is replaced; order: by parent,
/// then by (set, element). Particles behind a wall get no copy (counted in wrong_side).
template <int D, Execution E, class Eligible>
imaginary_report<D> make_imaginary(E e, const points<D>& x, const Eigen::VectorXd& L, index_t n_real,
                                   const Eligible& eligible, const geometry::polygon_set<D>& walls,
                                   const imaginary_params& p, std::vector<imaginary_copy<D>>& out) {
  return detail::make_imaginary<D>(e, x, L, n_real, eligible, detail::view_of(walls), p, out);
}

/// The same over several polygon sets; each copy records its set.
template <int D, Execution E, class Eligible>
imaginary_report<D> make_imaginary(E e, const points<D>& x, const Eigen::VectorXd& L, index_t n_real,
                                   const Eligible& eligible, const geometry::wall_collection<D>& walls,
                                   const imaginary_params& p, std::vector<imaginary_copy<D>>& out) {
  return detail::make_imaginary<D>(e, x, L, n_real, eligible, detail::view_of(walls), p, out);
}

/// Sequential form (exec::seq); results are identical to exec::par.
template <int D, class Eligible>
imaginary_report<D> make_imaginary(const points<D>& x, const Eigen::VectorXd& L, index_t n_real,
                                   const Eligible& eligible, const geometry::polygon_set<D>& walls,
                                   const imaginary_params& p, std::vector<imaginary_copy<D>>& out) {
  return make_imaginary<D>(exec::seq{}, x, L, n_real, eligible, walls, p, out);
}

/// Sequential form over several polygon sets.
template <int D, class Eligible>
imaginary_report<D> make_imaginary(const points<D>& x, const Eigen::VectorXd& L, index_t n_real,
                                   const Eligible& eligible, const geometry::wall_collection<D>& walls,
                                   const imaginary_params& p, std::vector<imaginary_copy<D>>& out) {
  return make_imaginary<D>(exec::seq{}, x, L, n_real, eligible, walls, p, out);
}

/// Writes the copies into the ghost range: x and L are resized to n_real + copies (the first n_real
/// columns/entries are kept) and ghost g = n_real + k takes copy k's position and diameter.
template <int D>
void write_ghosts(const std::vector<imaginary_copy<D>>& copies, index_t n_real, points<D>& x,
                  Eigen::VectorXd& L) {
  if (n_real < 0 || n_real > x.cols() || n_real > L.size())
    fail("wall::write_ghosts: n_real = ", n_real, " exceeds the ", x.cols(), " columns of x or the ",
         L.size(), " entries of L");
  const index_t n = n_real + static_cast<index_t>(copies.size());
  x.conservativeResize(Eigen::NoChange, n);
  L.conservativeResize(n);
  for (std::size_t k = 0; k < copies.size(); ++k) {
    const index_t g = n_real + static_cast<index_t>(k);
    x.col(g) = copies[k].x;
    L[g] = copies[k].L;
  }
}

/// A double-sided copy of a mesh: every element followed by its reversed twin (same vertices), the
/// representation of a thin wall with fluid on both sides (docs/walls.md §thin walls).
template <int D>
geometry::polygon_mesh<D> double_sided(const geometry::polygon_mesh<D>& m) {
  geometry::polygon_mesh<D> r;
  r.vertices = m.vertices;
  r.elements.resize(D, 2 * m.size());
  for (index_t e = 0; e < m.size(); ++e) {
    r.elements.col(2 * e) = m.elements.col(e);
    r.elements.col(2 * e + 1) = m.elements.col(e);
    r.flip(2 * e + 1);
  }
  return r;
}

}  // namespace mpskit::wall
