#pragma once
/// \file boundary/pressure.hpp
/// \brief Pressure inflow/outflow boundaries (Tanaka, Cardoso & Bahai 2018 §4.5.2) for the LSMPS scheme:
/// pressure-boundary particles placed in advance on polygon faces, Dirichlet p = P_b in the PPE, normal
/// n_p into the fluid, velocity by neighbour averaging of the fluid; outflow removes a fluid particle
/// within α_o L_i of a boundary particle with u_p·n_p < 0; inflow creates a particle at
/// x_l = x_p + α_i L_p n_p when no fluid particle lies within α_J L_i of it, with the boundary particle's
/// diameter and a velocity by LSMPS type B. The stepper (scheme/lsmps_semi_implicit.hpp) appends the
/// boundary particles as ghosts each step and applies the removals and creations at the step's end
/// through the state's one resize path. Readings and deviations: docs/channel.md.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/op/lsmps_b.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::boundary {

/// How a pressure-boundary particle averages the fluid's velocity.
enum class boundary_velocity {
  /// Tanaka §4.5.2 ("as for walls"): the w-weighted mean over the fluid neighbours within the pair-mean
  /// radius. Across the face it flattens the profile by ½ u'' ⟨Δt²⟩: the fluid beside the face sees a
  /// slower boundary, an extra viscous drag (the pressure-driven channel lost 3 % of its flow, measured).
  isotropic,
  /// Ours (the default): the same weight on an anisotropic distance, within `tube_width` L_p of the normal
  /// line through x_p and the pair-mean radius along it: the fluid "in line" with the boundary particle.
  /// Exact for a profile that does not vary along the normal (developed flow); the tangential smoothing is
  /// O(tube_width² L²) instead of O(R²). Falls back to `isotropic` when the tube holds no fluid.
  normal_tube,
};

/// Which distance the outflow test measures.
enum class outflow_rule {
  /// Tanaka §4.5.2: fluid within α_o L_i of a boundary particle with u_p·n_p < 0.
  particle_distance,
  /// Ours: also fluid within α_o L_i of the face itself (foot of the perpendicular inside it) whose nearest
  /// boundary particle on that element flows out. A particle arriving between two boundary particles
  /// (lateral offset up to L_p/2 > α_o L) otherwise reaches the face untouched and sits beside the p = P_b
  /// points: disordered arrivals (after splitting, or in the multi-diameter channel) blew up there.
  face_distance,
};

/// Numbers of the pressure boundary (Tanaka 2018 Table 1).
struct pressure_params {
  double alpha_o = 0.25;  ///< α_o: outflow removes fluid i with r_ip < α_o L_i (Table 1: 0.25). Range (0, 1]
  /// α_i: inflow position x_p + α_i L_p n_p (Table 1: 0.25; the text omits L_p). Range (0, 1]
  double alpha_i = 0.25;
  double alpha_j = 1.0;  ///< α_J (the text's α_l): inflow when no fluid within α_J L_i of x_l. Range (0, 2]
  /// The boundary particle's velocity keeps only its normal component (u_p·n_p) n_p: Tanaka, "the velocity
  /// on the pressure boundary should have the same direction as the normal vector ... for stability".
  bool normal_velocity = true;
  /// Also remove fluid that is behind a face (foot of the perpendicular inside the face, on its outer side):
  /// the rule r_ip < α_o L_i alone lets a particle passing between two boundary particles (lateral
  /// distance up to L/2 > α_o L) leave the domain (a deviation, docs/channel.md). Counted apart.
  bool remove_behind = true;
  /// The outflow test (default face_distance, ours; docs/channel.md).
  outflow_rule outflow = outflow_rule::face_distance;
  /// Velocity of a created particle: LSMPS type B at x_l (Tanaka §4.5.2) or, when false, the boundary
  /// particle's averaged velocity (for comparison; docs/channel.md).
  bool inflow_lsmps_b = true;
  /// The boundary particle's velocity (it enters the fluid's viscous term and ∇u′ of the source beside the
  /// face, and decides in/outflow): the paper's isotropic neighbour mean or (default, ours) the mean along
  /// the normal (a deviation; docs/channel.md: the 20 mm channel's steady profile error 3.0 % → 0.8 %).
  boundary_velocity velocity = boundary_velocity::normal_tube;
  /// Half-width of the normal tube, in units of the boundary particle's diameter L_p. Range (0, 3]
  double tube_width = 1.0;

  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("boundary::pressure_params");
    v.in_range("alpha_o", alpha_o, 1e-12, 1.0).in_range("alpha_i", alpha_i, 1e-12, 1.0);
    v.in_range("alpha_j", alpha_j, 1e-12, 2.0).in_range("tube_width", tube_width, 1e-12, 3.0);
    v.throw_if_any();
  }
};

/// The scene policy naming pressure boundaries (`using boundary = mpskit::boundary::pressure;`), run by
/// scheme::lsmps_semi_implicit with a pressure_boundary<D> given at construction.
struct pressure final {
  using params_type = pressure_params;
};

/// Fluxes of one step (also summed in the stepper's counters).
struct pressure_flux {
  index_t outflow = 0;          ///< fluid removed within α_o L of an outflowing boundary particle
  index_t behind = 0;           ///< fluid removed behind a face (remove_behind)
  index_t inflow = 0;           ///< fluid created
  double outflow_volume = 0.0;  ///< Σ V of the removed particles (m^D)
  double inflow_volume = 0.0;   ///< Σ V of the created particles (m^D)
};

/// A particle to be created by inflow.
template <int D>
struct inflow_particle {
  vec<D> x = vec<D>::Zero();  ///< x_l = x_p + α_i L_p n_p
  vec<D> u = vec<D>::Zero();  ///< by LSMPS type B at x_l
  double L = 0.0;             ///< the boundary particle's diameter
  double p = 0.0;             ///< initial pressure: P_b
  index_t source = npos;      ///< the boundary particle
};

/// Pressure-boundary particles placed in advance on polygon faces: in 2D each segment is cut into
/// n = ⌈|b − a| / L⌉ equal pieces with a particle at each piece's centre (L_p = |b − a| / n); in 3D each
/// triangle into n² similar triangles (n = ⌈√area / L⌉: one particle per L² of face) with a particle at each
/// centroid (L_p = √(area / n²)). The normal is the element's winding normal (it must point into the fluid)
/// and the pressure that of the element.
template <int D>
class pressure_boundary {
 public:
  /// faces: in/outflow faces (normals into the fluid); element_pressure: P_b per element (Pa); L: the
  /// largest spacing of the boundary particles (m), usually the fluid's diameter.
  pressure_boundary(geometry::polygon_set<D> faces, std::vector<double> element_pressure, double L,
                    const pressure_params& p = {})
      : pressure_boundary(std::move(faces), std::move(element_pressure), checked_spacing(L), p) {}

  /// Multi-resolution: the spacing follows a target diameter L*(x) along the faces (the issue's "target
  /// diameter in multi-resolution" for created particles, ours for the placement). In 2D a segment is cut
  /// into n = ⌈∫ ds / L*⌉ pieces of equal ∫ ds / L* (each piece ≈ L* long where it lies), one particle at
  /// each piece's centre, L_p = the piece's length; in 3D each triangle is cut uniformly with the smallest
  /// L* at its vertices and centroid. A constant L* gives the constant-L placement exactly.
  template <class Spacing>
    requires std::is_invocable_r_v<double, const Spacing&, const vec<D>&>
  pressure_boundary(geometry::polygon_set<D> faces, std::vector<double> element_pressure,
                    const Spacing& spacing, const pressure_params& p = {})
      : faces_(std::move(faces)), pressure_(std::move(element_pressure)), p_(p) {
    p_.validate();
    const auto Ls = [&](const vec<D>& y) {
      const double v = spacing(y);
      if (!(std::isfinite(v) && v > 0.0))
        fail("boundary::pressure_boundary: spacing L = ", v, " at (", y.transpose(),
             "), accepted range (0, inf)");
      return v;
    };
    if (static_cast<index_t>(pressure_.size()) != faces_.size())
      fail("boundary::pressure_boundary: ", pressure_.size(), " pressures for ", faces_.size(),
           " face elements (one P_b per element)");
    for (std::size_t e = 0; e < pressure_.size(); ++e)
      if (!std::isfinite(pressure_[e]))
        fail("boundary::pressure_boundary: P_b of element ", e, " is not finite");
    std::vector<vec<D>> xs, ns;
    std::vector<double> ls, ps;
    std::vector<index_t> es;
    for (index_t e = 0; e < faces_.size(); ++e) {
      const mat<D> v = faces_.element(e);
      const vec<D> nrm = faces_.element_normal(e);
      if constexpr (D == 2) {
        const vec<D> a = v.col(0), b = v.col(1);
        const double len = (b - a).norm();
        // φ(s) = ∫_0^s ds'/L*(s') by the trapezoidal rule on M samples (16 per smallest L* of a first pass)
        double lmin = 1e300;
        for (int q = 0; q <= 256; ++q) lmin = std::min(lmin, Ls(vec<D>(a + (q / 256.0) * (b - a))));
        const int M = std::max(256, 16 * static_cast<int>(std::ceil(len / lmin)));
        std::vector<double> phi(static_cast<std::size_t>(M) + 1, 0.0);
        double inv_prev = 1.0 / Ls(a);
        for (int q = 1; q <= M; ++q) {
          const double inv = 1.0 / Ls(vec<D>(a + (double(q) / M) * (b - a)));
          phi[static_cast<std::size_t>(q)] =
              phi[static_cast<std::size_t>(q) - 1] + 0.5 * (inv + inv_prev) * len / M;
          inv_prev = inv;
        }
        const double Phi = phi.back();
        const int m = std::max(1, static_cast<int>(std::ceil(Phi - 1e-9)));
        const auto s_of = [&](double target) {  // arc length where φ = target (linear inverse)
          const auto it = std::lower_bound(phi.begin(), phi.end(), target);
          const std::size_t q = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(it - phi.begin(), 1, M));
          const double f = (target - phi[q - 1]) / std::max(phi[q] - phi[q - 1], 1e-300);
          return (double(q - 1) + std::clamp(f, 0.0, 1.0)) * len / M;
        };
        const bool uniform = Phi * lmin >= len * (1.0 - 1e-12);  // a constant spacing: equal pieces exactly
        for (int k = 0; k < m; ++k) {
          const double s0 = uniform ? len * k / m : s_of(Phi * k / m);
          const double s1 = uniform ? len * (k + 1) / m : (k + 1 == m ? len : s_of(Phi * (k + 1) / m));
          xs.push_back(uniform ? vec<D>(a + (k + 0.5) / m * (b - a))
                               : vec<D>(a + (0.5 * (s0 + s1) / len) * (b - a)));
          ls.push_back(uniform ? len / m : s1 - s0);
          ns.push_back(nrm);
          ps.push_back(pressure_[static_cast<std::size_t>(e)]);
          es.push_back(e);
        }
      } else {
        const vec<D> a = v.col(0), b = v.col(1), c = v.col(2);
        const double L = std::min({Ls(a), Ls(b), Ls(c), Ls(vec<D>((a + b + c) / 3.0))});
        const double area = 0.5 * (b - a).cross(c - a).norm();
        // m² particles of area A/m² each, m = ⌈√A / L⌉: one particle per L² of face, L_p = √A/m ≤ L. (Cutting
        // by the longest edge, m = ⌈longest/L⌉, gave L_p ≈ L/2 on right triangles: inflow then created
        // particles of an eighth of the fluid's volume.)
        const int m = std::max(1, static_cast<int>(std::ceil(std::sqrt(area) / L - 1e-9)));
        const vec<D> e1 = (b - a) / m, e2 = (c - a) / m;
        for (int i = 0; i < m; ++i)
          for (int j = 0; i + j < m; ++j) {
            // the upright sub-triangle (i, j), and the inverted one beside it when it exists
            xs.push_back(a + (i + 1.0 / 3.0) * e1 + (j + 1.0 / 3.0) * e2);
            if (i + j + 1 < m) xs.push_back(a + (i + 2.0 / 3.0) * e1 + (j + 2.0 / 3.0) * e2);
          }
        const std::size_t added = xs.size() - ns.size();
        for (std::size_t k = 0; k < added; ++k) {
          ls.push_back(std::sqrt(area / (double(m) * m)));
          ns.push_back(nrm);
          ps.push_back(pressure_[static_cast<std::size_t>(e)]);
          es.push_back(e);
        }
      }
    }
    const index_t n = static_cast<index_t>(xs.size());
    x_.resize(D, n);
    n_.resize(D, n);
    L_.resize(n);
    P_.resize(n);
    for (index_t k = 0; k < n; ++k) {
      x_.col(k) = xs[static_cast<std::size_t>(k)];
      n_.col(k) = ns[static_cast<std::size_t>(k)];
      L_[k] = ls[static_cast<std::size_t>(k)];
      P_[k] = ps[static_cast<std::size_t>(k)];
    }
    element_ = std::move(es);
    element_begin_.assign(static_cast<std::size_t>(faces_.size()) + 1, n);
    for (index_t k = n; k-- > 0;)
      element_begin_[static_cast<std::size_t>(element_[static_cast<std::size_t>(k)])] = k;
    for (std::size_t e = element_begin_.size() - 1; e-- > 0;)  // elements without a particle: empty ranges
      element_begin_[e] = std::min(element_begin_[e], element_begin_[e + 1]);
  }

  index_t size() const { return x_.cols(); }                        ///< number of boundary particles
  const points<D>& x() const { return x_; }                          ///< positions x_p (m)
  const points<D>& normals() const { return n_; }                    ///< unit normals n_p into the fluid
  const Eigen::VectorXd& diameters() const { return L_; }            ///< L_p (m)
  const Eigen::VectorXd& pressures() const { return P_; }            ///< P_b (Pa)
  index_t element(index_t k) const { return element_[static_cast<std::size_t>(k)]; }  ///< face element of k
  const geometry::polygon_set<D>& faces() const { return faces_; }   ///< the faces
  const pressure_params& params() const { return p_; }               ///< the numbers
  /// Sets P_b of one face element (e.g. a time-dependent pressure, between steps).
  void set_pressure(index_t e, double P) {
    if (e < 0 || e >= faces_.size())
      fail("boundary::pressure_boundary::set_pressure: element ", e, " of ", faces_.size());
    if (!std::isfinite(P)) fail("boundary::pressure_boundary::set_pressure: P_b = ", P, " is not finite");
    pressure_[static_cast<std::size_t>(e)] = P;
    for (index_t k = 0; k < size(); ++k)
      if (element(k) == e) P_[k] = P;
  }

  /// Velocity of boundary particle k (ghost index g) from the fluid neighbours' u (j < n_fluid,
  /// participating), then (p.normal_velocity) its normal component only; zero when no fluid neighbour is in
  /// reach. Weight: Tanaka eq. 29's w(q) = (1 − q)² with pair-mean radius R = (R_g + R_j)/2 and q = r/R
  /// (isotropic, §4.5.1 "as for walls"), or (normal_tube) q = √((Δt/W)² + (Δn/R)²), Δn = d·n_p,
  /// Δt = |d − Δn n_p|, W = tube_width L_p.
  template <class Participates>
  vec<D> averaged_velocity(const points<D>& x, const search::neighbour_list<D>& nl, index_t g, index_t k,
                           index_t n_fluid, const Eigen::VectorXd& L, double re_ratio, const points<D>& u,
                           const Participates& participates) const {
    vec<D> iso = vec<D>::Zero(), tube = vec<D>::Zero();
    double wiso = 0.0, wtube = 0.0;
    const double W = p_.tube_width * L_[k];
    for (const auto jj : nl.neighbours(g)) {
      const index_t j = static_cast<index_t>(jj);
      if (j >= n_fluid || !participates(j)) continue;
      const vec<D> d = nl.displacement(x, g, j);
      const double r = d.norm(), R = 0.5 * re_ratio * (L[g] + L[j]);
      if (!(r < R)) continue;
      const double w = kernel::quadratic::w(r, R);
      iso += w * u.col(j);
      wiso += w;
      if (p_.velocity == boundary_velocity::normal_tube) {
        const double dn = d.dot(n_.col(k)), dt2 = (d - dn * n_.col(k)).squaredNorm();
        const double q = std::sqrt(dt2 / (W * W) + dn * dn / (R * R));
        if (q < 1.0) {
          const double wt = (1.0 - q) * (1.0 - q);
          tube += wt * u.col(j);
          wtube += wt;
        }
      }
    }
    vec<D> v = wtube > 0.0 ? vec<D>(tube / wtube) : wiso > 0.0 ? vec<D>(iso / wiso) : vec<D>::Zero();
    if (p_.normal_velocity) v = v.dot(n_.col(k)) * n_.col(k);
    return v;
  }

  /// Outflow (Tanaka §4.5.2): marks fluid i < n_fluid with r_ip < α_o L_i for a boundary particle p whose
  /// velocity points out (u_p·n_p < 0), and (remove_behind) fluid behind a face. Boundary particle k is
  /// ghost first_boundary + k; `x` are the current (moved) positions, the list that of this step (its skin
  /// covers the motion). `remove` has n_fluid entries; marked entries are set to 1 (others kept).
  void mark_outflow(const points<D>& x, const Eigen::VectorXd& L, index_t n_fluid, index_t first_boundary,
                    const points<D>& u_boundary, const search::neighbour_list<D>& nl,
                    std::vector<std::uint8_t>& remove, pressure_flux& flux, const Eigen::VectorXd& V) const {
    for (index_t k = 0; k < size(); ++k) {
      if (!(u_boundary.col(k).dot(n_.col(k)) < 0.0)) continue;
      const index_t g = first_boundary + k;
      for (const auto jj : nl.neighbours(g)) {
        const index_t i = static_cast<index_t>(jj);
        if (i >= n_fluid || remove[static_cast<std::size_t>(i)]) continue;
        if (nl.displacement(x, g, i).norm() < p_.alpha_o * L[i]) {
          remove[static_cast<std::size_t>(i)] = 1;
          ++flux.outflow;
          flux.outflow_volume += V[i];
        }
      }
    }
    const bool by_face = p_.outflow == outflow_rule::face_distance;
    if (!p_.remove_behind && !by_face) return;
    for (index_t i = 0; i < n_fluid; ++i) {
      if (remove[static_cast<std::size_t>(i)]) continue;
      const vec<D> xi = x.col(i);
      const geometry::closest_point<D> c = faces_.closest(xi, 2.0 * L[i]);
      if (!c.found() || c.kind != geometry::feature_kind::face) continue;
      const double h = (xi - c.point).dot(faces_.element_normal(c.element));
      if (p_.remove_behind && h < 0.0) {
        remove[static_cast<std::size_t>(i)] = 1;
        ++flux.behind;
        flux.outflow_volume += V[i];
      } else if (by_face && h < p_.alpha_o * L[i]) {
        // the nearest boundary particle of that element decides whether the face flows out there (an
        // element's particles are consecutive: [element_begin_[e], element_begin_[e + 1]))
        index_t best = npos;
        double d2 = 1e300;
        const std::size_t e = static_cast<std::size_t>(c.element);
        for (index_t k = element_begin_[e]; k < element_begin_[e + 1]; ++k) {
          const double dk = (x_.col(k) - c.point).squaredNorm();
          if (dk < d2) {
            d2 = dk;
            best = k;
          }
        }
        if (best != npos && u_boundary.col(best).dot(n_.col(best)) < 0.0) {
          remove[static_cast<std::size_t>(i)] = 1;
          ++flux.outflow;
          flux.outflow_volume += V[i];
        }
      }
    }
  }

  /// Inflow (Tanaka §4.5.2): for each boundary particle with u_p·n_p > 0, x_l = x_p + α_i L_p n_p; when no
  /// fluid particle (not marked for removal) lies within α_J L_i of x_l, a particle of diameter L_p is
  /// created there with the velocity of LSMPS type B (order 1, eqs. 47–52) fitted over the fluid and wall
  /// copies in the boundary particle's row (`fit_candidate(j)`), and p = P_b. The test is against the fluid
  /// present before this pass (new particles are L_p apart along the face by construction).
  template <class FitCandidate>
  void find_inflow(const points<D>& x, const points<D>& u, const Eigen::VectorXd& L, index_t n_fluid,
                   index_t first_boundary, const points<D>& u_boundary, const search::neighbour_list<D>& nl,
                   const std::vector<std::uint8_t>& remove, const FitCandidate& fit_candidate,
                   const op::lsmps_params& fit_params, std::vector<inflow_particle<D>>& out) const {
    out.clear();
    const op::lsmps_b<D, 1> fit(fit_params);
    std::vector<index_t> cand, idx;  // buffers kept across boundary particles
    points<D> xloc;
    Eigen::VectorXd lloc;
    for (index_t k = 0; k < size(); ++k) {
      if (!(u_boundary.col(k).dot(n_.col(k)) > 0.0)) continue;
      const index_t g = first_boundary + k;
      const vec<D> xl = x_.col(k) + p_.alpha_i * L_[k] * n_.col(k);
      bool occupied = false;
      cand.clear();
      for (const auto jj : nl.neighbours(g)) {
        const index_t j = static_cast<index_t>(jj);
        const bool fluid = j < n_fluid && !remove[static_cast<std::size_t>(j)];
        if (fluid && (x_.col(k) + nl.displacement(x, g, j) - xl).norm() <= p_.alpha_j * L[j]) occupied = true;
        if ((fluid || (j >= n_fluid && fit_candidate(j)))) cand.push_back(j);
      }
      if (occupied) continue;
      inflow_particle<D> np;
      np.x = xl;
      np.L = L_[k];
      np.p = P_[k];
      np.source = k;
      np.u = u_boundary.col(k);
      if (p_.inflow_lsmps_b && !cand.empty()) {
        // Candidate positions as seen from x_p (minimum image on periodic axes).
        const index_t m = static_cast<index_t>(cand.size());
        xloc.resize(D, m);
        lloc.resize(m);
        idx.resize(static_cast<std::size_t>(m));
        for (index_t c = 0; c < m; ++c) {
          xloc.col(c) = x_.col(k) + nl.displacement(x, g, cand[static_cast<std::size_t>(c)]);
          lloc[c] = L[cand[static_cast<std::size_t>(c)]];
          idx[static_cast<std::size_t>(c)] = c;
        }
        const auto st =
            fit.stencil(xloc, xl, L_[k], std::span<const index_t>(idx), op::per_particle_size{&lloc});
        if (!st.columns.empty() && st.order_used >= 0) {
          vec<D> v = vec<D>::Zero();
          for (std::size_t c = 0; c < st.columns.size(); ++c)
            v += st.weights[c][0] * u.col(cand[static_cast<std::size_t>(st.columns[c])]);
          np.u = v;
        }
      }
      out.push_back(np);
    }
  }

 private:
  static auto checked_spacing(double L) {
    if (!(std::isfinite(L) && L > 0.0))
      fail("boundary::pressure_boundary: L = ", L, ", accepted range (0, inf)");
    return [L](const vec<D>&) { return L; };
  }

  geometry::polygon_set<D> faces_;
  std::vector<double> pressure_;
  pressure_params p_;
  points<D> x_, n_;
  Eigen::VectorXd L_, P_;
  std::vector<index_t> element_;
  std::vector<index_t> element_begin_;  // first particle of each element (size elements + 1)
};

}  // namespace mpskit::boundary
