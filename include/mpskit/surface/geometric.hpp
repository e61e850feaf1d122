#pragma once
/// \file surface/geometric.hpp
/// \brief Geometric free-surface detection of Tanaka, Cardoso & Bahai 2018 (seed 000 §4.6, eqs. 88–89):
/// a particle is on the surface when no neighbour lies in the cone of half-angle θ1 around its outward
/// normal (second step), or none in the cone around the reflected normal n′ (third step). The first step
/// (isolated particles, c < α_c) is surface/packing_ratio.hpp; isolated particles are excluded by the
/// caller through `participates`. docs/surface.md, "Tanaka 2018 (LSMPS scenes)".
///
/// Readings (the paper leaves these open):
/// - Neighbours of both counts and of m_i are the participating j with |x_ij| < α_θ L_i (eq. 88's radius
///   also bounds m_i's sum: "the same particle count" of the third step; α_θ L_ij with the pair_mean
///   option). A coincident neighbour (r = 0) lies in no cone. Wall copies are neighbours (they block the
///   cone): the caller's `participates` includes them.
/// - A zero normal (degenerate, surface/normals.hpp) makes the cone tests meaningless: the particle is
///   inside when it has at least one participating neighbour within α_θ L_i, else surface.
/// - If Σ x_ij over the half-space neighbours is zero (impossible when θ1 ≤ θ2 ≤ π/2: the cone of step
///   two then lies in the half-space, holds ≥ 1 neighbour and every term has n_i·x_ij > 0), the third step
///   is skipped (inside).
/// Only wanted particles are classified (real fluid); imaginary copies inherit their parent's flag
/// (§4.6, last sentence) — that is the caller's job.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"
#include "mpskit/surface/normals.hpp"

namespace mpskit::surface {

/// Numbers of the geometric detection (Tanaka 2018 §4.6 and parameter table).
struct geometric_params {
  double alpha_theta = 2.1;               ///< α_θ: neighbours within α_θ L_i (eq. 88); finite, > 0
  double theta1 = std::numbers::pi / 4;   ///< θ1: half-angle of the cones (eqs. 88–89); in (0, π)
  double theta2 = std::numbers::pi / 2;   ///< θ2: half-angle of the half-space of m_i (third step); in (0, π]
  /// Radius of eqs. 88–89: `own` = α_θ L_i as printed (default); `pair_mean` = α_θ (L_i + L_j)/2, an mpskit
  /// option for multi-resolution (docs/surface.md: no false surface flags at 2:1 interfaces); `max` refused.
  search::radius_rule radius = search::radius_rule::own;
  /// Throws mpskit::error listing every bad value with its accepted range.
  void validate() const {
    validator v("geometric_params");
    v.positive("alpha_theta", alpha_theta);
    v.in_open_range("theta1", theta1, 0.0, std::numbers::pi);
    v.require(std::isfinite(theta2) && theta2 > 0.0 && theta2 <= std::numbers::pi, "theta2",
              mpskit::detail::concat("is ", theta2, "; must be in (0, pi]"));
    v.require(radius != search::radius_rule::max, "radius", "is max; must be own (eq. 88) or pair_mean");
    v.throw_if_any();
  }
};

/// Which step decided a particle (diagnostics and tests).
enum class geometric_step : std::uint8_t {
  inside = 0,          ///< N_θ > 0 and N′_θ > 0 (or a zero normal with neighbours): not on the surface
  cone = 1,            ///< N_θ = 0 (eq. 88): surface by the second step
  reflected_cone = 2,  ///< N_θ > 0 but N′_θ = 0 (eq. 89): surface by the third step
  no_neighbour = 3,    ///< zero normal and no participating neighbour within α_θ L_i: surface
};

/// The scene policy naming this detection (`using surface = mpskit::surface::geometric_detector;`), run by
/// scheme::lsmps_semi_implicit (normals, then geometric(), copies inheriting their parent's flag).
struct geometric_detector final {
  using params_type = geometric_params;
};

/// The counts behind one decision.
template <int D>
struct geometric_result {
  geometric_step step = geometric_step::inside;  ///< the deciding step
  index_t n_theta = 0;                           ///< N_θ of eq. 88 (0 when the normal is zero)
  index_t n_theta_prime = -1;                    ///< N′_θ of eq. 89 (−1 when the third step did not run)
  vec<D> n_prime = vec<D>::Zero();               ///< n′_i (zero when the third step did not run)
  /// True when the particle is on the surface.
  bool surface() const { return step != geometric_step::inside; }
};

/// §4.6 steps two and three for particle i with outward unit normal ni (zero when degenerate).
template <int D, class Participates>
  requires Dimension<D>
geometric_result<D> geometric_of(const points<D>& x, const Eigen::VectorXd& L,
                                 const search::neighbour_list<D>& nl, const Participates& participates,
                                 const vec<D>& ni, const geometric_params& p, index_t i) {
  const search::support<search::per_particle_radius> s{{&L, p.alpha_theta}, p.radius};
  const double cos1 = std::cos(p.theta1), cos2 = std::cos(p.theta2);
  // A neighbour exactly on the cone's edge counts as inside (relative 1e-12): on a lattice in a 90° corner
  // both wall copies of the corner particle lie at exactly θ1 = π/4 from its normal, and the strict
  // inequality of eq. 88 then flagged the corner particle as free surface (p = 0 inside the fluid).
  const double cos1t = cos1 - 1e-12;
  geometric_result<D> out;
  if (ni.squaredNorm() == 0.0) {  // zero normal: inside unless alone (reading in the file comment)
    index_t count = 0;
    nl.for_each_neighbour(x, i, s,
                          [&](index_t j, const vec<D>&, double) { count += participates(j) ? 1 : 0; });
    out.step = count > 0 ? geometric_step::inside : geometric_step::no_neighbour;
    return out;
  }
  // Eq. 88: n_i · x_ij/|x_ij| > cos θ1, written n_i · x_ij > |x_ij| cos θ1 (no division; r = 0 never counts).
  // Third step: m_i = Σ x_ij / |Σ x_ij| over n_i · x_ij > |x_ij| cos θ2.
  // The participating neighbours inside α_θ L_i are kept (up to `keep`) so the third step does not
  // walk the list again; a larger neighbourhood (very mixed sizes) walks it a second time.
  constexpr int keep = 128;
  double kd[keep][D];
  double kr[keep];
  int kept = 0;
  bool overflow = false;
  vec<D> msum = vec<D>::Zero();
  nl.for_each_neighbour(x, i, s, [&](index_t j, const vec<D>& d, double r2) {
    if (!participates(j)) return;
    const double r = std::sqrt(r2);
    const double c = ni.dot(d);
    out.n_theta += c > r * cos1t ? 1 : 0;
    if (c > r * cos2) msum += d;
    if (kept < keep) {
      for (int a = 0; a < D; ++a) kd[kept][a] = d[a];
      kr[kept++] = r;
    } else {
      overflow = true;
    }
  });
  if (out.n_theta == 0) {
    out.step = geometric_step::cone;
    return out;
  }
  const double mlen = msum.norm();
  if (mlen == 0.0) return out;  // no half-space neighbour (only when θ1 > θ2): third step skipped
  const vec<D> m = msum / mlen;
  out.n_prime = 2.0 * m.dot(ni) * ni - m;  // n′_i = 2(m_i·n_i)n_i − m_i: m reflected about n_i
  out.n_theta_prime = 0;
  if (!overflow) {
    for (int q = 0; q < kept; ++q) {
      double c = 0.0;
      for (int a = 0; a < D; ++a) c += out.n_prime[a] * kd[q][a];
      out.n_theta_prime += c > kr[q] * cos1t ? 1 : 0;  // eq. 89
    }
  } else {
    nl.for_each_neighbour(x, i, s, [&](index_t j, const vec<D>& d, double r2) {
      if (!participates(j)) return;
      out.n_theta_prime += out.n_prime.dot(d) > std::sqrt(r2) * cos1t ? 1 : 0;  // eq. 89
    });
  }
  if (out.n_theta_prime == 0) out.step = geometric_step::reflected_cone;
  return out;
}

/// The walls as a neighbour of the cone tests (a deviation from Tanaka §4.6, docs/lsmps_scheme.md): true
/// when the cone that found no particle is solid. Imaginary copies sample a wall only where a fluid particle
/// is within α_w L, so a cone can look into the solid between them: beside an inclined wall the reflected
/// cone (eq. 89) found the lattice's staircase gaps, and in 3D the cone of a particle next to an edge of two
/// walls contained neither copy (measured: 3 of 11 rows beside a 60° incline and 32 edge particles of a 3D
/// box flagged as free surface). A flag of eq. 88 is withdrawn when the cone's axis and the 2(D − 1) rays
/// on its rim at θ1 all meet a wall within α_θ L_i (a contact-line particle, whose cone is partly open,
/// keeps its flag); a flag of eq. 89 when n′ meets the plane of the closest wall point within α_θ L_i.
template <int D>
bool wall_blocks_cone(const geometry::polygon_set<D>& walls, const vec<D>& xi, double Li, const vec<D>& ni,
                      const geometric_result<D>& g, const geometric_params& p) {
  const double reach = p.alpha_theta * Li;
  const auto q = walls.query(xi, reach);
  if (!q.found()) return false;
  if (g.step == geometric_step::reflected_cone) {
    const double toward = -g.n_prime.dot(q.normal);
    return toward > 0.0 && q.signed_distance < reach * toward;
  }
  if (g.step != geometric_step::cone || !(ni.norm() > 0.0)) return false;
  const vec<D> axis = ni.normalized();
  vec<D> e1 = vec<D>::Zero();  // a unit vector perpendicular to the axis
  int k = 0;
  for (int a = 1; a < D; ++a)
    if (std::abs(axis[a]) < std::abs(axis[k])) k = a;
  e1[k] = 1.0;
  e1 -= axis.dot(e1) * axis;
  e1.normalize();
  const double c1 = std::cos(p.theta1), s1 = std::sin(p.theta1);
  const auto solid = [&](const vec<D>& dir) {
    return walls.first_crossing(xi, vec<D>(xi + reach * dir)).has_value();
  };
  bool blocked = solid(axis) && solid(vec<D>(c1 * axis + s1 * e1)) && solid(vec<D>(c1 * axis - s1 * e1));
  if constexpr (D == 3) {
    const vec<D> e2(axis[1] * e1[2] - axis[2] * e1[1], axis[2] * e1[0] - axis[0] * e1[2],
                    axis[0] * e1[1] - axis[1] * e1[0]);  // axis × e1 (no <Eigen/Geometry>)
    blocked = blocked && solid(vec<D>(c1 * axis + s1 * e2)) && solid(vec<D>(c1 * axis - s1 * e2));
  }
  return blocked;
}

/// The cone axis slid along the walls (a deviation, with wall_blocks_cone): from the unit axis, up to D
/// times, the ray of length α_θ L_i is cast and, where it enters a wall, the axis loses its component into
/// that wall. Returns the slid unit axis when the ray is then open, or nullopt (solid, or nothing left). A
/// particle in a vertical edge of a box at the free surface has its normal tilted toward the edge (the fluid
/// on the other side is not mirrored), so its cone is solid although the surface is right above it: measured,
/// the 4 such particles of a 3D box were left unflagged and grew a vertical mode 2.2× per step.
template <int D>
std::optional<vec<D>> wall_slid_axis(const geometry::polygon_set<D>& walls, const vec<D>& xi, double Li,
                                     const vec<D>& axis, const geometric_params& p) {
  const double reach = p.alpha_theta * Li;
  vec<D> a = axis;
  for (int k = 0;; ++k) {
    const auto hit = walls.first_crossing(xi, vec<D>(xi + reach * a));
    if (!hit) return a;
    if (k == D) return std::nullopt;  // still solid after sliding along D walls
    const double into = a.dot(hit->normal);
    if (!(into < 0.0)) return std::nullopt;  // leaving through a wall's back: solid behind it
    a -= into * hit->normal;
    const double len = a.norm();
    if (!(len > 1e-8)) return std::nullopt;
    a /= len;
  }
}

/// Sets surface[i] = 1 (surface) or 0 (inside) for the particles with wanted(i) (default: all; pass real
/// fluid particles), from outward unit normals n (surface/normals.hpp; zero columns for degenerate ones).
/// surface is resized to x.cols() when its size differs (new entries 0); other entries are untouched.
/// The list must hold the pairs with r < α_θ L_i (or α_θ L_ij with pair_mean; a list built at ratio ≥ α_θ
/// holds both, since lists store the `max` rule). With `walls`, the walls count as a neighbour of the cone
/// tests (wall_blocks_cone). Throws mpskit::error on bad p or sizes.
template <int D, Execution E, class Participates, class Wanted = all_particles>
  requires Dimension<D>
void geometric(E e, const points<D>& x, const Eigen::VectorXd& L, const search::neighbour_list<D>& nl,
               const Participates& participates, const points<D>& n, const geometric_params& p,
               std::vector<std::uint8_t>& surface, const Wanted& wanted = {},
               const geometry::polygon_set<D>* walls = nullptr) {
  p.validate();
  const index_t np = x.cols();
  if (L.size() != np) fail("geometric: L has ", L.size(), " entries for ", np, " particles");
  if (n.cols() != np) fail("geometric: n has ", n.cols(), " columns for ", np, " particles");
  if (nl.rows() != np)
    fail("geometric: the neighbour list has ", nl.rows(), " rows for ", np, " particles (rebuild it)");
  check_diameters("geometric", L, np);
  if (static_cast<index_t>(surface.size()) != np) surface.assign(static_cast<std::size_t>(np), 0);
  for_each_particle(e, np, [&](index_t i) {
    if (!wanted(i)) return;
    const vec<D> ni = n.col(i);
    const geometric_result<D> g = geometric_of<D>(x, L, nl, participates, ni, p, i);
    bool on_surface = g.surface();
    if (on_surface && walls && wall_blocks_cone<D>(*walls, x.col(i), L[i], ni, g, p)) {
      on_surface = false;
      // A contact-line particle: the cone around the axis slid along the walls is open and holds no
      // participating neighbour (eq. 88 with the slid axis) — the flag is kept.
      if (g.step == geometric_step::cone)
        if (const auto a = wall_slid_axis<D>(*walls, x.col(i), L[i], vec<D>(ni.normalized()), p))
          on_surface = geometric_of<D>(x, L, nl, participates, *a, p, i).step == geometric_step::cone;
    }
    surface[static_cast<std::size_t>(i)] = on_surface ? 1 : 0;
  });
}

}  // namespace mpskit::surface
