#pragma once
// Flow between two fixed gears (Tanaka, Cardoso & Bahai 2018 §5.5; validation-cases.md A5): geometry
// generator (the domain as mpskit_polyline text), the multi-resolution scene and its runner.
//
// The paper gives: top gear 12 teeth, tip diameter 42 mm, tooth depth 6.75 mm; bottom gear 24 teeth, tip
// diameter 78 mm, tooth depth 6.75 mm; centre distance 55 mm; minimum gap 0.68 mm; fluid area 1061.6 mm²;
// 100 Pa on the right face, 0 Pa on the left; ρ = 1000 kg/m³, μ = 0.001 Pa s, no body force; to 0.4 s; the
// target diameter a function of the distance from the domain's centre (Fig. 21b, not in the text). Fig. 21 is
// not available: every other number below is OUR reconstruction (docs/gears.md):
//  - Teeth: module m = tip diameter / (N + 2) = 3 mm for both gears (42/14 = 78/26 = 3: a standard pair whose
//    depth 6.75 mm = 2.25 m), involute flanks with a 20° pressure angle, radial flanks below the base circle,
//    tip and root corners rounded (quadratic Bézier, `tip_round`, `root_round`).
//  - Tooth thickness: the standard π m/2 at the pitch circle minus `thinning`, the same for both gears,
//    solved so that the smallest outline-to-outline distance is `gap` (0.68 mm). At 55 mm (1 mm over the
//    standard 54 mm) the standard pair's normal backlash 2 Δa sin 20° = 0.684 mm is shared by the two flanks
//    of the symmetric phase (0.34 mm each), so the teeth must be thinned to give 0.68 mm on each side.
//  - Phase: symmetric about the line of centres: a bottom tooth points straight up into a top tooth space.
//  - Coordinates: origin on the line of centres, midway through the overlap of the tip circles (5 mm); the
//    bottom centre at y = −36.5 mm, the top centre at y = +18.5 mm. The origin is the "domain centre" of
//    L*(d).
//  - Window: a straight top wall at the top gear's centre height (it meets the top gear's root circle in the
//    tooth spaces at 0° and 180°), vertical pressure faces at x = ±a, the bottom gear below; a solved so that
//    the fluid area is `area`. The faces' lines cut the bottom gear's teeth: tooth spaces a face line cuts
//    off below the face's lower end are not part of the fluid (not counted in the area, not filled).
//  - Pressure: the printed values (100 Pa right, 0 Pa left), so the flow runs right to left; the text's
//    "inflow on the left" contradicts them and is not followed.
//  - Target diameter: a √2 staircase in d (gears_config::target); initial particles: a wall row plus a
//    quadtree (gears_initial_state).
//  - Scheme: Tanaka's LSMPS with three opt-in stabilisers (gears_config::params), without which every run
//    blew up beside a tooth within milliseconds (docs/gears.md "Failures and what we tried").
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "cases/run_measures.hpp"
#include "mpskit/boundary/pressure.hpp"
#include "mpskit/geometry/generators.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/polyline_io.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"
#ifdef MPSKIT_HAS_SUITESPARSE
#include "mpskit/ppe/suitesparse.hpp"
#endif
#include "mpskit/resolution/split_merge.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// The paper's numbers and our reconstruction's (file comment; docs/gears.md). Lengths in m.
struct gears_geometry_config {
  int teeth_top = 12, teeth_bottom = 24;           ///< [P]
  double tip_d_top = 0.042, tip_d_bottom = 0.078;  ///< tip diameters [P]
  double depth = 6.75e-3;                          ///< tooth depth [P]
  double centre_distance = 0.055;                  ///< [P]
  double gap = 0.68e-3;     ///< minimum outline-to-outline distance [P] (the solve's target)
  double area = 1061.6e-6;  ///< fluid area [P] (the solve's target, m²)
  double pressure_angle = 20.0 * std::numbers::pi / 180.0;  ///< ours
  double tip_round = 0.5e-3, root_round = 0.4e-3;           ///< corner rounding radii (ours)
  double ds = 0.1e-3;                                       ///< outline sampling (segment length, ours)
  double overhang = 4e-3;  ///< walls continue this far beyond the faces (as the channels)
};

/// A generated domain: the polyline mesh (walls, then the two faces) and the solved numbers.
struct gears_geometry {
  geometry::polygon_mesh<2> mesh;   ///< walls and faces, fluid on the left of every segment
  double a = 0.0;                   ///< faces at x = ±a (m)
  double y_top = 0.0;               ///< the top wall's height (m)
  double thinning = 0.0;            ///< tooth thickness removed at the pitch circle, each gear (m)
  double gap = 0.0;                 ///< smallest outline distance achieved (m)
  double area = 0.0;                ///< fluid area of the window (m²)
  vec<2> centre_top = vec<2>::Zero(), centre_bottom = vec<2>::Zero();
  int pockets = 0;                  ///< tooth spaces cut off by the face lines (not part of the fluid)
};

namespace gears_detail {

using pts = std::vector<vec<2>>;

inline double involute(double alpha) { return std::tan(alpha) - alpha; }

/// Rounds the corner at index c of an open polyline with a quadratic Bézier of tangent length t (control
/// point the corner): smooth (tangent-continuous) replacement of the sharp vertex. Returns false if t does
/// not fit.
inline bool round_corner(pts& p, std::size_t c, double t, double ds) {
  if (!(t > 0.0) || c == 0 || c + 1 >= p.size()) return true;
  // walk back from c a length t
  double acc = 0.0;
  std::size_t k = c;
  vec<2> A = p[c];
  while (k > 0) {
    const double l = (p[k] - p[k - 1]).norm();
    if (acc + l >= t) {
      A = p[k] + (p[k - 1] - p[k]) * ((t - acc) / l);
      break;
    }
    acc += l;
    --k;
  }
  if (k == 0) return false;
  acc = 0.0;
  std::size_t j = c;
  vec<2> B = p[c];
  while (j + 1 < p.size()) {
    const double l = (p[j + 1] - p[j]).norm();
    if (acc + l >= t) {
      B = p[j] + (p[j + 1] - p[j]) * ((t - acc) / l);
      break;
    }
    acc += l;
    ++j;
  }
  if (j + 1 >= p.size()) return false;
  const vec<2> P = p[c];
  pts out(p.begin(), p.begin() + static_cast<std::ptrdiff_t>(k));  // p[0..k-1]
  const int n = std::max(4, static_cast<int>(std::ceil(2.0 * t / ds)));
  for (int q = 0; q <= n; ++q) {
    const double u = static_cast<double>(q) / n;
    out.push_back((1 - u) * (1 - u) * A + 2 * u * (1 - u) * P + u * u * B);
  }
  out.insert(out.end(), p.begin() + static_cast<std::ptrdiff_t>(j + 1), p.end());
  p = std::move(out);
  return true;
}

/// Turning angle at vertex c of a polyline (rad, 0 for straight).
inline double turn(const pts& p, std::size_t c) {
  const vec<2> d1 = (p[c] - p[c - 1]).normalized(), d2 = (p[c + 1] - p[c]).normalized();
  return std::acos(std::clamp(d1.dot(d2), -1.0, 1.0));
}

/// Closed outline of one gear, counter-clockwise (the gear's inside on the left), without a repeated end
/// point. Involute of the base circle r_b = r_p cos α above the base circle, the half-thickness angle
/// ψ(r) = s/(2 r_p) + inv α − inv α_r, cos α_r = r_b / r (standard involute geometry); radial below r_b.
inline pts gear_outline(int N, double r_tip, double depth, double alpha, double thinning,
                        const vec<2>& centre, double phase, double tip_round, double root_round, double ds) {
  const double pi = std::numbers::pi;
  const double m = 2.0 * r_tip / (N + 2);
  const double rp = 0.5 * m * N, rb = rp * std::cos(alpha), rr = r_tip - depth;
  const double s = 0.5 * pi * m - thinning;
  const auto psi = [&](double r) {
    const double ar = std::acos(std::min(1.0, rb / std::max(r, rb)));
    return s / (2.0 * rp) + involute(alpha) - involute(ar);
  };
  const double half = pi / N, psi_root = psi(rr), psi_tip = psi(r_tip);
  if (!(psi_tip > 0.0) || !(psi_root < half))
    fail("gear_outline: thinning ", thinning, " m gives no tip land or no root land (N = ", N, ")");
  const auto polar = [](double r, double th) { return vec<2>(r * std::cos(th), r * std::sin(th)); };
  // one tooth centred at angle 0, from −π/N to +π/N
  pts t;
  std::vector<std::size_t> corners;
  const auto arc = [&](double r, double a0, double a1, bool last) {
    const int n = std::max(1, static_cast<int>(std::ceil(std::abs(a1 - a0) * r / ds)));
    for (int q = 0; q < n + (last ? 1 : 0); ++q) t.push_back(polar(r, a0 + (a1 - a0) * q / n));
  };
  const int nf = std::max(2, static_cast<int>(std::ceil((r_tip - rr) / ds)));
  arc(rr, -half, -psi_root, false);
  corners.push_back(t.size());  // root corner (concave)
  for (int q = 0; q < nf; ++q) {
    const double r = rr + (r_tip - rr) * q / nf;
    t.push_back(polar(r, -psi(r)));
  }
  corners.push_back(t.size());  // tip corner (convex)
  arc(r_tip, -psi_tip, psi_tip, false);
  corners.push_back(t.size());  // tip corner
  for (int q = 0; q < nf; ++q) {
    const double r = r_tip - (r_tip - rr) * q / nf;
    t.push_back(polar(r, psi(r)));
  }
  corners.push_back(t.size());  // root corner
  arc(rr, psi_root, half, true);
  // round from the last corner to the first (indices before a rounded corner stay valid)
  for (std::size_t q = corners.size(); q-- > 0;) {
    const std::size_t c = corners[q];
    const double r = (q == 0 || q == 3) ? root_round : tip_round;
    const double tl = r * std::tan(0.5 * turn(t, c));
    if (!round_corner(t, c, tl, ds)) fail("gear_outline: corner rounding ", r, " m does not fit the tooth");
  }
  pts out;
  for (int k = 0; k < N; ++k) {
    const double th = phase + 2.0 * pi * k / N;
    const double c = std::cos(th), sn = std::sin(th);
    for (std::size_t q = 0; q + 1 < t.size(); ++q)  // the last point is the next tooth's first
      out.push_back(centre + vec<2>(c * t[q][0] - sn * t[q][1], sn * t[q][0] + c * t[q][1]));
  }
  return out;
}

/// Smallest distance between two closed outlines, from the vertices of each within `box` of the origin to the
/// other outline (geometry::polygon_set's closest-point query).
inline double outline_distance(const pts& A, const pts& B, double box) {
  double best = 1e300;
  const auto near = [&](const vec<2>& x) { return std::abs(x[0]) < box && std::abs(x[1]) < box; };
  const auto one_way = [&](const pts& P, const pts& Q) {
    const geometry::polygon_set<2> q(geometry::detail::closed_polygon(Q, geometry::fluid_side::outside));
    for (const vec<2>& x : P)
      if (near(x)) best = std::min(best, q.closest(x).distance);
  };
  one_way(A, B);
  one_way(B, A);
  return best;
}

/// Point in a closed polygon (even-odd crossing rule).
inline bool inside(const pts& P, const vec<2>& x) {
  bool in = false;
  for (std::size_t i = 0, j = P.size() - 1; i < P.size(); j = i++) {
    if ((P[i][1] > x[1]) != (P[j][1] > x[1]) &&
        x[0] < (P[j][0] - P[i][0]) * (x[1] - P[i][1]) / (P[j][1] - P[i][1]) + P[i][0])
      in = !in;
  }
  return in;
}

/// Clips a closed outline to the box [lo, hi] (Liang–Barsky per segment); returns the open chains inside, in
/// the outline's order. Precondition: P[0] lies outside the box (no chain wraps around the start).
inline std::vector<pts> clip(const pts& P, const vec<2>& lo, const vec<2>& hi) {
  std::vector<pts> chains;
  bool open = false;
  for (std::size_t q = 0; q < P.size(); ++q) {
    const vec<2> a = P[q], b = P[(q + 1) % P.size()];
    const vec<2> d = b - a;
    double t0 = 0.0, t1 = 1.0;
    bool keep = true;
    for (int k = 0; k < 2 && keep; ++k) {
      const double pk[2] = {-d[k], d[k]}, qk[2] = {a[k] - lo[k], hi[k] - a[k]};
      for (int s = 0; s < 2; ++s) {
        if (pk[s] == 0.0) {
          if (qk[s] < 0.0) keep = false;
        } else {
          const double r = qk[s] / pk[s];
          if (pk[s] < 0.0) t0 = std::max(t0, r);
          else t1 = std::min(t1, r);
        }
      }
    }
    if (!keep || t0 >= t1) {
      open = false;
      continue;
    }
    const vec<2> A = a + t0 * d, B = a + t1 * d;
    if (!open || t0 > 0.0) {
      chains.push_back({A});
      open = true;
    }
    chains.back().push_back(B);
    if (t1 < 1.0) open = false;
  }
  return chains;
}

/// Rotates a closed outline so that it starts at its vertex of extreme y (lowest if `lowest`).
inline pts start_at_extreme(pts P, bool lowest) {
  std::size_t k = 0;
  for (std::size_t q = 1; q < P.size(); ++q)
    if (lowest ? P[q][1] < P[k][1] : P[q][1] > P[k][1]) k = q;
  std::rotate(P.begin(), P.begin() + static_cast<std::ptrdiff_t>(k), P.end());
  return P;
}

/// The fluid boundary of the window [−a, a] × (−∞, y_top] outside both gears, as oriented open chains (fluid
/// on the left); faces are the face chains (one segment each, x = +a then x = −a). With `ext` > 0 the walls
/// (gear chains, top wall) are clipped to [−a − ext, a + ext] instead (the overhang beyond the faces).
struct boundary_chains {
  std::vector<pts> walls;
  std::array<pts, 2> faces;  // right (x = +a, upward), left (x = −a, downward)
  int pockets = 0;
};

inline boundary_chains window_boundary(const pts& bottom_cw, double centre_y, const pts& top_cw, double a,
                                       double y_top, double ext) {
  boundary_chains r;
  const double big = 1.0;  // 1 m: beyond everything
  // the bottom gear's upper half (bottom_cw starts at its lowest vertex, outside)
  const double ylo = centre_y;
  for (pts& c : clip(bottom_cw, vec<2>(-a - ext, ylo), vec<2>(a + ext, y_top)))
    r.walls.push_back(std::move(c));
  const std::vector<pts> tc = clip(top_cw, vec<2>(-big, -big), vec<2>(big, y_top));
  if (tc.size() != 1)
    fail("gears: the top wall must cut the top gear in two points (", tc.size(), " chains)");
  const pts& g = tc.front();  // from the right crossing, around the bottom, to the left crossing
  pts top{
      vec<2>(a + ext, y_top)};  // the top wall, the top gear's lower half, the top wall: one connected chain
  top.insert(top.end(), g.begin(), g.end());
  top.push_back(vec<2>(-a - ext, y_top));
  r.walls.push_back(std::move(top));
  // the face lines: intervals outside the bottom gear; the topmost reaches y_top (the face), the others are
  // pockets
  for (int side = 0; side < 2; ++side) {
    const double x = side == 0 ? a : -a;
    std::vector<double> ys;
    for (std::size_t q = 0; q < bottom_cw.size(); ++q) {
      const vec<2>& p0 = bottom_cw[q];
      const vec<2>& p1 = bottom_cw[(q + 1) % bottom_cw.size()];
      if ((p0[0] > x) != (p1[0] > x)) {
        const double y = p0[1] + (p1[1] - p0[1]) * (x - p0[0]) / (p1[0] - p0[0]);
        if (y > centre_y) ys.push_back(y);  // the upper half: the line enters there from inside the gear
      }
    }
    std::sort(ys.begin(), ys.end());
    std::vector<std::pair<double, double>> iv;  // fluid intervals on the line, bottom to top
    for (std::size_t q = 0; q < ys.size(); ++q) {
      const double y0 = ys[q], y1 = q + 1 < ys.size() ? std::min(ys[q + 1], y_top) : y_top;
      if (y0 < y1 && y0 < y_top && !inside(bottom_cw, vec<2>(x, 0.5 * (y0 + y1)))) iv.emplace_back(y0, y1);
    }
    if (iv.empty() || iv.back().second != y_top)
      fail("gears: the face at x = ", x, " m does not reach the top wall");
    const auto& f = iv.back();
    r.faces[static_cast<std::size_t>(side)] =
        side == 0 ? pts{vec<2>(x, f.first), vec<2>(x, f.second)}   // upward, normal −x
                  : pts{vec<2>(x, f.second), vec<2>(x, f.first)};  // downward, normal +x
    r.pockets += static_cast<int>(iv.size()) - 1;
  }
  return r;
}

/// The bottom gear's chain between the two faces' lower ends (ext = 0 clipping): the fluid's lower boundary.
/// Other clipped pieces bound tooth spaces cut off by the face lines (not connected to the window's fluid).
inline const pts& main_bottom_chain(const boundary_chains& b) {
  const vec<2> from = b.faces[1].back(), to = b.faces[0].front();
  for (const pts& c : b.walls)
    if ((c.front() - from).norm() < 1e-12 && (c.back() - to).norm() < 1e-12) return c;
  fail("gears: no bottom-gear chain joins the two faces' lower ends");
}

/// Area enclosed by oriented chains that together bound a region on their left (½ Σ x_i × x_{i+1}).
inline double chains_area(const std::vector<pts>& chains) {
  double s = 0.0;
  for (const pts& c : chains)
    for (std::size_t q = 0; q + 1 < c.size(); ++q) s += c[q][0] * c[q + 1][1] - c[q + 1][0] * c[q][1];
  return 0.5 * s;
}

}  // namespace gears_detail

/// Generates the domain: solves the tooth thinning for the gap, then the half-width a for the area.
inline gears_geometry make_gears_geometry(const gears_geometry_config& g) {
  namespace gd = gears_detail;
  const double pi = std::numbers::pi;
  const double rt1 = 0.5 * g.tip_d_top, rt2 = 0.5 * g.tip_d_bottom;
  const double overlap = rt1 + rt2 - g.centre_distance;
  gears_geometry r;
  r.centre_bottom = vec<2>(0.0, -(rt2 - 0.5 * overlap));
  r.centre_top = r.centre_bottom + vec<2>(0.0, g.centre_distance);
  r.y_top = r.centre_top[1];
  const double phase_top = -0.5 * pi + pi / g.teeth_top;  // a tooth space straight down
  const double phase_bottom = 0.5 * pi;                    // a tooth straight up
  const auto outlines = [&](double thin) {
    gd::pts top = gd::gear_outline(g.teeth_top, rt1, g.depth, g.pressure_angle, thin, r.centre_top, phase_top,
                                   g.tip_round, g.root_round, g.ds);
    gd::pts bot = gd::gear_outline(g.teeth_bottom, rt2, g.depth, g.pressure_angle, thin, r.centre_bottom,
                                   phase_bottom, g.tip_round, g.root_round, g.ds);
    return std::pair{std::move(top), std::move(bot)};
  };
  const double box = 0.02;  // the mesh zone: |x|, |y| < 20 mm
  // gap(thinning) grows with the thinning: bisection
  double lo = 0.0, hi = 0.8e-3;  // the top gear keeps a tip land up to ≈ 1.5 mm
  {
    auto [t0, b0] = outlines(hi);
    if (gd::outline_distance(t0, b0, box) < g.gap) fail("gears: the gap ", g.gap, " m is out of reach");
  }
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    auto [t, b] = outlines(mid);
    (gd::outline_distance(t, b, box) < g.gap ? lo : hi) = mid;
  }
  r.thinning = hi;
  auto [top, bot] = outlines(r.thinning);
  r.gap = gd::outline_distance(top, bot, box);
  std::reverse(top.begin(), top.end());  // clockwise: the fluid (outside the gear) on the left
  std::reverse(bot.begin(), bot.end());
  const gd::pts top_cw = gd::start_at_extreme(std::move(top), false);
  const gd::pts bot_cw = gd::start_at_extreme(std::move(bot), true);
  // the area of the fluid connected to the faces: the main bottom chain, the top walls and top gear, the
  // faces
  const auto area = [&](double a) {
    const gd::boundary_chains b = gd::window_boundary(bot_cw, r.centre_bottom[1], top_cw, a, r.y_top, 0.0);
    std::vector<gd::pts> loop{b.walls.back()};  // the top wall, the top gear, the top wall
    loop.push_back(gd::main_bottom_chain(b));
    loop.push_back(b.faces[0]);
    loop.push_back(b.faces[1]);
    return gd::chains_area(loop);
  };
  double alo = rt1 + 1e-3, ahi = rt2 - 1e-3;
  if (area(alo) > g.area || area(ahi) < g.area) fail("gears: the area ", g.area, " m^2 is out of reach");
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (alo + ahi);
    (area(mid) < g.area ? alo : ahi) = mid;
  }
  r.a = 0.5 * (alo + ahi);
  r.area = area(r.a);
  const gd::boundary_chains b =
      gd::window_boundary(bot_cw, r.centre_bottom[1], top_cw, r.a, r.y_top, g.overhang);
  r.pockets = b.pockets;
  // mesh: walls first, then the right face, then the left face
  std::vector<vec<2>> v;
  std::vector<std::array<index_t, 2>> e;
  const auto add = [&](const gd::pts& c) {
    const index_t first = static_cast<index_t>(v.size());
    v.insert(v.end(), c.begin(), c.end());
    for (std::size_t q = 0; q + 1 < c.size(); ++q)
      if ((c[q + 1] - c[q]).norm() > 1e-12)
        e.push_back({first + static_cast<index_t>(q), first + static_cast<index_t>(q + 1)});
  };
  for (const gd::pts& c : b.walls) add(c);
  add(b.faces[0]);
  add(b.faces[1]);
  r.mesh.vertices.resize(2, static_cast<index_t>(v.size()));
  for (std::size_t q = 0; q < v.size(); ++q) r.mesh.vertices.col(static_cast<index_t>(q)) = v[q];
  r.mesh.elements.resize(2, static_cast<index_t>(e.size()));
  for (std::size_t q = 0; q < e.size(); ++q) r.mesh.elements.col(static_cast<index_t>(q)) << e[q][0], e[q][1];
  return r;
}

/// Splits a domain read from a polyline into walls and faces: the faces are the segments on x = ±a that reach
/// the top wall y = y_top (exactly two). Returns {walls, faces} with the faces ordered right (x = +a), left.
inline std::pair<geometry::polygon_mesh<2>, geometry::polygon_mesh<2>> split_gears_faces(
    const geometry::polygon_mesh<2>& m, double a, double y_top) {
  const double tol = 1e-9;
  std::vector<index_t> walls, faces;
  index_t right = npos, left = npos;
  for (index_t e = 0; e < m.size(); ++e) {
    const vec<2> p = m.vertices.col(m.elements(0, e)), q = m.vertices.col(m.elements(1, e));
    const bool on_line = std::abs(p[0] - q[0]) < tol && std::abs(std::abs(p[0]) - a) < tol;
    const bool reaches_top = std::max(p[1], q[1]) > y_top - tol;
    if (on_line && reaches_top) {
      (p[0] > 0.0 ? right : left) = e;
    } else {
      walls.push_back(e);
    }
  }
  if (right == npos || left == npos)
    fail("gears: the polyline has no face on x = ", right == npos ? "+a" : "-a", " (a = ", a, " m)");
  geometry::polygon_mesh<2> w, f;
  w.vertices = m.vertices;
  w.elements.resize(2, static_cast<index_t>(walls.size()));
  for (std::size_t q = 0; q < walls.size(); ++q)
    w.elements.col(static_cast<index_t>(q)) = m.elements.col(walls[q]);
  f.vertices.resize(2, 4);
  f.elements.resize(2, 2);
  index_t k = 0;
  for (index_t e : {right, left}) {
    f.vertices.col(2 * k) = m.vertices.col(m.elements(0, e));
    f.vertices.col(2 * k + 1) = m.vertices.col(m.elements(1, e));
    f.elements.col(k) << 2 * k, 2 * k + 1;
    ++k;
  }
  // keep only the vertices the walls use
  std::vector<index_t> map(static_cast<std::size_t>(w.vertices.cols()), npos);
  std::vector<vec<2>> used;
  for (index_t e = 0; e < w.size(); ++e)
    for (int s = 0; s < 2; ++s) {
      index_t& id = map[static_cast<std::size_t>(w.elements(s, e))];
      if (id == npos) {
        id = static_cast<index_t>(used.size());
        used.push_back(w.vertices.col(w.elements(s, e)));
      }
      w.elements(s, e) = id;
    }
  w.vertices.resize(2, static_cast<index_t>(used.size()));
  for (std::size_t q = 0; q < used.size(); ++q) w.vertices.col(static_cast<index_t>(q)) = used[q];
  return {std::move(w), std::move(f)};
}

/// The case's scene: Tanaka's LSMPS scheme, pressure faces, splitting and merging, ILUT-BiCGSTAB (the
/// Dirichlet-to-Dirichlet PPE through a winding 0.68 mm passage; the long channel needed ILUT,
/// docs/channel.md).
struct gears_scene : lsmps_defaults<2> {
  using surface = mpskit::scheme::no_surface;
  using boundary = mpskit::boundary::pressure;
  using resolution = mpskit::resolution::split_merge<>;
  using solver = mpskit::ppe::bicgstab;
};

/// The same with BiCGSTAB-Jacobi (the library's LSMPS default solver).
struct gears_jacobi_scene : gears_scene {
  using solver = mpskit::ppe::bicgstab_jacobi;
};

#ifdef MPSKIT_HAS_SUITESPARSE
/// The same with UMFPACK's sparse LU (a direct solve: no iteration to diverge).
struct gears_umfpack_scene : gears_scene {
  using solver = mpskit::ppe::umfpack;
};
#endif

struct gears_config {
  gears_geometry_config geometry{};
  double L_min = 0.2e-3;     ///< target diameter within r_fine of the centre (m)
  double L_max = 0.8e-3;     ///< the largest target diameter (m); the initial coarse lattice
  /// L*(d) (ours): L_min for d < r_fine, then ×√2 every `level_width` up to L_max: a staircase of one split
  /// generation per step (eq. 65: L′ = L/√2). The odd steps are 0.99 √2 × the level below, inside eq. 71's
  /// merge threshold (β_m = √2), so that the initial quadtree (levels L_max / 2^k) starts without a split or
  /// merge. L_max / L_min a power of 2.
  double r_fine = 7e-3, level_width = 3e-3;
  double p_right = 100.0, p_left = 0.0;    ///< face pressures (Pa) [P]
  double rho = 1000.0, mu = 0.001;         ///< [P]
  double t_end = 0.05;       ///< run end (s); the paper 0.4 s
  double window = 0.01;      ///< the balance is averaged over the last `window` seconds
  double wall_limit = 0.0;   ///< stop after this many wall-clock seconds (0: none); reported as `stopped`
  /// The scheme's numbers: the library defaults except three opt-ins (docs/gears.md "What it took"): the
  /// two-point term of the copy row (copy_two_point β = 1) and the wall-only projection of the shifting
  /// penalty (the dam break's opt-in pair, docs/lsmps_scheme.md), and the one-sided-band velocity filter at
  /// ε = 0.2 per step (default 0.05). With the defaults every run blew up within 2–6 ms beside a tooth
  /// (single resolution at 0.2 mm too, at 6.2 ms); with β = 1 alone at 4.6 ms, with ε = 0.2 alone at once,
  /// with both at 33 ms.
  scheme::lsmps_params<2> params = [] {
    scheme::lsmps_params<2> p;
    p.copy_two_point = 1.0;
    p.shift.projection = regularize::penalty_projection::wall_only;
    p.boundary_filter.strength = 0.2;
    return p;
  }();
  /// α_o = 0.5 and the face-distance outflow rule, as the multi-diameter channel (docs/channel.md).
  boundary::pressure_params boundary = [] {
    boundary::pressure_params b;
    b.alpha_o = 0.5;
    return b;
  }();
  /// The target diameter L*(x), Tanaka's Fig. 21b reconstructed: a function of the distance d from the
  /// origin.
  double target(const vec<2>& x) const {
    const double d = x.norm();
    if (d < r_fine) return L_min;
    const int k = static_cast<int>(std::floor((d - r_fine) / level_width)) + 1;
    const double L = L_min * std::exp2(0.5 * k) * (k % 2 == 1 ? 0.99 : 1.0);
    return std::min(L_max, L);
  }
  /// The scheme's parameters as run_gears runs them: `params` with ρ, ν = μ/ρ, no gravity, Δt_max and the
  /// target diameter L*(x) of this configuration.
  scheme::lsmps_params<2> scheme_params() const {
    scheme::lsmps_params<2> p = params;
    p.rho = rho;
    p.nu = mu / rho;
    p.g.setZero();
    // adaptive, Courant α_C = 0.1 (Tanaka Table 2); dt_max = α_C L_min / √(2 Δp / ρ) (ours): at rest the
    // Courant limit says nothing, and the first step at 1 ms gave 1.1 m/s and a PPE divergence at step 2
    p.time.dt_max = p.time.courant * L_min / std::sqrt(2.0 * std::abs(p_right - p_left) / rho);
    p.resolution.target_diameter = [c = *this](const vec<2>& x) { return c.target(x); };
    return p;
  }
};

struct gears_result {
  index_t particles = 0, particles_end = 0;  ///< fluid particles at the start and the end
  double particles_mean = 0.0;               ///< mean over the steps
  long splits = 0, merges = 0, steps = 0, inflow = 0, outflow = 0, outflow_behind = 0, guarded = 0;
  double L_min = 0.0, L_max = 0.0;           ///< smallest / largest fluid diameter at the end (m)
  double balance = 0.0, q_in = 0.0, q_out = 0.0, dvdt = 0.0;  ///< window means (m²/s)
  double p_min = 0.0, p_max = 0.0, u_max = 0.0, u_max_window = 0.0;
  vec<2> p_min_at = vec<2>::Zero(), p_max_at = vec<2>::Zero(), u_max_at = vec<2>::Zero();
  double p_min_t = 0.0, p_max_t = 0.0, u_max_t = 0.0;
  double t_reached = 0.0, wall_seconds = 0.0, ledger_error = 0.0;
  long ppe_iterations_max = 0;       ///< the most iterations of one solve
  double ppe_iterations_mean = 0.0;  ///< iterations per step, every solve of a step summed
  bool failed = false;
  bool stopped = false;  ///< stopped at config.wall_limit (not a failure)
  std::string failure;  ///< the error's message when the run stopped early
};

/// Initial particles (ours): a row along every wall (below), then a cell-centred quadtree over the window
/// (coarse cells of L_max, halved while L* < β_s h at the cell's centre, Tanaka eq. 66's β_s, so that no
/// particle wants to split), keeping leaves at least h/2 inside the walls and clear of the row; only
/// particles connected to the top-right corner without crossing a wall are kept. Volume h² each. With
/// gears_config's √2 staircase a particle's size lies inside the no-event band [1/β_m, 1/β_s] × L* (eqs. 66,
/// 71) except in cells straddling a step (a linear L* ramp gave 343 merges at step 1: that band is narrower
/// than the quadtree's factor 2).
inline scheme::lsmps_state<2> gears_initial_state(const gears_config& c,
                                                  const geometry::polygon_mesh<2>& wall_mesh,
                                                  const geometry::polygon_set<2>& walls, double a,
                                                  double y_top, double y_bottom) {
  const double beta_s = 0.5 * (std::sqrt(0.5) + 1.0);
  const auto level = [&](const vec<2>& p) {  // the quadtree's size at p
    double s = c.L_max;
    while (c.target(p) < beta_s * s && s > 0.75 * c.L_min) s *= 0.5;
    return s;
  };
  std::vector<vec<2>> x;
  std::vector<double> h;
  // 1. A row along every wall, h/2 off it and h apart (h the local level): each wall is represented by
  //    imaginary copies (α_w L) from the start. Quadtree leaves alone left gaps up to ≈ h beside curved
  //    walls; a particle with no copy beside a wall gap (the top corners, 0.94 L from the gear) started an
  //    odd-even pressure mode at step 2.
  const auto far_enough = [&](const vec<2>& p, double hp, double factor) {
    for (std::size_t q = 0; q < x.size(); ++q)
      if ((x[q] - p).norm() < factor * 0.5 * (h[q] + hp)) return false;
    return true;
  };
  for (index_t e = 0; e < wall_mesh.size(); ++e) {
    const vec<2> p0 = wall_mesh.vertices.col(wall_mesh.elements(0, e)),
                 p1 = wall_mesh.vertices.col(wall_mesh.elements(1, e));
    const double len = (p1 - p0).norm();
    const vec<2> t = (p1 - p0) / len, n(-t[1], t[0]);  // n: into the fluid (left of p0 → p1)
    double u = 0.0;
    while (u < len) {
      const vec<2> foot = p0 + u * t;
      double hp = level(foot);
      vec<2> q = foot + 0.5 * hp * n;
      for (int it = 0; it < 3 && level(q) != hp; ++it) {  // the size of the particle's own position
        hp = level(q);
        q = foot + 0.5 * hp * n;
      }
      u += 0.25 * hp;  // dense candidates; the spacing test below keeps them ≈ h apart
      if (level(q) != hp) continue;
      if (std::abs(q[0]) > a - 0.5 * hp || q[1] > y_top - 0.5 * hp) continue;
      if (walls.signed_distance(q) < 0.5 * hp * (1.0 - 1e-6)) continue;
      if (!far_enough(q, hp, 0.95)) continue;
      x.push_back(q);
      h.push_back(hp);
    }
  }
  const std::size_t n_row = x.size();
  const std::function<void(const vec<2>&, double)> cell = [&](const vec<2>& ctr, double s) {
    if (c.target(ctr) < beta_s * s && s > 0.75 * c.L_min) {  // the same rule as level()
      for (int i = -1; i <= 1; i += 2)
        for (int j = -1; j <= 1; j += 2) cell(ctr + 0.25 * s * vec<2>(i, j), 0.5 * s);
      return;
    }
    if (std::abs(ctr[0]) > a - 0.5 * s || ctr[1] > y_top - 0.5 * s) return;
    if (walls.signed_distance(ctr) < 0.5 * s * (1.0 - 1e-12)) return;
    // 2. leaves clear of the wall row (0.7 of the mean diameter)
    for (std::size_t q = 0; q < n_row; ++q)
      if ((x[q] - ctr).norm() < 0.7 * 0.5 * (h[q] + s)) return;
    x.push_back(ctr);
    h.push_back(s);
  };
  const double h0 = c.L_max;
  const int ni = static_cast<int>(std::ceil(2.0 * a / h0)),
            nj = static_cast<int>(std::ceil((y_top - y_bottom) / h0));
  for (int i = 0; i < ni; ++i)
    for (int j = 0; j < nj; ++j) cell(vec<2>(a - (i + 0.5) * h0, y_top - (j + 0.5) * h0), h0);
  // Keep the leaves connected to the top-right corner without crossing a wall: tooth spaces cut off by a face
  // line lie outside the gears but are not part of the window's fluid.
  std::vector<std::vector<std::size_t>> bucket(static_cast<std::size_t>(ni * nj));
  const auto key = [&](const vec<2>& p) {
    const int i = std::clamp(static_cast<int>((a - p[0]) / h0), 0, ni - 1);
    const int j = std::clamp(static_cast<int>((y_top - p[1]) / h0), 0, nj - 1);
    return std::pair{i, j};
  };
  for (std::size_t q = 0; q < x.size(); ++q) {
    const auto [i, j] = key(x[q]);
    bucket[static_cast<std::size_t>(i * nj + j)].push_back(q);
  }
  std::vector<char> seen(x.size(), 0);
  std::vector<std::size_t> todo;
  std::size_t seed = 0;
  for (std::size_t q = 1; q < x.size(); ++q)
    if ((x[q] - vec<2>(a, y_top)).norm() < (x[seed] - vec<2>(a, y_top)).norm()) seed = q;
  if (!x.empty()) {
    seen[seed] = 1;
    todo.push_back(seed);
  }
  while (!todo.empty()) {
    const std::size_t q = todo.back();
    todo.pop_back();
    const auto [i, j] = key(x[q]);
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj) {
        if (i + di < 0 || i + di >= ni || j + dj < 0 || j + dj >= nj) continue;
        for (std::size_t o : bucket[static_cast<std::size_t>((i + di) * nj + j + dj)])
          if (!seen[o] && (x[o] - x[q]).norm() < 0.75 * (h[o] + h[q]) && !walls.crosses(x[q], x[o])) {
            seen[o] = 1;
            todo.push_back(o);
          }
      }
  }
  const index_t n = static_cast<index_t>(std::count(seen.begin(), seen.end(), 1));
  scheme::lsmps_state<2> s0(n);
  index_t k = 0;
  for (std::size_t q = 0; q < x.size(); ++q) {
    if (!seen[q]) continue;
    s0.x().col(k) = x[q];
    s0.get<field::volume>()[k] = h[q] * h[q];
    ++k;
  }
  return s0;
}

/// Runs the case on a domain read from a polyline (walls and the two faces, split by split_gears_faces). The
/// observer is called after every step (VTK, progress). Failures of the stepper (PPE, non-finite values) are
/// caught and reported in the result with the time reached; the extremes up to then are kept.
template <class Scene = gears_scene, class Observer>
gears_result run_gears(gears_config c, const geometry::polygon_mesh<2>& domain, double a, double y_top,
                       Observer&& observer) {
  if (!(c.t_end > c.window) || !(c.window > 0.0)) fail("run_gears: need t_end > window > 0");
  auto [wm, fm] = split_gears_faces(domain, a, y_top);
  double y_bottom = 1e300;  // the lowest wall point inside the window: the fill's lower bound
  for (index_t v = 0; v < wm.vertices.cols(); ++v)
    if (std::abs(wm.vertices(0, v)) <= a) y_bottom = std::min(y_bottom, wm.vertices(1, v));
  const geometry::polygon_mesh<2> wm_copy = wm;
  const geometry::polygon_set<2> walls(std::move(wm));
  const scheme::lsmps_params<2> p = c.scheme_params();
  const auto spacing = [&](const vec<2>& y) { return std::min(c.L_max, c.target(y)); };
  const boundary::pressure_boundary<2> pb(geometry::polygon_set<2>(std::move(fm)), {c.p_right, c.p_left},
                                          spacing, c.boundary);
  simulation<Scene> sim(p, gears_initial_state(c, wm_copy, walls, a, y_top, y_bottom), &walls, &pb);
  gears_result r;
  r.particles = sim.state().n_real();
  const auto volume = [&] { return fluid_volume(sim.state()); };
  const auto flux = [&](double x0) { return slab_flux(sim.state(), x0, c.L_max); };
  const double V0 = volume();
  r.p_min = 1e300;
  r.p_max = -1e300;
  bool in_window = false;
  double qin = 0.0, qout = 0.0, n_sum = 0.0;
  long samples = 0, nsteps = 0;
  double v_begin = V0, t_begin = 0.0;
  struct wall_limit_reached {};
  const auto t_start = std::chrono::steady_clock::now();
  const auto observe = [&](const auto& sm) {
    const auto& st = sim.state();
    track_extremes(r, st, sim.time(), in_window);
    n_sum += static_cast<double>(st.n_real());
    ++nsteps;
    if (in_window) {
      // the flow runs right to left (100 Pa on the right): Q = −∫ u_x dy
      qin += -flux(a - 3.0 * c.L_max);
      qout += -flux(-a + 3.0 * c.L_max);
      ++samples;
    }
    observer(sm);
    if (c.wall_limit > 0.0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() > c.wall_limit)
      throw wall_limit_reached{};
  };
  try {
    sim.run_until(c.t_end - c.window, observe);
    v_begin = volume();
    t_begin = sim.time();
    in_window = true;
    sim.run_until(c.t_end, observe);
  } catch (const wall_limit_reached&) {
    r.stopped = true;
  } catch (const mpskit::error& e) {
    r.failed = true;
    r.failure = e.what();
  }
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  r.t_reached = sim.time();
  if (samples > 0 && sim.time() > t_begin) {
    r.q_in = qin / samples;
    r.q_out = qout / samples;
    r.dvdt = (volume() - v_begin) / (sim.time() - t_begin);
    r.balance = std::abs(r.q_in - r.q_out - r.dvdt) / std::abs(r.q_in);
  }
  const auto& k = sim.counters();
  record_channel_end(r, k, sim.state(), V0);
  r.ppe_iterations_max = k.ppe_iterations_max;
  r.ppe_iterations_mean =
      k.steps > 0 ? static_cast<double>(k.ppe_iterations) / static_cast<double>(k.steps) : 0.0;
  r.particles_mean = nsteps > 0 ? n_sum / static_cast<double>(nsteps) : static_cast<double>(r.particles);
  return r;
}

}  // namespace mpskit::cases
