#pragma once
/// \file scheme/lsmps_semi_implicit.hpp
/// \brief The LSMPS projection scheme of Tanaka, Cardoso & Bahai 2018 (§4.1–4.3, 4.5.1, 4.6–4.7) at single
/// resolution with per-particle diameters: LSMPS type A operators, the det F volume condition with the
/// packing-ratio correction, polygon walls with imaginary particles on the boundary, geometric surface
/// detection, isolated particles, Tanaka's particle shifting and a wall-crossing guard.
///
/// Stage order of one step (docs/solver.md "LSMPS scheme"):
///  1. Δt from the controller (Courant on min L / max |u|, Tanaka eq. 64); ghosts cleared; every
///     `reorder_every` steps the particles are put in cell order.
///  2. Imaginary copies of fluid particles within α_w L of a wall (eqs. 75–77), in the ghost range.
///  3. Neighbour list over real + copies, R_i = R_e L_i, pair-mean radius (eqs. 27–28), thin-wall
///     visibility when the scene has walls.
///  4. Packing ratio c (eqs. 32–40, least-squares form); isolated fluid: c < α_c (§4.6); isolated
///     particles are excluded from every operator, the PPE and shifting and move ballistically.
///  5. Normals (eq. 31, outward) and free-surface flags (§4.6, both cone tests, the wall counted as a
///     neighbour: a deviation, see surface::wall_blocks_cone) on real fluid; a copy inherits its parent's
///     flag.
///  6. LSMPS type A moments at x^k; with copy_row = constrained_poisson copies carry the Neumann
///     constraint (eqs. 85–86); with copy_row = neumann_points a second set of moments for the pressure, in
///     which each copy is the Neumann equation of eq. 83 at its wall point (op::neumann_points).
///  7. Explicit prediction u′ = u + Δt (ν ∇²u + g) (eq. 13), copies holding the wall velocity (no-slip,
///     §4.5.1 last paragraph).
///  8. PPE (1/ρ) Σ cof(A)_ab ∂_a∂_b p = (det A − c′)/Δt² (eq. 63 and its 3D form, ppe/det_f.hpp), A = I +
///     Δt ∇u′ at x^k (eq. 60), copies carrying u′_w in ∇u′. Unknowns: non-surface, non-isolated fluid and
///     the copies of non-isolated particles; surface fluid is Dirichlet p = 0. The row at a copy k of
///     parent i (params.copy_row, docs/solver.md "Wall rows"): by default (1/ρ) n_k·⟨∇p⟩_i = (u′_i −
///     u_wall)·n_k/Δt, i.e. the wall condition of eq. 83 imposed through the parent's own gradient stencil so
///     that the parent's corrected normal velocity vanishes (a deviation: the paper's form, the det F
///     equation with the Neumann-constrained operator of eqs. 85–87, and eq. 83 at the copy both let an
///     odd-even mode along the wall grow by ≈ 6 % per step, measured); the paper's forms are options. With
///     copy_row = neumann_points the copies are no unknowns (docs/lsmps_scheme.md, deviation 11).
///     Parts with no Dirichlet row (periodic boxes) are pinned at their lowest-id particle after making the
///     right-hand side compatible with the left null vector, and counted. With active_set_solves > 0 fluid
///     particles solved at p < 0 become p = 0 rows and the PPE is solved again (ours, opt-in: deviation 13).
///  9. Correction u = u′ − (Δt/ρ) ∇p (eq. 15), ∇p by LSMPS type A at x^k; x = x^k + Δt u (eq. 16). Then the
///     one-sided-band velocity filter (a deviation, on by default: lsmps_params::boundary_filter) and, when
///     asked, pair collisions (a deviation, off by default: lsmps_params::collision).
/// 10. Shifting (eqs. 93–100) with δu = ∇u δx (eq. 91), if the scene names it.
/// 11. Wall-crossing guard (a documented deviation), periodic wrap, NaN/inf check.
/// 12. If Scene::resolution is split_merge: splitting/merging on this step's list, normals and flags, one
///     resize (scheme/detail/resolution_stage.hpp, docs/resolution.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>
#include <Eigen/SparseCore>

#include "mpskit/boundary/pressure.hpp"
#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/op/lsmps_a.hpp"
#include "mpskit/op/row.hpp"
#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/det_f.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"
#include "mpskit/ppe/floating_parts.hpp"
#include "mpskit/ppe/solve.hpp"
#include "mpskit/regularize/boundary_filter.hpp"
#include "mpskit/regularize/collision.hpp"
#include "mpskit/regularize/tanaka_shift.hpp"
#include "mpskit/scheme/detail/component_fits.hpp"
#include "mpskit/scheme/detail/resolution_stage.hpp"
#include "mpskit/scheme/detail/spectral_radius.hpp"
#include "mpskit/scheme/semi_implicit.hpp"
#include "mpskit/scheme/time_step.hpp"
#include "mpskit/search/domain.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/geometric.hpp"
#include "mpskit/surface/normals.hpp"
#include "mpskit/surface/packing_ratio.hpp"
#include "mpskit/wall/crossing_guard.hpp"
#include "mpskit/wall/imaginary.hpp"
#include "mpskit/wall/visibility.hpp"

namespace mpskit::scheme {

/// A scene without walls (periodic or open domains).
struct no_walls final {};
/// A scene without free-surface detection (closed or periodic domains: every fluid particle is inner).
struct no_surface final {};
/// A scene without pressure boundaries (the default when a scene names no `boundary`).
struct no_pressure_boundary final {};

namespace detail {
template <class Scene>
struct scene_boundary {
  using type = no_pressure_boundary;
};
template <class Scene>
  requires requires { typename Scene::boundary; }
struct scene_boundary<Scene> {
  using type = typename Scene::boundary;
};
}  // namespace detail

/// Which velocity a copy carries in the velocity gradient of the det F source (docs/solver.md).
enum class copy_velocity_in_source {
  extrapolated,  ///< the neighbour-averaged u′ (default: the wall's normal condition then enters once,
                 ///< through eq. 83; measured on the hydrostatic tank, see docs/solver.md)
  wall           ///< the wall velocity (issue #7's literal reading; the jump u′ → u_wall at the wall is
                 ///< then a second, spurious source next to every wall)
};

/// Tanaka's shifting with the penalty of eq. 96 pushing overlapping pairs apart (docs/regularize.md): with
/// the printed direction −∇c/|∇c| the Taylor–Green vortex collapsed at its saddles (min r_ij/L 0.04 at
/// t = 0.16 s, N = 50), with the pair direction it ran to 0.5 s with min r_ij/L ≥ 0.6.
inline regularize::tanaka_shift_params pair_penalty_shift() {
  regularize::tanaka_shift_params p;
  p.penalty = regularize::penalty_direction::pair;
  return p;
}

/// The PPE row at an imaginary copy.
enum class copy_row_kind {
  constrained_poisson,  ///< the det F equation with the Neumann-constrained LSMPS (eqs. 85–87)
  neumann,              ///< eq. 83 itself, (1/ρ) n·∇p = (u′_w − u_wall)·n/Δt, with the plain LSMPS gradient
  parent_gradient,      ///< (1/ρ) n·⟨∇p⟩_parent = (u′_parent − u_wall)·n/Δt: the parent's corrected normal
                        ///< velocity vanishes (a deviation; docs/solver.md)
  neumann_points        ///< no copy unknowns: each copy enters its neighbours' pressure fits (the PPE rows
                        ///< and the correction's gradient) as eq. 83 at its wall point, n·∇p =
                        ///< ρ (u′_w − u_wall)·n/Δt, in place of a value (opt-in; docs/lsmps_scheme.md
                        ///< deviation 11); the copies' pressures are set afterwards for output and probes
};

/// The pressure operator of the det F rows (docs/lsmps_scheme.md "Stability of the projection").
enum class pressure_operator {
  second_derivatives,  ///< Σ_ab cof(A)_ab ∂_a∂_b p with LSMPS-A second derivatives (eqs. 59 and 63; default)
  nested_gradient      ///< Σ_ab cof(A)_ab ∂_b⟨∇_a p⟩: the LSMPS gradient of the LSMPS gradient, eq. 58 read
                       ///< literally (an exact discrete projection; needs a direct solver, see the docs)
};

/// What the PPE does with a fluid row whose operator has a non-negative diagonal (docs/lsmps_scheme.md,
/// deviation 10). Such a row is not a discrete Laplacian at its particle: it appears at sparse particles
/// the surface test did not flag (measured in Tanaka's dam break: c = 0.35–0.7 at the surge toe and in
/// splashes), and with it the matrix is singular or indefinite there and the iterative solve diverges.
enum class wrong_sign_row {
  dirichlet,  ///< the particle becomes a free-surface particle, p = 0 (counted in counters().wrong_sign_rows)
  keep        ///< solve with the row as it is (Tanaka's scheme read literally)
};

/// Which fluid velocity u′_w enters a copy's wall condition (eq. 83).
enum class copy_neumann_velocity {
  average,  ///< w-weighted average of the fluid neighbours' u′ (Tanaka §4.5.1's recommendation)
  parent    ///< the parent's own u′ (the copy is its parent's projection on the wall)
};

/// The own-loop guard (ours, opt-in; docs/lsmps_scheme.md deviation 15). After the PPE solve, each checked
/// particle i gets the D×D block B_i = ∂u_i^{n+1}/∂u′_i of the projection (stages 8–9 linearised at this
/// step's solution: its own predicted velocity through every PPE row it enters, its copies' wall data and the
/// correction's gradient at i). ρ(B_i) > 1 is a loop through the particle's own velocity that one step
/// amplifies; on Tanaka's dam break every failure measured with benchmarks/linearised_step.cpp began as one
/// (2.5–67× per step at one sparse particle beside a wall), while elsewhere ρ(B_i) ≤ 1.02. δp is solved on a
/// patch (the unknowns within patch_radius·R_e,i of i, δp = 0 outside, dense LU), which matched the full
/// Jacobian's block to 6 % where it mattered (3.70 / 3.55, 6.49 / 6.49, 5.66 / 5.62, 40.1 / 39.7, 23.7
/// / 25.1). Where ρ(B_i) > max_gain: a non-surface particle becomes a Dirichlet p = 0 row for the step (as
/// the active set's particles: no own pressure, no own loop), a surface particle's copies lose the two-point
/// term of copy_two_point (their row then makes the parent's corrected normal velocity vanish: B_i·n = 0),
/// or, when the parent's fit sees no unknown outside the group of such parents and their copies (not tied,
/// own_loop_check), its copies become p = 0 rows (a gradient-only group is singular when the fits are exactly
/// determined: measured, two surface particles alone in a corner, docs/lsmps_scheme.md); the PPE is solved
/// again and checked again, at most `rounds` times. Counted (lsmps_counters::own_loop_*).
struct own_loop_guard_params {
  bool enabled = false;   ///< off: Tanaka's scheme (and every earlier result) unchanged
  double max_gain = 1.1;  ///< ρ(B_i) above which the fallback acts (the patch estimate reads up to
                          ///< 0.05 above the full step's block, which the velocity filter damps;
                          ///< below 1 it marks decaying loops too, for experiments). Accepted: [0, 1e6]
  double candidate_packing = 0.7;  ///< non-surface particles with packing ratio c < this are checked (the
                                   ///< failing ones had c = 0.40–0.58; c ≈ 1 inside)
  double wall_candidate_packing = 0.7;  ///< non-surface particles with wall copies and c < this are checked
                                        ///< too (an own loop at c = 0.87 beside a wall was measured at
                                        ///< 3.6 mm; ≤ candidate_packing: no extra candidates, the default)
  double patch_radius = 1.5;  ///< patch radius in units of the particle's R_e
  int rounds = 3;             ///< checks per step, each followed by a solve when a fallback acted
  void validate() const {
    validator v("own_loop_guard_params");
    v.in_range("max_gain", max_gain, 0.0, 1e6).in_range("candidate_packing", candidate_packing, 0.0, 1e3);
    v.in_range("wall_candidate_packing", wall_candidate_packing, 0.0, 1e3);
    v.in_range("patch_radius", patch_radius, 1.0, 1e3).in_range("rounds", rounds, 1, 100);
    v.throw_if_any();
  }
};

/// An axis-aligned box [lo, hi] outside which particles are removed (lsmps_params::remove_outside); ±inf
/// bounds: that side is open. The default removes nothing.
template <int D>
struct removal_box {
  vec<D> lo = vec<D>::Constant(-std::numeric_limits<double>::infinity());  ///< lower corner (m)
  vec<D> hi = vec<D>::Constant(std::numeric_limits<double>::infinity());   ///< upper corner (m)

  /// True when some bound is finite (the stepper then tests every particle).
  bool any() const { return (lo.array().isFinite() || hi.array().isFinite()).any(); }
  /// True when x lies in [lo, hi] on every axis (on the boundary counts as inside).
  bool contains(const vec<D>& x) const {
    return (x.array() >= lo.array()).all() && (x.array() <= hi.array()).all();
  }
  /// Throws mpskit::error on NaN bounds, lo ≥ hi, or a finite bound on a periodic axis of `domain`.
  void validate(const search::domain<D>& domain) const {
    validator v("lsmps_params::remove_outside");
    for (int a = 0; a < D; ++a) {
      v.require(!std::isnan(lo[a]) && !std::isnan(hi[a]) && lo[a] < hi[a], "lo, hi",
                mpskit::detail::concat("axis ", a, ": lo = ", lo[a], ", hi = ", hi[a],
                                       ": need lo < hi (±inf: open)"));
      v.require(
          !(domain.periodic[a] && (std::isfinite(lo[a]) || std::isfinite(hi[a]))), "lo, hi",
          mpskit::detail::concat("axis ", a, " is periodic (domain.periodic): its bounds must be ±inf"));
    }
    v.throw_if_any();
  }
};

/// Runtime numbers of the LSMPS scheme, with Tanaka 2018's defaults (Table 2).
template <int D>
struct lsmps_params {
  double rho = 1000.0;                  ///< density (kg/m³)
  double nu = 1e-6;                     ///< kinematic viscosity (m²/s)
  vec<D> g = semi_implicit_params<D>::gravity();  ///< body force per unit mass (m/s²)
  op::lsmps_params op{};                ///< R_e = 3.1, pair-mean radius, degenerate fallback
  ppe::det_f_params volume{};           ///< c_min, c_max, c′_min, c′_max (eq. 62)
  surface::packing_ratio_params packing{};  ///< number of radii A, α_c (isolated threshold)
  surface::geometric_params surface{};  ///< α_θ, θ_1, θ_2 (§4.6)
  wall::imaginary_params walls{};       ///< α_w (eq. 75), small-diameter event ratio
  wall::guard_params guard{};           ///< ε of the wall-crossing guard
  /// α_g, α_T, α_p, α_S (eqs. 93–100); the penalty of eq. 96 acts per pair (a deviation, docs/solver.md)
  regularize::tanaka_shift_params shift = pair_penalty_shift();
  /// Eq. 99 also along a second wall a particle is copied onto (a 3D edge or corner, a 2D corner; ours,
  /// opt-in, docs/lsmps_scheme.md deviation 12): the 3D tanks at rest stay quiet (the 60° prism meets
  /// issue #4's criteria), but as the default the 3D duct with pressure faces and a 3D tank refined along an
  /// edge fail.
  bool shift_second_wall = false;
  /// Eq. 99 one-sided for the faces whose copies were merged away (ours, default on; docs/lsmps_scheme.md
  /// deviation 14): a particle with a copy keeps no component of δx into any face within α_w L_i seen from
  /// the front that has no copy of its own (two faces of a kink within
  /// wall::imaginary_params::merge_angle_deg keep one copy, so nothing else holds the particle off the other
  /// face). Off, the shifting walked a particle into an 18.4° concave corner of the paper's channel and the
  /// PPE failed (docs/resolution.md).
  bool shift_merged_faces = true;
  /// Eq. 91's δu = ∇u δx clipped per component to the range of u over the particle and its neighbours (copies
  /// at the wall velocity included): regularize::limit_to_neighbour_range, Barth and Jespersen's limiter for
  /// one point (ours, opt-in; docs/lsmps_scheme.md "The shifted velocity's limiter"). Counted
  /// (lsmps_counters::shift_velocity_clipped). Off: Tanaka's eq. 91, every earlier result unchanged.
  bool shift_velocity_limit = false;
  /// Isolated particles (c < α_c) enter the others' overlap penalty of eq. 96 (per pair, pushing i off them,
  /// after eqs. 99–100), not eq. 94 (ours, opt-in; docs/lsmps_scheme.md deviation 18; needs
  /// shift.penalty = pair, the default). Issue #7 item 5 leaves them out of the shifting; then surface
  /// particles of the run-up film were shifted onto isolated ones riding up beside them (Tanaka's dam break
  /// refined 4/2 mm, 4 mm particles: r_ij/L_ij 0.039 at T = 3.98, 0.006 at T = 8.25). Measured with
  /// shift.projection = wall_only (the dam-break wall variants); with eq. 99 as printed a surface particle
  /// keeps no push along its normal. Off: every earlier result unchanged.
  bool shift_isolated_penalty = false;
  /// ε of the velocity filter in the one-sided band (particles with a wall copy, a pressure-boundary or a
  /// free-surface particle among their neighbours, or a neighbour of another size beyond size_ratio; a
  /// deviation, regularize/boundary_filter.hpp): with the
  /// paper's scheme alone the linearised step grows ≈ 1.5 % per step there. 0 switches it off.
  regularize::boundary_filter_params boundary_filter{};
  bool thin_walls = true;  ///< pairs whose segment crosses a wall are not neighbours (walls
                           ///< thinner than the support; +~40 % list-build time, off if none)
  /// the row at a copy (docs/solver.md: the most stable measured)
  copy_row_kind copy_row = copy_row_kind::parent_gradient;
  copy_neumann_velocity copy_neumann = copy_neumann_velocity::parent;  ///< u′_w in eq. 83
  /// β of the two-point term added to the parent-gradient copy row (a deviation, docs/lsmps_scheme.md):
  /// (1/ρ)[n·⟨∇p⟩_parent + β (p_parent − p_copy)/d] = (1 + β)(u′ − u_wall)·n/Δt, d = (x_parent − x_copy)·n.
  /// Both terms are eq. 83; the second gives the copy's unknown a diagonal, without which alternating copy
  /// pressures along a floor were nearly invisible to every row and ran away (±2 MPa in Tanaka's dam break
  /// from T ≈ 1.35). 0 gives the parent-gradient row alone. Accepted: [0, inf).
  double copy_two_point = 0.0;
  copy_velocity_in_source copy_velocity = copy_velocity_in_source::extrapolated;  ///< see the enum
  /// Copies of free-surface particles are Dirichlet p = 0 rows, as their parents are (opt-in; the paper's
  /// reading: Tanaka 2018 §4.6, a copy's surface state is its parent's, and surface particles are Dirichlet
  /// p = 0; issue #7 item 4, "surface fluid and their copies p = 0"). By default they are unknowns with the
  /// parent-gradient row (docs/lsmps_scheme.md deviation 3: p = 0 put a wrong value on a copy below its
  /// parent on an inclined wall, 1.6 % of ρ g H at the first step); in the far-wall impact of Tanaka's dam
  /// break such a copy of a sparse surface particle was solved at 114–155 ρ g H and kicked its neighbours.
  /// Needs copy_row = parent_gradient (with the other rows the copies of surface particles are p = 0 already,
  /// or not unknowns at all).
  bool surface_copies_zero = false;
  /// Copies of sparse free-surface particles are Dirichlet p = 0 rows: those whose parent's packing ratio c
  /// (eq. 40) is below this value (ours, opt-in; 0: off). A narrower surface_copies_zero, aimed at the copies
  /// of sparse surface particles solved at 114–155 ρ g H in the far-wall impact of Tanaka's dam break (their
  /// parents at c = 0.37 and 0.45; a particle of a flat surface has c ≈ 0.5, one inside ≈ 1; measured with
  /// 0.4: no remedy, docs/lsmps_scheme.md "Sparse surface copies and a collision before the PPE"). Needs
  /// copy_row = parent_gradient. Accepted: [0, inf).
  double surface_copies_zero_below = 0.0;
  /// fluid rows with a diagonal ≥ 0 (see the enum)
  wrong_sign_row wrong_sign_rows = wrong_sign_row::dirichlet;
  /// the det F rows' operator (see the enum)
  pressure_operator pressure = pressure_operator::second_derivatives;
  negative_pressure negative = negative_pressure::keep;  ///< LSMPS needs no clamping (Tanaka §4.7)
  /// p ≥ 0 by an active set (ours, opt-in; docs/lsmps_scheme.md deviation 13). 0: off (Tanaka's scheme).
  /// k > 0: after the PPE solve, the fluid particles with p < 0 become Dirichlet p = 0 rows for the rest of
  /// the step (as free-surface particles are: the fluid may separate there but not pull) and the PPE is
  /// solved again, at most k more times; a particle once in the set stays in it for the step. Negative
  /// pressures left after the k-th repeat are kept, not clamped, and counted
  /// (counters().active_set_unfinished). Accepted: [0, 100].
  int active_set_solves = 0;
  /// The active set's repeated solves reuse the rows of the first build (they do not depend on the set: a
  /// particle joining it only drops its row and its column, and its p = 0 moves nothing to the right-hand
  /// sides). false rebuilds every row for every repeat: the reference path, bitwise the same (tested).
  bool active_set_reuse_rows = true;
  /// The active set takes the wall copies too (ours, opt-in; needs active_set_solves > 0): a copy unknown
  /// solved below 0 becomes a p = 0 row for the rest of the step — the wall's contact condition as the same
  /// complementarity, p_wall ≥ 0 (a wall pushes, it does not pull: the fluid may leave it). Without it,
  /// copies of particles leaving a wall were solved at −1.4·10⁷ Pa in the dam break (3.8 mm),
  /// docs/lsmps_scheme.md.
  bool active_set_copies = false;
  /// The active set also releases (ours, opt-in; needs active_set_solves > 0; docs/lsmps_scheme.md
  /// deviation 13): after each repeated solve, a fluid particle held at p = 0 whose own row, evaluated at
  /// that solution, is not met in the compressing direction (w = b − Σ_j a_ij p_j < 0 with a_ii < 0: freed,
  /// it would take p > 0) leaves the set, and the PPE is built and solved again. The set then satisfies the
  /// complementarity p ≥ 0, w ≥ 0, p w = 0 at the fluid rows (the primal–dual active-set iteration) instead
  /// of only p ≥ 0. Without it 63 % of the set's particles violate w ≥ 0 in the main example's fine run, and
  /// the set alternates from step to step (a period-two cycle of the pressures). Wall copies are only joined
  /// (active_set_copies), never released.
  bool active_set_release = false;
  /// The active set starts each step from the previous step's (ours, opt-in; needs active_set_release;
  /// docs/lsmps_scheme.md deviation 13): the real fluid particles held at p = 0 by the set when the previous
  /// pressure solve ended (the previous step's, or with the own-loop guard the previous round's; by particle
  /// id, so splits, merges and removals need no mapping) are held again from the first solve, if they are
  /// still neither surface nor isolated, and the releases are tested after that first solve as well. Without
  /// it each step starts from an empty set; with releases, the first (unconstrained) solve then pulls at
  /// nearly every fluid particle in the main example's run, the set takes almost the whole fluid and the
  /// releases free it again over five repeats (docs/resolution.md). Where the iteration converges both starts
  /// satisfy the same complementarity conditions. The set is part of the state: checkpoints save it (section
  /// `lsmps.active_set_held`).
  bool active_set_warm_start = false;
  own_loop_guard_params own_loop{};   ///< the own-loop guard (ours, opt-in; see the struct)
  /// Pair collisions after the correction (ours, opt-in; docs/lsmps_scheme.md deviation 17): seed 001 eq. 13
  /// (Lee et al. 2011) between fluid particles closer than α1 L_ij that approach, and against their wall
  /// copies (at the wall velocity, immovable), momentum-conserving for unequal volumes
  /// (regularize::sized_collisions). alpha1 = 0: off, Tanaka's scheme. Counted (lsmps_counters::collisions).
  regularize::sized_collision_params collision{};
  /// The collision stage on the predicted velocities, before the PPE, instead of after the correction (ours,
  /// opt-in; docs/lsmps_scheme.md "Sparse surface copies and a collision before the PPE"): approaching pairs
  /// and particles approaching their wall copies are slowed before the pressure is solved, so the PPE need
  /// not stop them. Needs collision.alpha1 > 0.
  bool collide_before_ppe = false;
  time_step_params time{};              ///< Δt controller (Tanaka: α_C = 0.1, constant Δt in the source)
  ppe::solver_params solver{};          ///< linear solver stopping rule
  search::domain<D> domain{};           ///< periodic axes
  /// Real particles whose centre lies outside [lo, hi] on some axis at the start of a step are removed then,
  /// counted (lsmps_counters::left_domain) and, with Scene::resolution = split_merge, entered in the volume
  /// ledger as the flux "left_domain" (ours; the paper says nothing of fluid leaving an open vessel). The
  /// default ±inf removes nothing and costs one test per particle-step only when a bound is finite. Refused:
  /// NaN, lo ≥ hi, a finite bound on a periodic axis (the wrap keeps particles in the period box there).
  removal_box<D> remove_outside{};
  double skin = 0.2;                    ///< list skin (fraction of the build radius)
  int reorder_every = 25;               ///< steps between cell reorders (0: never)
  /// Split/merge numbers and L* (used, and validated by the stepper, only when Scene::resolution is
  /// split_merge).
  resolution::split_merge_params<D> resolution{};

  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("lsmps_params");
    v.positive("rho", rho).non_negative("nu", nu);
    for (int a = 0; a < D; ++a) v.finite("g", g[a]);
    v.in_range("skin", skin, 0.0, 1.0).in_range("reorder_every", reorder_every, 0, 1e9);
    v.non_negative("copy_two_point", copy_two_point);
    v.in_range("active_set_solves", active_set_solves, 0, 100);
    v.require(
        !(active_set_solves > 0 && negative == negative_pressure::clamp_to_zero), "active_set_solves",
        "needs negative = keep (clamping each solve to zero would hide the negative pressures the active set "
        "looks for)");
    v.require(
        !(pressure == pressure_operator::nested_gradient && copy_row == copy_row_kind::constrained_poisson),
        "pressure",
        "nested_gradient takes the wall rows parent_gradient or neumann, not constrained_poisson "
        "(the det F row at a copy has no nested form)");
    v.require(!(pressure == pressure_operator::nested_gradient && copy_row == copy_row_kind::neumann_points),
              "pressure",
              "nested_gradient takes the wall rows parent_gradient or neumann, not neumann_points "
              "(the nested rows read the copies' parents' gradients, which have no Neumann points)");
    v.require(!(shift_isolated_penalty && shift.penalty != regularize::penalty_direction::pair),
              "shift_isolated_penalty",
              "needs shift.penalty = penalty_direction::pair (the printed direction "
              "-grad c does not push a particle away from an isolated one)");
    v.require(!(active_set_release && active_set_solves == 0), "active_set_release",
              "needs active_set_solves > 0 (the releases happen between the active set's repeated solves)");
    v.require(!(active_set_warm_start && !active_set_release), "active_set_warm_start",
              "needs active_set_release (without releases a set carried from step to step could only grow)");
    v.require(!(active_set_copies && active_set_solves == 0), "active_set_copies",
              "needs active_set_solves > 0 (the copies join the active set's repeated solves)");
    v.require(!(active_set_copies && copy_row == copy_row_kind::neumann_points), "active_set_copies",
              "needs copy rows (copy_row = neumann_points has no copy unknowns)");
    v.require(!(surface_copies_zero && copy_row != copy_row_kind::parent_gradient), "surface_copies_zero",
              "needs copy_row = parent_gradient (with the other rows the copies of surface particles are not "
              "unknowns)");
    v.require(surface_copies_zero_below >= 0.0 && std::isfinite(surface_copies_zero_below),
              "surface_copies_zero_below", "must be finite and >= 0 (0: off)");
    v.require(!(surface_copies_zero_below > 0.0 && copy_row != copy_row_kind::parent_gradient),
              "surface_copies_zero_below",
              "needs copy_row = parent_gradient (with the other rows the copies of surface particles are not "
              "unknowns)");
    v.require(!(collide_before_ppe && collision.alpha1 <= 0.0), "collide_before_ppe",
              "needs the collision stage on (collision.alpha1 > 0)");
    v.require(
        !(copy_two_point > 0.0 && copy_row == copy_row_kind::neumann_points), "copy_two_point",
        "a two-point copy row needs copy_row = parent_gradient (with neumann_points the copies have no row)");
    v.throw_if_any();
    op.validate();
    volume.validate();
    packing.validate();
    surface.validate();
    walls.validate();
    guard.validate();
    shift.validate();
    boundary_filter.validate();
    own_loop.validate();
    collision.validate();
    time.validate();
    solver.validate();
    domain.validate();
    remove_outside.validate(domain);
  }
};

/// The LSMPS scheme's impact configuration (docs/lsmps_scheme.md "The impact configuration"): the opt-in
/// deviations with which violent free-surface flows get through their impacts, written into `p` (by default
/// Tanaka's Table 2): the ten fields below are overwritten, every other field of `p` is kept. The paper's
/// defaults fail in Tanaka's dam break at T ≈ 1.6 (4 mm); with these the 2D dam break runs through the
/// far-wall impact at every spacing measured (6–1.5 mm) and the obstacle case with no guard activation
/// (docs/validation.md). Each setting is a documented deviation (docs/lsmps_scheme.md):
/// - copy_two_point = 1: the two-point term in the wall copies' rows (gives a copy's unknown a diagonal);
/// - shift.projection = wall_only: eq. 99's projection only at walls, not at the free surface;
/// - active_set_solves = 10 with active_set_copies: p ≥ 0 for the fluid and the wall copies (deviation 13);
/// - own_loop.enabled: the own-loop guard (deviation 15);
/// - op.max_condition = 1e4: a fit whose moment matrix has cond1 above 1e4 falls back to a lower order;
/// - shift_velocity_limit: eq. 91's shifted velocity clipped to the neighbours' range;
/// - collision.alpha1 = 0.5 with collision.isolated, and shift_isolated_penalty (deviations 17 and 18).
/// Not the default: the two-point rows worsen the Poiseuille profile (3.0 → 3.6 %) and wall-only shifting
/// lets tanks at rest spread; the other settings were not measured on the channels, tanks and vortex, which
/// were validated without them (each deviation's "why not the default" in docs/lsmps_scheme.md). In a 3D slab
/// of the dam break (periodic at 10 mm, between end walls at 10–5 mm) it reaches the far wall where Table 2
/// blows up at T ≈ 0.8–1.2 (docs/lsmps_scheme.md "The impact configuration"; label dam_break_slab).
template <int D>
lsmps_params<D> lsmps_impact_params(lsmps_params<D> p = {}) {
  p.copy_two_point = 1.0;
  p.shift.projection = regularize::penalty_projection::wall_only;
  p.active_set_solves = 10;
  p.own_loop.enabled = true;
  p.active_set_copies = true;
  p.op.max_condition = 1e4;
  p.shift_velocity_limit = true;
  p.collision.alpha1 = 0.5;
  p.collision.isolated = true;
  p.shift_isolated_penalty = true;
  return p;
}

/// Counters of a run.
struct lsmps_counters {
  long steps = 0;               ///< steps taken
  long ppe_iterations = 0;      ///< solver iterations, summed
  /// largest of one solve (a step may solve more than once: ppe_repeat_solves)
  long ppe_iterations_max = 0;
  /// lagged-ILUT solves (solver_params::ilut_reuse) repeated with fresh factors
  long ppe_lagged_retries = 0;
  /// solves made by the fallback solver after the primary failed (ppe::with_fallback)
  long ppe_fallbacks = 0;
  /// solves restarted from 0 after a Krylov breakdown (solver_params::breakdown_restart)
  long ppe_breakdown_restarts = 0;
  /// warm-started solves repeated from 0 after not converging (solver_params::cold_restart)
  long ppe_cold_restarts = 0;
  long pinned_components = 0;      ///< PPE parts with no Dirichlet row, pinned (summed over steps)
  long isolated = 0;               ///< isolated particle-steps
  long copies = 0;                 ///< imaginary copies made (summed over steps)
  long small_diameter_events = 0;  ///< copies with 1 − r σ < small_ratio (L′ = 2L), summed
  long guarded = 0;                ///< wall-crossing guard activations (a deviation: should stay 0)
  long shift_limited = 0;          ///< shifts limited to α_S L (eq. 100)
  /// particle-steps whose eq. 91 velocity was clipped (shift_velocity_limit)
  long shift_velocity_clipped = 0;
  long collisions = 0;  ///< colliding directed pairs of the collision stage (lsmps_params::collision)
  /// directed pairs at r = 0 the collision stage skipped (no direction; should be 0)
  long collision_coincident = 0;
  long shift_coincident = 0;   ///< directed pairs at r = 0 the shifting left out of eq. 94 (should be 0)
  long degenerate = 0;         ///< operator fallbacks on participating particles (particle-steps)
  long negative_clamped = 0;   ///< pressures clamped to zero (when asked)
  long wrong_sign_rows = 0;    ///< fluid PPE rows with a diagonal ≥ 0 made p = 0 rows (particle-steps)
  long active_set_rows = 0;    ///< fluid particles (and copies: active_set_copies) made p = 0 rows by the
                               ///< active set (particle-steps)
  long active_set_solves = 0;  ///< PPE solves repeated by the active set (summed over steps)
  /// steps whose last allowed solve still left a fluid pressure < 0 (kept) or, with active_set_release, a
  /// member its row would release (kept at p = 0)
  long active_set_unfinished = 0;
  /// fluid particles released from the active set (lsmps_params::active_set_release; particle-steps, a
  /// particle counted at each release)
  long active_set_released = 0;
  long own_loop_checked = 0;    ///< particle-steps whose own-loop block was computed (own_loop_guard_params)
  long own_loop_dirichlet = 0;  ///< particle-steps made p = 0 rows by the own-loop guard (a surface particle:
                                ///< its copies made p = 0 rows)
  long own_loop_one_point = 0;  ///< particle-steps whose copies lost the two-point term (own-loop guard)
  long own_loop_solves = 0;     ///< PPE solves repeated by the own-loop guard
  long list_builds = 0;         ///< neighbour-list builds
  long reorders = 0;            ///< cell reorders
  long filtered = 0;            ///< particle-steps filtered in the one-sided band (boundary_filter)
  long splits = 0;              ///< particle splits (Scene::resolution)
  long merges = 0;              ///< particle merges (Scene::resolution)
  long inflow = 0;              ///< particles created by pressure-boundary inflow (Tanaka §4.5.2)
  long outflow = 0;             ///< particles removed by pressure-boundary outflow (r_ip < α_o L_i)
  long outflow_behind = 0;      ///< particles removed behind a pressure face (a deviation, docs/channel.md)
  /// particle-steps of the band left unfiltered:
  /// Σ|w| of their fit > boundary_filter_params::max_amplification
  long filter_amplifying = 0;
  /// particle-steps of the band filtered with ε Λ_t/Σ|w|: Σ|w| > boundary_filter_params::taper_amplification
  long filter_tapered = 0;
  long left_domain = 0;  ///< particles removed outside lsmps_params::remove_outside (counted at removal)
  /// pressure solves made (one per step, plus the active set's and the own-loop guard's repeats, but none for
  /// a system with no unknowns: so at most steps + active_set_solves + own_loop_solves; not the floating
  /// parts' left-null-vector solves). Since 2026-12-07: resumed from an older checkpoint, counted from the
  /// load
  long ppe_solves = 0;
  /// ILUT or ILU(0) factorisations of the pressure solver, a lagged retry's included (0 for solvers without
  /// incomplete factors); since 2026-12-07, as above
  long ppe_factorisations = 0;
  /// the pressure solves after the first of their step (the active set's and the own-loop guard's repeats
  /// that made a solve: at most active_set_solves + own_loop_solves); the first solves are ppe_solves −
  /// this. Since 2026-12-07, as above
  long ppe_repeat_solves = 0;
  /// the iterations of those repeated solves (the first solves': ppe_iterations − this); since 2026-12-07, as
  /// above
  long ppe_repeat_iterations = 0;
  double inflow_volume = 0.0;   ///< Σ V created by inflow (m^D): the boundary fluxes of the volume ledger
  double outflow_volume = 0.0;  ///< Σ V removed by outflow (both rules, m^D)
  double left_domain_volume = 0.0;  ///< Σ V removed outside lsmps_params::remove_outside (m^D)

  /// The volume the boundaries added: inflow − outflow − what left the domain (m^D); a run's volume balance
  /// is ΣV(t) − ΣV(0) − net_boundary_volume().
  [[nodiscard]] double net_boundary_volume() const noexcept {
    return inflow_volume - outflow_volume - left_domain_volume;
  }
};

/// lsmps_counters' integer counters in checkpoint order (io/lsmps_checkpoint.hpp; a counter added later goes
/// last, and the loader reads older files' shorter lists): the one list that saving, loading, restore's check
/// and the tests walk.
inline constexpr std::array<long lsmps_counters::*, 43> lsmps_counter_fields{
    &lsmps_counters::steps, &lsmps_counters::ppe_iterations, &lsmps_counters::ppe_iterations_max,
    &lsmps_counters::ppe_lagged_retries, &lsmps_counters::pinned_components, &lsmps_counters::isolated,
    &lsmps_counters::copies, &lsmps_counters::small_diameter_events, &lsmps_counters::guarded,
    &lsmps_counters::shift_limited, &lsmps_counters::degenerate, &lsmps_counters::negative_clamped,
    &lsmps_counters::wrong_sign_rows, &lsmps_counters::active_set_rows, &lsmps_counters::active_set_solves,
    &lsmps_counters::active_set_unfinished, &lsmps_counters::list_builds, &lsmps_counters::reorders,
    &lsmps_counters::filtered, &lsmps_counters::splits, &lsmps_counters::merges, &lsmps_counters::inflow,
    &lsmps_counters::outflow, &lsmps_counters::outflow_behind, &lsmps_counters::filter_amplifying,
    &lsmps_counters::filter_tapered, &lsmps_counters::own_loop_checked, &lsmps_counters::own_loop_dirichlet,
    &lsmps_counters::own_loop_one_point, &lsmps_counters::own_loop_solves, &lsmps_counters::ppe_fallbacks,
    &lsmps_counters::shift_velocity_clipped, &lsmps_counters::ppe_breakdown_restarts,
    &lsmps_counters::collisions, &lsmps_counters::collision_coincident, &lsmps_counters::shift_coincident,
    &lsmps_counters::left_domain, &lsmps_counters::active_set_released, &lsmps_counters::ppe_cold_restarts,
    &lsmps_counters::ppe_solves, &lsmps_counters::ppe_factorisations, &lsmps_counters::ppe_repeat_solves,
    &lsmps_counters::ppe_repeat_iterations};
// A counter added to lsmps_counters without a place in the list above fails here.
static_assert(sizeof(lsmps_counters) == lsmps_counter_fields.size() * sizeof(long) + 3 * sizeof(double));

/// Particle state of the LSMPS scheme: core fields + pressure + volume (V = L^D, Tanaka eq. 26; copies
/// have their own diameter, eq. 76, so sizes are per particle even at single resolution).
template <int D>
using lsmps_state = particle_state<D, field_list<field::pressure, field::volume>>;

/// The LSMPS semi-implicit stepper for a Scene (scene.hpp `lsmps_defaults`: dim, op, source = det_f,
/// solver, surface, shifting, walls).
template <class Scene>
class lsmps_semi_implicit {
 public:
  static constexpr int D = Scene::dim;
  using op_type = typename Scene::op;
  using source_type = typename Scene::source;
  using solver_type = typename Scene::solver;
  using surface_type = typename Scene::surface;
  using shifting_type = typename Scene::shifting;
  using walls_type = typename Scene::walls;
  using boundary_type = typename detail::scene_boundary<Scene>::type;
  using pressure_boundary_type = boundary::pressure_boundary<Scene::dim>;
  using state_type = lsmps_state<D>;
  using params_type = lsmps_params<D>;
  using geometry_type = geometry::polygon_set<D>;
  static constexpr bool has_walls = !std::is_same_v<walls_type, no_walls>;
  static constexpr bool has_surface = !std::is_same_v<surface_type, no_surface>;
  static constexpr bool has_shift = !std::is_same_v<shifting_type, no_regularization>;
  using resolution_type = detail::scene_resolution_t<Scene>;  ///< Scene::resolution, default uniform
  static constexpr bool has_resolution = !std::is_same_v<resolution_type, resolution::uniform>;
  static_assert(!has_resolution || detail::is_split_merge<resolution_type>::value,
                "mpskit: the LSMPS scheme takes resolution::uniform or resolution::split_merge<...>");
  static_assert(!has_resolution || resolution::ResolutionCompatibleWalls<walls_type>,
                "mpskit: resolution::split_merge cannot run with wall::dummy_layers (Tanaka 2018 §4.5.1)");
  static constexpr bool has_pressure_boundary = std::is_same_v<boundary_type, boundary::pressure>;
  static_assert(has_pressure_boundary || std::is_same_v<boundary_type, no_pressure_boundary>,
                "mpskit: the LSMPS scheme's Scene::boundary is boundary::pressure (Tanaka §4.5.2) or absent");
  static_assert(ppe::SecondDerivativeOperator<op_type>,
                "mpskit: the det F source (Tanaka 2018 eq. 63) needs every second derivative separately: "
                "use LSMPS type A of order >= 2 (classic MPS and order 1 cannot give them)");
  static_assert(std::is_same_v<source_type, ppe::det_f>,
                "mpskit: the LSMPS scheme implements the det F source");
  static_assert(!solver_type::requires_symmetric,
                "mpskit: the LSMPS PPE is not symmetric: use ppe::bicgstab, ppe::gmres or ppe::idrs");
  static_assert(op_type::dim == D, "mpskit: Scene::op has another dimension than the scene");
  static_assert(
      !has_walls || std::is_same_v<walls_type, wall::imaginary>,
      "mpskit: the LSMPS scheme takes polygon walls with imaginary particles (wall::imaginary) or none");
  static_assert(
      !has_shift || std::is_same_v<shifting_type, regularize::tanaka_shift>,
      "mpskit: the LSMPS scheme shifts with regularize::tanaka_shift (Tanaka eqs. 93–100) or not at all");

  /// Takes the numbers, the initial particles (fluid; volumes set, V = L^D) and the walls (required when
  /// the scene names wall::imaginary; must outlive the stepper).
  /// Scenes with `boundary = boundary::pressure` also take the pressure boundary (must outlive the stepper).
  lsmps_semi_implicit(const params_type& p, state_type initial, const geometry_type* walls = nullptr,
                      const pressure_boundary_type* pressure_boundary = nullptr)
      : p_(checked(p)),
        op_(p.op),
        op_p_(p.op),
        source_(p.volume),
        dt_ctrl_(p.time),
        s_(std::move(initial)),
        walls_(walls),
        pb_(pressure_boundary) {
    if constexpr (has_pressure_boundary) {
      if (p_.pressure == pressure_operator::nested_gradient)
        fail("lsmps_semi_implicit: pressure = nested_gradient is not implemented with boundary::pressure");
      if (!pb_)
        fail("lsmps_semi_implicit: the scene has boundary::pressure but no pressure_boundary was given");
      if (pb_->size() == 0) fail("lsmps_semi_implicit: the pressure boundary has no particles");
    } else {
      if (pb_) fail("lsmps_semi_implicit: a pressure boundary given to a scene without boundary::pressure");
    }
    solver_.set_params(p_.solver);
    adjoint_solver_.set_params(p_.solver);
    if constexpr (has_resolution) {
      p_.resolution.validate();
      resolution::ledger_params lp = p_.resolution.ledger;
      lp.rho = p_.rho;
      ledger_ = resolution::conservation_ledger<D>(lp);
    }
    if constexpr (has_walls) {
      if (!walls_) fail("lsmps_semi_implicit: the scene has wall::imaginary but no geometry was given");
    } else {
      if (walls_) fail("lsmps_semi_implicit: walls given to a scene without wall::imaginary");
    }
    if constexpr (has_resolution && has_pressure_boundary) check_boundary_spacing();
    check_particles(s_, "the initial state");
  }

  /// \brief Restores a checkpoint (io::load_simulation, io/lsmps_checkpoint.hpp): the real particles, the
  /// simulated time, the last step's Δt, the counters, the Δt controller and the split/merge ledger's totals.
  /// Refuses (mpskit::error) a stepper that has already stepped (its neighbour list, operators and lagged
  /// factorisation would describe other particles), a state the constructor would refuse (ghosts, kinds
  /// other than fluid, volumes not finite and > 0), a time or Δt not finite and ≥ 0, negative counters and a
  /// Δt rung outside the controller's ladder. `held`: the ids the active set held when the saved run's last
  /// pressure solve ended (active_set_held(); lsmps_params::active_set_warm_start), refused unless strictly
  /// increasing and each the id of a restored particle. On error *this is unchanged.
  void restore(state_type s, double t, double dt, const lsmps_counters& c, const time_step_state& ts,
               const resolution::ledger_step<D>& ledger_totals, long ledger_steps,
               std::vector<particle_id> held = {}) {
    if (nl_.rows() != 0)
      fail("lsmps_semi_implicit::restore: the stepper has already stepped (restore into a new one)");
    check_particles(s, "the restored state");
    if (!(std::isfinite(t) && t >= 0.0) || !(std::isfinite(dt) && dt >= 0.0))
      fail("lsmps_semi_implicit::restore: time ", t, " s and dt ", dt, " s must be finite and >= 0");
    for (long lsmps_counters::*f : lsmps_counter_fields)
      if (c.*f < 0) fail("lsmps_semi_implicit::restore: a counter is negative (", c.*f, ")");
    if (!(std::isfinite(c.inflow_volume) && c.inflow_volume >= 0.0 && std::isfinite(c.outflow_volume) &&
          c.outflow_volume >= 0.0 && std::isfinite(c.left_domain_volume) && c.left_domain_volume >= 0.0))
      fail("lsmps_semi_implicit::restore: boundary volumes ", c.inflow_volume, ", ", c.outflow_volume, ", ",
           c.left_domain_volume, " must be finite and >= 0");
    if (ts.halvings < 0 || ts.halvings > dt_ctrl_.max_rungs() || ts.held < 0 || ts.changes < 0)
      fail("lsmps_semi_implicit::restore: time-step state {", ts.halvings, ", ", ts.held, ", ", ts.changes,
           "} out of range (rungs in [0, ", dt_ctrl_.max_rungs(), "], counts >= 0)");
    if (!held.empty()) {
      std::vector<particle_id> ids(s.ids().begin(), s.ids().begin() + s.n_real());
      std::sort(ids.begin(), ids.end());
      for (std::size_t k = 0; k < held.size(); ++k)
        if ((k > 0 && !(held[k - 1] < held[k])) || !std::binary_search(ids.begin(), ids.end(), held[k]))
          fail(
              "lsmps_semi_implicit::restore: the active set's held ids must be strictly increasing ids of "
              "restored particles (entry ",
              k, ": id ", held[k], ")");
    }
    resolution::conservation_ledger<D> ledger = ledger_;
    ledger.restore(ledger_totals, ledger_steps);  // validates; throws before anything is changed
    held_ids_ = std::move(held);
    s_ = std::move(s);
    t_ = t;
    dt_ = dt;
    c_ = c;
    dt_ctrl_.restore(ts);
    ledger_ = std::move(ledger);
  }

  const state_type& state() const { return s_; }          ///< particles (real + this step's copies)
  state_type& state() { return s_; }                      ///< particles (change only between steps)
  double time() const { return t_; }                      ///< simulated time (s)
  double dt() const { return dt_; }                       ///< Δt of the last step (s)
  const lsmps_counters& counters() const { return c_; }   ///< counters
  /// The ids (sorted) of the real particles the active set held at p = 0 when the last pressure solve ended
  /// (the own-loop guard's excluded); kept only with lsmps_params::active_set_warm_start, else empty.
  const std::vector<particle_id>& active_set_held() const { return held_ids_; }
  const params_type& params() const { return p_; }        ///< the numbers
  const op_type& op() const { return op_; }               ///< operators of the last step
  const search::neighbour_list<D>& neighbours() const { return nl_; }  ///< list of the last step
  const ppe::solve_report& last_solve() const { return last_solve_; }  ///< last PPE solve
  /// The last PPE matrix (row r is particle ppe_rows()[r]; columns in the same order).
  const ppe::matrix& ppe_matrix() const { return A_; }
  const std::vector<index_t>& ppe_rows() const { return rows_; }  ///< the particle of each PPE row
  /// The right-hand side of the last PPE solve (row order ppe_rows(); known neighbours' values moved into
  /// it).
  const Eigen::VectorXd& ppe_rhs() const { return b_; }
  /// pressure-boundary fluxes of the last step
  const boundary::pressure_flux& last_flux() const { return last_flux_; }
  /// c of the last step (real + copies), in that step's particle order: after a step that resized the state
  /// (splits, merges, inflow, outflow) entry i is no longer state() particle i. The same holds for normals(),
  /// neighbours(), op() and diameter(i).
  const Eigen::VectorXd& packing_ratio() const { return c_pack_; }
  /// ρ(B_i) of the own-loop guard's last check this step, per real particle (NaN where not checked; empty
  /// when the guard is off). See own_loop_guard_params.
  const Eigen::VectorXd& own_loop_gains() const { return own_loop_gain_; }
  /// normals of the last step (its order: packing_ratio())
  const points<D>& normals() const { return normal_; }
  const time_step_controller& time_step() const { return dt_ctrl_; }  ///< Δt controller
  /// Split/merge ledger (Scene::resolution): one closed step per step() call.
  const resolution::conservation_ledger<D>& ledger() const { return ledger_; }
  /// What the resolution stage of the last step did (empty for resolution::uniform).
  const resolution::split_merge_report<D>& last_resolution() const { return last_resolution_; }
  /// Diameter of particle i in the last step (V^(1/D)).
  double diameter(index_t i) const { return L_[i]; }
  /// Shifting displacement δx of particle i in the last step (eqs. 93–100; zero in a scene without shifting),
  /// in that step's particle order (see packing_ratio()).
  vec<D> shift_displacement(index_t i) const {
    if constexpr (has_shift)
      if (i < 0 || i >= dx_.cols())
        fail("lsmps_semi_implicit::shift_displacement: i = ", i, ", accepted range [0, ", dx_.cols(), ")");
    return dx_shift(i);
  }

  /// Advances one step.
  void step() {
    s_.clear_ghosts();
    if (p_.remove_outside.any()) remove_outside();
    const index_t n = s_.n_real();
    // 1. Δt: Courant α_C min L / max |u| over fluid (a deviation, the default), or eq. 64 as written,
    //    min_i α_C L_i/|u_i| (time_step_params::per_particle_courant); the same at single resolution. The
    //    viscous limit at the smallest L.
    double umax = 0.0, lmin = std::numeric_limits<double>::infinity();
    double lc = 0.0, uc = 0.0;  // the Courant pair of the limiting particle
    index_t fastest = npos, limiting = npos;
    const auto& V = s_.template get<field::volume>();
    for (index_t i = 0; i < n; ++i) {
      const double Li = diameter_of_volume(V[i]);
      lmin = std::min(lmin, Li);
      const double u = s_.u().col(i).norm();
      if (u > umax) {
        umax = u;
        fastest = i;
      }
      if (u > 0.0 && (limiting == npos || Li * uc < lc * u)) {  // L_i/u_i < lc/uc without dividing
        lc = Li;
        uc = u;
        limiting = i;
      }
    }
    dt_ctrl_.check_speed(umax, c_.steps, fastest == npos ? npos : id_of(fastest));
    if (p_.time.per_particle_courant)
      dt_ = dt_ctrl_.next(lc, uc, lmin, p_.nu, c_.steps, limiting == npos ? npos : id_of(limiting));
    else
      dt_ = dt_ctrl_.next(lmin, umax, p_.nu, c_.steps, fastest == npos ? npos : id_of(fastest));
    const double dt = dt_;
    copies_.clear();
    if (p_.reorder_every > 0 && c_.steps % p_.reorder_every == 0 && n > 0) {
      sizes_from_volumes();
      build_list();
      s_.reorder(nl_.cells().order());
      ++c_.reorders;
    }

    // 2. Imaginary copies (ghost range).
    if constexpr (has_walls) make_copies();
    nc_ = s_.size();  // copies are [n, nc_); pressure-boundary particles [nc_, nt)
    if constexpr (has_pressure_boundary) add_boundary_particles();
    const index_t nt = s_.size();
    if constexpr (!has_walls) normal_.setZero(D, nt);
    sizes_from_volumes();
    // 3. Neighbour list over real + copies.
    build_list();
    const points<D>& x = s_.x();
    auto& flags = s_.flags();
    std::fill(flags.begin(), flags.end(), flag::type{0});

    // 4. Packing ratio (everyone participates: isolation is decided from c) and isolated particles (a copy
    //    of an isolated parent is excluded with it).
    excluded_.assign(static_cast<std::size_t>(nt), 0);
    const auto is_copy = [n](index_t j) { return j >= n; };
    surface::packing_ratio(
        exec::par{}, x, L_, nl_, [](index_t) { return true; }, is_copy, p_.packing, c_pack_);
    c_.isolated += static_cast<long>(surface::isolated_flags(c_pack_.head(n), p_.packing.alpha_c, flags));
    for (index_t i = 0; i < n; ++i)
      excluded_[static_cast<std::size_t>(i)] = (flags[static_cast<std::size_t>(i)] & flag::isolated) != 0;
    for (index_t k = n; k < nc_; ++k)
      excluded_[static_cast<std::size_t>(k)] = excluded_[static_cast<std::size_t>(parent(k))];
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };

    // 5. Normals (real fluid; copies keep the wall's) and surface flags; copies inherit the parent's flag.
    surface_.assign(static_cast<std::size_t>(nt), 0);
    if constexpr (has_surface) {
      const auto wanted = [&](index_t i) { return i < n && participates(i); };
      surface::normals(exec::par{}, x, L_, nl_, participates, normal_, normal_degenerate_, wanted);
      surface::geometric(exec::par{}, x, L_, nl_, participates, normal_, p_.surface, surface_, wanted,
                         walls_);
      for (index_t i = 0; i < n; ++i)
        if (!participates(i)) surface_[static_cast<std::size_t>(i)] = 0;
      for (index_t k = n; k < nc_; ++k)
        surface_[static_cast<std::size_t>(k)] = surface_[static_cast<std::size_t>(parent(k))];
      for (index_t i = 0; i < nt; ++i)
        if (surface_[static_cast<std::size_t>(i)]) flags[static_cast<std::size_t>(i)] |= flag::surface;
    }

    // 6. LSMPS moments at x^k; copies carry the Neumann constraint (constrained_poisson), or are the Neumann
    //    points of a second, pressure-only operator (neumann_points).
    const bool constrained = has_walls && p_.copy_row == copy_row_kind::constrained_poisson;
    if (constrained || neumann_points()) {
      copy_mark_.assign(static_cast<std::size_t>(nt), 0);
      for (index_t k = n; k < nc_; ++k) copy_mark_[static_cast<std::size_t>(k)] = 1;
    }
    if (constrained)
      op_.compute(exec::par{}, x, nl_, op::per_particle_size{&L_},
                  op::neumann_constraint<D>{&normal_, &copy_mark_}, participates);
    else
      op_.compute(exec::par{}, x, nl_, op::per_particle_size{&L_}, participates);
    if (neumann_points())
      op_p_.compute(exec::par{}, x, nl_, op::per_particle_size{&L_},
                    op::neumann_points<D>{&normal_, &copy_mark_, &dpdn_}, participates);
    for (index_t i = 0; i < nt; ++i)
      if (participates(i) && (op_.flags()[static_cast<std::size_t>(i)] & flag::degenerate)) {
        flags[static_cast<std::size_t>(i)] |= flag::degenerate;
        ++c_.degenerate;
      }

    // Pressure-boundary particles: u by neighbour averaging of the fluid's u^k (Tanaka §4.5.2, as walls).
    if constexpr (has_pressure_boundary) boundary_velocities(s_.u(), s_.u());
    // 7. Explicit prediction; copies hold the wall velocity.
    points<D>& u = s_.u();
    ut_ = u;
    for (int a = 0; a < D; ++a) comp_[a] = u.row(a).transpose();
    for_each_particle(exec::par{}, n, [&](index_t i) {
      vec<D> acc = p_.g;
      if (participates(i) && p_.nu > 0.0) {
        const vec<D> lap = detail::component_laplacians(op_, x, nl_, i, comp_, participates);
        for (int a = 0; a < D; ++a) acc[a] += p_.nu * lap[a];
      }
      ut_.col(i) = u.col(i) + dt * acc;
    });
    // 7b. Pair collisions on the predicted velocities (ours, opt-in: collide_before_ppe). The copies' columns
    //     of ut_ still hold the wall velocity here (ut_ = u above); their averaged u′ is set below.
    if (p_.collision.alpha1 > 0.0 && p_.collide_before_ppe) collide(n, ut_);
    // Copies: u′_w = w-weighted average of the participating fluid neighbours' u′ (§4.5.1).
    for_each_particle(exec::par{}, nc_ - n, [&](index_t k0) {
      const index_t k = n + k0;
      vec<D> sum = vec<D>::Zero();
      double wsum = 0.0;
      nl_.for_each_neighbour(x, k, support(), [&](index_t j, const vec<D>& xkj, double r2) {
        if (j >= n || !participates(j)) return;
        const double Rkj = 0.5 * (re(k) + re(j));
        const double w = kernel::quadratic::w(std::sqrt(r2), Rkj);
        (void)xkj;
        sum += w * ut_.col(j);
        wsum += w;
      });
      ut_.col(k) = wsum > 0.0 ? vec<D>(sum / wsum) : s_.u().col(k);
      if (p_.copy_neumann == copy_neumann_velocity::parent) ut_.col(k) = ut_.col(parent(k));
    });

    // Pressure-boundary particles: u′ by neighbour averaging of the fluid's u′ (enters ∇u′ of the source).
    if constexpr (has_pressure_boundary) boundary_velocities(ut_, ut_);
    // 8. PPE.
    solve_pressure(dt);

    // 9. Correction at x^k.
    auto& pres = s_.template get<field::pressure>();
    xold_ = x.leftCols(n);
    const double inv_rho = 1.0 / p_.rho;
    for_each_particle(exec::par{}, n, [&](index_t i) {
      vec<D> unew = ut_.col(i);
      if (participates(i)) unew -= dt * inv_rho * pressure_op().gradient(x, nl_, i, pres, participates);
      s_.u().col(i) = unew;
    });
    // 9b. Velocity filter in the one-sided band (a deviation; regularize/boundary_filter.hpp): particles with
    //     a copy, a pressure-boundary particle, a free-surface particle or (multi-resolution) a particle of
    //     another size among their neighbours. The band (one_sided_) is flagged in the near-surface sweep of
    //     solve_pressure.
    if (p_.boundary_filter.strength > 0.0) {
      const auto one_sided = [&](index_t i) { return one_sided_[static_cast<std::size_t>(i)] != 0; };
      // Fitted values: the fluid's velocities and the copies' wall velocity (no-slip; with the parent's
      // velocity instead the 60° tank kept an eigenvalue 1.0008, measured); pressure-boundary particles (an
      // average, not the fluid's own field: 1.7 % off a uniform start-up flow, measured) are left out. The
      // filter reads every value before it writes any, so u is both the fitted values and the output.
      const auto fitted = [&](index_t j) { return j < nc_ && participates(j); };
      const regularize::boundary_filter_report fr =
          regularize::boundary_filter(exec::par{}, x, L_, nl_, support(), p_.op, fitted, one_sided, n,
                                      p_.boundary_filter, s_.u(), s_.u(), filter_du_);
      c_.filtered += static_cast<long>(fr.filtered);
      c_.filter_amplifying += static_cast<long>(fr.amplifying);
      c_.filter_tapered += static_cast<long>(fr.tapered);
    }
    // 9c. Pair collisions (ours, opt-in: lsmps_params::collision).
    if (p_.collision.alpha1 > 0.0 && !p_.collide_before_ppe) collide(n, s_.u());
    // 10. Shifting (δx from this step's lists at x^k; δu = ∇u δx, eq. 91).
    if constexpr (has_shift) shift_particles();
    for_each_particle(exec::par{}, n, [&](index_t i) { s_.x().col(i) += dt * s_.u().col(i) + dx_shift(i); });
    // 11. Guard, wrap, checks.
    if constexpr (has_walls) {
      // The guard reads and writes the first n columns only (the copies behind them are left as they are).
      c_.guarded +=
          wall::guard_crossings(exec::par{}, xold_, s_.x(), s_.u(), L_, n, *walls_, p_.guard, &flags);
    }
    if (p_.domain.any_periodic())
      for (index_t i = 0; i < n; ++i) s_.x().col(i) = p_.domain.wrap(s_.x().col(i));
    // 12–13. Resolution stage and pressure-boundary outflow/inflow (Tanaka §4.5.2). Both read this step's
    //        neighbour list and resize the state: the exchange is decided first (on the list), the particles
    //        leaving take no part in split/merge, the resolution stage resizes, then the exchange is applied
    //        with its removal marks carried through the stage's old_to_new map.
    if constexpr (has_pressure_boundary) {
      boundary_exchange plan = plan_boundary_exchange();
      if constexpr (has_resolution) {
        resolve_sizes(&plan.remove);
        // else no resize
        if (last_resolution_.splits + last_resolution_.merges > 0) remap_marks(plan.remove);
      }
      apply_boundary_exchange(plan);
      if constexpr (has_resolution) {
        ledger_.add_flux("pressure_inflow", plan.flux.inflow_volume, plan.inflow_momentum, plan.flux.inflow);
        ledger_.add_flux("pressure_outflow", -plan.flux.outflow_volume, -plan.outflow_momentum,
                         -(plan.flux.outflow + plan.flux.behind));
        ledger_.close_step();
      }
    } else if constexpr (has_resolution) {
      resolve_sizes();
      ledger_.close_step();
    }
    t_ += dt;
    ++c_.steps;
    check_finite();
  }

  /// Steps until time() >= t_end (the last step is not shortened), calling observer(*this) after each.
  template <class Observer>
  void run_until(double t_end, Observer&& observer) {
    step_until(*this, t_end, observer);
  }
  /// Steps until time() >= t_end.
  void run_until(double t_end) {
    run_until(t_end, [](const lsmps_semi_implicit&) {});
  }

 private:
  static const params_type& checked(const params_type& p) {
    p.validate();
    return p;
  }
  static double diameter_of_volume(double v) { return D == 2 ? std::sqrt(v) : std::cbrt(v); }
  /// "particle i (id …)" or "imaginary copy i of particle p (id …)" for error messages.
  std::string describe(index_t i) const {
    if (i < s_.n_real()) return mpskit::detail::concat("particle ", i, " (id ", id_of(i), ")");
    if (i >= nc_) return mpskit::detail::concat("pressure-boundary particle ", i - nc_);
    const index_t par = parent(i);
    return mpskit::detail::concat("imaginary copy ", i, " of particle ", par, " (id ", id_of(par), ")");
  }
  kind kind_of(index_t i) const { return s_.kinds()[static_cast<std::size_t>(i)]; }
  particle_id id_of(index_t i) const { return s_.ids()[static_cast<std::size_t>(i)]; }
  index_t parent(index_t k) const { return s_.template get<field::parent>()[static_cast<std::size_t>(k)]; }
  double re(index_t i) const { return p_.op.re_ratio * L_[i]; }
  search::support<search::per_particle_radius> support() const {
    return {search::per_particle_radius{&L_, p_.op.re_ratio}, search::radius_rule::pair_mean};
  }

  void sizes_from_volumes() {
    const auto& V = s_.template get<field::volume>();
    L_.resize(s_.size());
    for (index_t i = 0; i < s_.size(); ++i) L_[i] = diameter_of_volume(V[i]);
  }

  void build_list() {
    if constexpr (has_walls) {
      if (p_.thin_walls) {
        wall::wall_visibility<D> vis{walls_, &s_.x(), s_.n_real(), &copies_, &p_.domain};
        vis.other_ghosts = s_.size() - s_.n_real() - static_cast<index_t>(copies_.size());
        vis.prepare(exec::par{}, p_.op.re_ratio * L_.maxCoeff() * (1.0 + p_.skin));
        nl_.build(exec::par{}, s_.x(), search::per_particle_radius{&L_, p_.op.re_ratio}, {p_.skin, p_.domain},
                  vis);
        ++c_.list_builds;
        return;
      }
    }
    nl_.build(exec::par{}, s_.x(), search::per_particle_radius{&L_, p_.op.re_ratio}, {p_.skin, p_.domain});
    ++c_.list_builds;
  }

  /// Imaginary copies of every fluid particle within α_w L of a wall (wall/imaginary.hpp), appended as
  /// ghosts: position on the wall, diameter eq. 76, wall velocity, wall normal (toward the fluid).
  void make_copies() {
    const index_t n = s_.n_real();
    sizes_from_volumes();
    copies_.clear();
    const auto rep = wall::make_imaginary(
        exec::par{}, s_.x(), L_, n, [](index_t) { return true; }, *walls_, p_.walls, copies_);
    c_.copies += static_cast<long>(copies_.size());
    c_.small_diameter_events += static_cast<long>(rep.small_diameter_events);
    const index_t m = static_cast<index_t>(copies_.size());
    normal_.setZero(D, n + m);
    // first_copy_: the copies of particle i are [n + first_copy_[i], n + first_copy_[i + 1]); make_imaginary
    // writes them grouped by parent in ascending order (checked: the ranges must match)
    first_copy_.assign(static_cast<std::size_t>(n) + 1, 0);
    for (index_t k = 0; k < m; ++k)
      ++first_copy_[static_cast<std::size_t>(copies_[static_cast<std::size_t>(k)].parent) + 1];
    for (index_t i = 0; i < n; ++i)
      first_copy_[static_cast<std::size_t>(i) + 1] += first_copy_[static_cast<std::size_t>(i)];
    for (index_t k = 0; k < m; ++k) {
      const std::size_t i = static_cast<std::size_t>(copies_[static_cast<std::size_t>(k)].parent);
      if (k < first_copy_[i] || k >= first_copy_[i + 1])
        fail("lsmps_semi_implicit: the wall copies are not grouped by parent (copy ", k, ", parent ", i, ")");
    }
    if (m == 0) return;
    const index_t first = s_.add_ghosts(m, ghost_role::imaginary);
    auto& V = s_.template get<field::volume>();
    auto& par = s_.template get<field::parent>();
    auto& pres = s_.template get<field::pressure>();
    for (index_t k = 0; k < m; ++k) {
      const auto& cp = copies_[static_cast<std::size_t>(k)];
      const index_t g = first + k;
      s_.x().col(g) = cp.x;
      s_.u().col(g) = cp.wall_velocity;
      s_.kinds()[static_cast<std::size_t>(g)] = kind::wall;
      V[g] = std::pow(cp.L, D);
      par[static_cast<std::size_t>(g)] = cp.parent;
      pres[g] = 0.0;
      normal_.col(g) = cp.normal;
    }
  }

  /// Pressure-boundary particles (Tanaka §4.5.2, placed in advance) appended as ghosts after the copies:
  /// kind pressure_boundary, V = L_p^D, p = P_b, normal n_p; velocities are set after the list build.
  void add_boundary_particles() {
    const index_t nb = pb_->size();
    const index_t first = s_.add_ghosts(nb, ghost_role::pressure);
    auto& V = s_.template get<field::volume>();
    auto& pres = s_.template get<field::pressure>();
    normal_.conservativeResize(D, first + nb);
    for (index_t k = 0; k < nb; ++k) {
      const index_t g = first + k;
      s_.x().col(g) = pb_->x().col(k);
      s_.u().col(g).setZero();
      s_.kinds()[static_cast<std::size_t>(g)] = kind::pressure_boundary;
      V[g] = std::pow(pb_->diameters()[k], D);
      pres[g] = pb_->pressures()[k];
      normal_.col(g) = pb_->normals().col(k);
    }
  }

  /// dst's pressure-boundary columns from src's fluid columns (neighbour averaging, boundary/pressure.hpp).
  void boundary_velocities(const points<D>& src, points<D>& dst) {
    const index_t n = s_.n_real();
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    for_each_particle(exec::par{}, pb_->size(), [&](index_t k) {
      dst.col(nc_ + k) =
          pb_->averaged_velocity(s_.x(), nl_, nc_ + k, k, n, L_, p_.op.re_ratio, src, participates);
    });
  }

  /// What the step end does at the pressure boundaries: the removal marks (real particles), the particles
  /// to create, the fluxes.
  struct boundary_exchange {
    std::vector<std::uint8_t> remove;
    std::vector<boundary::inflow_particle<D>> born;
    boundary::pressure_flux flux;
    vec<D> inflow_momentum = vec<D>::Zero(), outflow_momentum = vec<D>::Zero();  ///< Σ V u (ledger)
  };

  /// Multi-resolution with pressure boundaries: inflow creates particles of the boundary particle's diameter
  /// L_p at x_l = x_p + α_i L_p n_p (Tanaka §4.5.2), so L_p must not be one the trigger splits there (with
  /// Tanaka's thresholds L*(x_l) < β_s L_p). Such faces feed the refined layer beside them with coarse
  /// particles that split on arrival, next to the face where P_b is imposed: in the 3D duct the flow then
  /// lagged 3.8 % against 0.7 % with the faces at the target spacing (docs/resolution.md). Refused here with
  /// the remedy (ours: the paper does not discuss it). Finer boundary particles than the target are accepted:
  /// their inflow particles merge in the fluid, counted as merges (a 3D face triangle is cut uniformly at the
  /// smallest L* of its corners, so a face spanning a refined and a coarse zone always has some). A target
  /// reading the context gets the inflow point's wall distance; its surface distance is +inf and its index
  /// npos (no particle yet).
  void check_boundary_spacing() const {
    const auto& rp = p_.resolution;
    if (!rp.split) return;  // nothing splits
    for (index_t k = 0; k < pb_->size(); ++k) {
      const double Lp = pb_->diameters()[k];
      const auto tp = rp.target_diameter.point(
          vec<D>(pb_->x().col(k) + pb_->params().alpha_i * Lp * pb_->normals().col(k)),
          [this](const vec<D>& y) {
            if constexpr (has_walls)
              return walls_->signed_distance(y);
            else
              return std::numeric_limits<double>::infinity();
          });
      const double Ls = rp.target_diameter.checked(tp, "lsmps_semi_implicit", [&] {
        return mpskit::detail::concat("the inflow point (", tp.x.transpose(),
                                      ") of pressure-boundary particle ", k);
      });
      if (resolution_type::trigger::template decide<D>(Ls, Lp) == resolution::want::split)
        fail("lsmps_semi_implicit: pressure-boundary particle ", k, " at (", pb_->x().col(k).transpose(),
             ") has spacing L_p = ", Lp, " but the target diameter at its inflow point is L* = ", Ls,
             ": its inflow particles would split on arrival. Build the pressure_boundary with the target "
             "diameter as its spacing (pressure_boundary(faces, P_b, spacing_callable, params))");
    }
  }

  /// Step end (Tanaka §4.5.2), decided on this step's list: outflow removal and inflow creation at the moved
  /// positions with the boundary velocities averaged from the corrected fluid velocities.
  boundary_exchange plan_boundary_exchange() {
    const index_t n = s_.n_real(), nb = pb_->size();
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    points<D> ub(D, nb);
    for (index_t k = 0; k < nb; ++k)
      ub.col(k) =
          pb_->averaged_velocity(s_.x(), nl_, nc_ + k, k, n, L_, p_.op.re_ratio, s_.u(), participates);
    const auto& V = s_.template get<field::volume>();
    boundary_exchange plan;
    plan.remove.assign(static_cast<std::size_t>(n), 0);
    pb_->mark_outflow(s_.x(), L_, n, nc_, ub, nl_, plan.remove, plan.flux, V);
    for (index_t i = 0; i < n; ++i)
      if (plan.remove[static_cast<std::size_t>(i)]) plan.outflow_momentum += V[i] * s_.u().col(i);
    pb_->find_inflow(s_.x(), s_.u(), L_, n, nc_, ub, nl_, plan.remove,
                     [&](index_t j) { return j < nc_ && participates(j); }, p_.op, plan.born);
    return plan;
  }

  /// lsmps_params::remove_outside: at the step's start (no ghosts), the real particles outside the box are
  /// removed through the state's resize path; their volume and momentum go to the ledger as a flux.
  /// (Positions are finite here: the constructor and restore() validate them and every step ends with
  /// check_finite().)
  void remove_outside() {
    const index_t n = s_.n_real();
    std::vector<std::uint8_t> marks(static_cast<std::size_t>(n), 0);
    index_t k = 0;
    double volume = 0.0;
    vec<D> momentum = vec<D>::Zero();
    const auto& V = s_.template get<field::volume>();
    for (index_t i = 0; i < n; ++i)
      if (!p_.remove_outside.contains(s_.x().col(i))) {
        marks[static_cast<std::size_t>(i)] = 1;
        ++k;
        volume += V[i];
        momentum += V[i] * s_.u().col(i);
      }
    if (k == 0) return;
    if (k == n)
      fail("lsmps_semi_implicit: every particle (", n,
           ") lies outside lsmps_params::remove_outside at the start of "
           "step ",
           c_.steps + 1, ": nothing left to simulate");
    s_.remove(marks);
    c_.left_domain += static_cast<long>(k);
    c_.left_domain_volume += volume;
    if constexpr (has_resolution) ledger_.add_flux("left_domain", -volume, -momentum, -k);
  }

  /// Carries removal marks through the resolution stage's resize (old_to_new). Marked particles were frozen
  /// (no event), so each is kept in exactly one slot.
  void remap_marks(std::vector<std::uint8_t>& marks) const {
    std::vector<std::uint8_t> moved(static_cast<std::size_t>(s_.n_real()), 0);
    const auto& o2n = last_resolution_.resize.old_to_new;
    for (std::size_t i = 0; i < marks.size(); ++i) {
      if (!marks[i]) continue;
      if (i >= o2n.size() || o2n[i] == npos)
        fail("lsmps_semi_implicit: a particle leaving through a pressure boundary was lost by split/merge");
      moved[static_cast<std::size_t>(o2n[i])] = 1;
    }
    marks = std::move(moved);
  }

  /// Applies a planned exchange: ghosts cleared, then one remove and one append through the state's resize
  /// path; counted as boundary fluxes.
  void apply_boundary_exchange(boundary_exchange& plan) {
    auto& flux = plan.flux;
    const auto& born = plan.born;
    s_.clear_ghosts();
    if (flux.outflow + flux.behind > 0) s_.remove(plan.remove);
    if (!born.empty()) {
      const index_t first = s_.append(static_cast<index_t>(born.size()), kind::fluid);
      auto& Vn = s_.template get<field::volume>();
      auto& pres = s_.template get<field::pressure>();
      for (std::size_t b = 0; b < born.size(); ++b) {
        const index_t i = first + static_cast<index_t>(b);
        s_.x().col(i) = born[b].x;
        s_.u().col(i) = born[b].u;
        Vn[i] = std::pow(born[b].L, D);
        pres[i] = born[b].p;
        flux.inflow_volume += Vn[i];
        plan.inflow_momentum += Vn[i] * born[b].u;
      }
      flux.inflow = static_cast<index_t>(born.size());
    }
    c_.inflow += static_cast<long>(flux.inflow);
    c_.outflow += static_cast<long>(flux.outflow);
    c_.outflow_behind += static_cast<long>(flux.behind);
    c_.inflow_volume += flux.inflow_volume;
    c_.outflow_volume += flux.outflow_volume;
    last_flux_ = flux;
    if constexpr (has_resolution) sizes_from_volumes();
  }

  /// 9c. Seed 001 eq. 13 between the participating fluid particles and against their copies (wall velocity,
  /// immovable) on this step's list at x^k (the velocities are the corrected, filtered ones, or with
  /// collide_before_ppe the predicted ones, 7b; the copies' u is the wall's); the isolated ones too with
  /// collision.isolated. Pressure-boundary particles take no part.
  /// Jacobi: every Δu from the same u. u: s_.u() after the correction, ut_ before the PPE
  /// (collide_before_ppe; its copies' columns then hold the wall velocity).
  void collide(index_t n, points<D>& u) {
    // excluded_ marks the isolated particles and their copies: in the stage only with collision.isolated.
    const bool all = p_.collision.isolated;
    const auto movable = [this, n, all](index_t i) {
      return i < n && (all || !excluded_[static_cast<std::size_t>(i)]);
    };
    const auto partner = [this, all](index_t j) {
      return j < nc_ && (all || !excluded_[static_cast<std::size_t>(j)]);
    };
    const regularize::collision_report rep =
        regularize::sized_collisions(exec::par{}, s_.x(), u, L_, s_.template get<field::volume>(), nl_,
                                     partner, movable, p_.collision, collision_du_);
    u.leftCols(n) += collision_du_.leftCols(n);
    c_.collisions += static_cast<long>(rep.pairs);
    c_.collision_coincident += static_cast<long>(rep.coincident);
  }

  /// Tanaka's shifting (eqs. 93–100) from this step's list at x^k; δu = ∇u δx (eq. 91) with the corrected
  /// velocities' LSMPS gradient (copies at the wall velocity). Surface particles and particles with a wall
  /// copy (within α_w L of a wall) shift tangentially only (eq. 99).
  void shift_particles() {
    const index_t n = s_.n_real(), nt = s_.size();
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    const points<D>& x = s_.x();
    points<D> grad_c(D, nt);
    grad_c.setZero();
    for_each_particle(exec::par{}, n, [&](index_t i) {
      if (participates(i)) grad_c.col(i) = op_.gradient(x, nl_, i, c_pack_, participates);
    });
    std::vector<std::uint8_t> tangential(static_cast<std::size_t>(nt), 0),
        active(static_cast<std::size_t>(n), 0);
    for (index_t i = 0; i < n; ++i) {
      active[static_cast<std::size_t>(i)] = participates(i);
      tangential[static_cast<std::size_t>(i)] = surface_[static_cast<std::size_t>(i)];
    }
    wall_normal_.setZero(D, n);
    const bool second = p_.shift_second_wall;
    if (second) wall_normal2_.setZero(D, n);
    for (index_t k = n; k < nc_; ++k) {  // within α_w L of a wall: tangential to the wall too (eq. 99)
      const index_t i = parent(k);
      tangential[static_cast<std::size_t>(i)] = 1;
      if (wall_normal_.col(i).isZero(0.0)) wall_normal_.col(i) = normal_.col(k);
      else if (second && wall_normal2_.col(i).isZero(0.0) &&
               std::abs(wall_normal_.col(i).dot(normal_.col(k))) < 1.0 - 1e-6)
        wall_normal2_.col(i) =
            normal_.col(k);  // a second wall (an edge, a corner): tangential to it too (ours)
    }
    // Within 2 L_i of a pressure-boundary particle: no shifting (a deviation; Tanaka is silent).
    // Unrestricted, it pushed the particles beside an outflow face into the gaps that removals leave (the
    // 20 mm channel failed at step 227); tangential to the face (eq. 99 with n_p), it pushed them between the
    // boundary particles, past the outflow test r_ip < α_o L, and the channel failed at step 142.
    for (index_t k = nc_; k < nt; ++k)
      for (const auto jj : nl_.neighbours(k)) {
        const index_t i = static_cast<index_t>(jj);
        if (i >= n || nl_.displacement(x, k, i).squaredNorm() >= 4.0 * L_[i] * L_[i]) continue;
        active[static_cast<std::size_t>(i)] = 0;
      }
    std::vector<std::uint8_t> penalty_only;  // deviation 18: real isolated particles, eq. 96 only
    if (p_.shift_isolated_penalty) {
      penalty_only.assign(static_cast<std::size_t>(nt), 0);
      for (index_t i = 0; i < n; ++i)
        penalty_only[static_cast<std::size_t>(i)] = excluded_[static_cast<std::size_t>(i)];
    }
    const auto rep = regularize::tanaka_shift_displacement(
        exec::par{}, x, L_, nl_, participates, grad_c, normal_, tangential, active, p_.shift, dx_,
        &wall_normal_, second ? &wall_normal2_ : nullptr,
        p_.shift_isolated_penalty ? &penalty_only : nullptr);
    c_.shift_limited += static_cast<long>(rep.limited);
    c_.shift_coincident += static_cast<long>(rep.coincident_pairs);
    if (p_.shift_merged_faces && walls_ && nc_ > n) keep_off_merged_faces(n);
    for (int a = 0; a < D; ++a) comp_[a] = s_.u().row(a).transpose();
    if (!p_.shift_velocity_limit) {
      for_each_particle(exec::par{}, n, [&](index_t i) {
        if (!active[static_cast<std::size_t>(i)] || (dx_.col(i).array() == 0.0).all()) return;
        const mat<D> G = detail::component_gradients(op_, x, nl_, i, comp_, participates);
        s_.u().col(i) += G * dx_.col(i);  // eq. 91
      });
      return;
    }
    // The limiter reads every particle's velocity before the shift: the new ones go to u_new_ first.
    u_new_ = s_.u().leftCols(n);
    std::vector<std::uint8_t> clipped(static_cast<std::size_t>(n), 0);
    for_each_particle(exec::par{}, n, [&](index_t i) {
      if (!active[static_cast<std::size_t>(i)] || (dx_.col(i).array() == 0.0).all()) return;
      const mat<D> G = detail::component_gradients(op_, x, nl_, i, comp_, participates);
      vec<D> un = s_.u().col(i) + G * dx_.col(i);  // eq. 91
      clipped[static_cast<std::size_t>(i)] =
          regularize::limit_to_neighbour_range(un, s_.u(), i, nl_.neighbours(i), participates);
      u_new_.col(i) = un;
    });
    s_.u().leftCols(n) = u_new_;
    c_.shift_velocity_clipped += std::count(clipped.begin(), clipped.end(), std::uint8_t{1});
  }
  /// Deviation 14 (docs/lsmps_scheme.md): for particle i with copies, every face within α_w L_i whose foot
  /// lies on it and which is seen from the front ((x_i − q)·n ≥ 0, as wall/imaginary.hpp decides copies) but
  /// whose normal is no copy's normal of i was merged away; if δx_i points into it (δx·n < 0) that component
  /// is removed. The merge angle is < 90°, so n·n_copy > 0 and the removal leaves δx·n_copy ≥ 0: eq. 99's own
  /// wall is not entered either. Only a concave kink has two faces' feet in reach: at a convex corner the
  /// feet exclude each other. |δx| only shrinks, so eq. 100's limit still holds.
  void keep_off_merged_faces(index_t n) {
    const points<D>& x = s_.x();
    for_each_particle(exec::par{}, n, [&](index_t i) {
      const index_t c0 = n + first_copy(i), c1 = n + first_copy(i + 1);
      if (c0 == c1 || (dx_.col(i).array() == 0.0).all()) return;
      const vec<D> xi = x.col(i);
      const double r = p_.walls.alpha_w * L_[i];
      vec<D> d = dx_.col(i);
      walls_->for_each_element_within(xi, r, [&](const geometry::closest_point<D>& c) {
        if (c.kind != geometry::feature_kind::face || !(c.distance < r)) return;
        const vec<D> ne = walls_->element_normal(c.element);
        if ((xi - c.point).dot(ne) < 0.0) return;  // behind it: the other side of a thin wall
        // this face has its own copy
        for (index_t k = c0; k < c1; ++k) if (ne.dot(normal_.col(k)) > 1.0 - 1e-9) return;
        const double into = d.dot(ne);
        if (into < 0.0) d -= into * ne;
      });
      dx_.col(i) = d;
    });
  }
  vec<D> dx_shift(index_t i) const {
    if constexpr (has_shift) return dx_.col(i);
    else {
      (void)i;
      return vec<D>::Zero();
    }
  }

  /// 8. The PPE: solve_pressure_with_set, then, with lsmps_params::own_loop, the own-loop guard's checks,
  /// each followed by a new solve when it marked a particle.
  void solve_pressure(double dt) {
    solves_before_step_ = c_.ppe_solves;  // the solves after this step's first are repeats (the ledger)
    if (p_.own_loop.enabled) {
      const std::size_t n = static_cast<std::size_t>(s_.n_real());
      own_loop_dirichlet_.assign(n, 0);
      own_loop_one_point_.assign(n, 0);
      own_loop_zero_copies_.assign(n, 0);
      own_loop_gain_.setConstant(static_cast<index_t>(n), std::numeric_limits<double>::quiet_NaN());
    }
    // one call site of the solve (a second one let the compiler inline the whole build-and-solve twice)
    for (int round = 0;; ++round) {
      solve_pressure_with_set(dt);
      if (!p_.own_loop.enabled || round == p_.own_loop.rounds || own_loop_check(dt) == 0) return;
      ++c_.own_loop_solves;
    }
  }

  /// The own-loop guard's check (own_loop_guard_params; ours, docs/lsmps_scheme.md deviation 15) on the PPE
  /// just solved: for each candidate i, B_i = I − (Δt/ρ) ∂⟨∇p⟩_i/∂u′_i with δp from the patch system
  /// A_PP δp = δr_P, δr the change of the rows' residuals b − A p when u′_i (and the wall data of i's copies,
  /// which carry u′_i: copy_neumann = parent) moves by ε along each axis, every row rebuilt (the det F rows'
  /// coefficients depend on ∇u′ too). Marks the fallbacks where ρ(B_i) > max_gain; returns their number.
  index_t own_loop_check(double dt) {
    const index_t n = s_.n_real(), nt = s_.size();
    const points<D>& x = s_.x();
    const auto& pres = s_.template get<field::pressure>();
    if (rows_.empty()) return 0;
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    const bool one_point_fallback = p_.copy_two_point > 0.0 && p_.copy_row == copy_row_kind::parent_gradient;
    const auto known = [this](index_t j) { return unk_[static_cast<std::size_t>(j)] == npos; };
    std::vector<index_t> marked;
    std::vector<index_t> at(static_cast<std::size_t>(nt), npos), patch;
    Eigen::VectorXd dp_field = Eigen::VectorXd::Zero(nt);
    op::row_entries row;
    for (index_t i = 0; i < n; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      if (!participates(i) || own_loop_dirichlet_[si] || own_loop_one_point_[si] || own_loop_zero_copies_[si])
        continue;
      const index_t k0 = n + first_copy(i), k1 = n + first_copy(i + 1);
      bool candidate = false;
      if (!surface_[si]) {
        candidate = !known(i) && (c_pack_[i] < p_.own_loop.candidate_packing ||
                                  (k1 > k0 && c_pack_[i] < p_.own_loop.wall_candidate_packing));
      } else if (one_point_fallback) {
        for (index_t k = k0; k < k1; ++k) candidate = candidate || !known(k);
      }
      if (!candidate) continue;
      ++c_.own_loop_checked;
      // The patch: the unknowns within patch_radius R_e,i of i (a scan of the rows: O(m) per candidate, small
      // beside the rows' rebuilds; a copy is an unknown at its wall point).
      const double R = p_.own_loop.patch_radius * re(i);
      patch.clear();
      for (const index_t j : rows_)
        if ((x.col(j) - x.col(i)).squaredNorm() <= R * R) {
          at[static_cast<std::size_t>(j)] = static_cast<index_t>(patch.size());
          patch.push_back(j);
        }
      const index_t mp = static_cast<index_t>(patch.size());
      mat<D> B = mat<D>::Identity();
      if (mp > 0) {
        Eigen::MatrixXd Ap = Eigen::MatrixXd::Zero(mp, mp);
        Eigen::VectorXd res0(mp);
        for (index_t q = 0; q < mp; ++q) {
          const index_t j = patch[static_cast<std::size_t>(q)];
          for (ppe::matrix::InnerIterator it(A_, unk_[static_cast<std::size_t>(j)]); it; ++it) {
            const index_t c = at[static_cast<std::size_t>(rows_[static_cast<std::size_t>(it.col())])];
            if (c != npos) Ap(q, c) = it.value();
          }
          const double b = build_ppe_row(j, dt, row);
          res0[q] = b - row.apply(pres) + row.constant();
        }
        const Eigen::PartialPivLU<Eigen::MatrixXd> lu(Ap);
        const double eps = 1e-6 * L_[i] / dt;  // ≈ 1e-6 of a particle's width per step
        Eigen::VectorXd dr(mp);
        // the values the perturbation touches, restored bitwise afterwards (x + ε − ε need not be x)
        std::vector<double> saved;
        for (int a = 0; a < D; ++a) {
          saved.clear();
          saved.push_back(ut_(a, i));
          saved.push_back(comp_[a][i]);
          for (index_t k = k0; k < k1; ++k) {
            saved.push_back(ut_(a, k));
            saved.push_back(comp_[a][k]);
            saved.push_back(dpdn_[k]);
          }
          ut_(a, i) += eps;
          comp_[a][i] += eps;
          for (index_t k = k0; k < k1; ++k) {
            if (p_.copy_neumann == copy_neumann_velocity::parent) ut_(a, k) += eps;
            if (p_.copy_velocity != copy_velocity_in_source::wall) comp_[a][k] = ut_(a, k);
            dpdn_[k] = p_.rho * (ut_.col(k) - s_.u().col(k)).dot(normal_.col(k)) / dt;
          }
          for (index_t q = 0; q < mp; ++q) {
            const double b = build_ppe_row(patch[static_cast<std::size_t>(q)], dt, row);
            dr[q] = (b - row.apply(pres) + row.constant() - res0[q]) / eps;
          }
          std::size_t at_saved = 0;
          ut_(a, i) = saved[at_saved++];
          comp_[a][i] = saved[at_saved++];
          for (index_t k = k0; k < k1; ++k) {
            ut_(a, k) = saved[at_saved++];
            comp_[a][k] = saved[at_saved++];
            dpdn_[k] = saved[at_saved++];
          }
          const Eigen::VectorXd dp = lu.solve(dr);
          for (index_t q = 0; q < mp; ++q) dp_field[patch[static_cast<std::size_t>(q)]] = dp[q];
          B.col(a) -= dt / p_.rho * pressure_op().gradient(x, nl_, i, dp_field, participates);
          for (index_t q = 0; q < mp; ++q) dp_field[patch[static_cast<std::size_t>(q)]] = 0.0;
        }
        for (const index_t j : patch) at[static_cast<std::size_t>(j)] = npos;
      }
      const double gain = detail::spectral_radius<D>(B);
      own_loop_gain_[i] = gain;
      if (gain > p_.own_loop.max_gain) marked.push_back(i);
    }
    // Marked after the sweep: every block of this round is computed on the same solved system.
    for (const index_t i : marked)
      if (!surface_[static_cast<std::size_t>(i)]) {
        own_loop_dirichlet_[static_cast<std::size_t>(i)] = 1;
        ++c_.own_loop_dirichlet;
      }
    // Surface parents: one-point copy rows are gradient rows of the parent's fit with no diagonal of their
    // own. A group of one-point parents whose fits see no unknown but the group's own copies is a
    // gradient-only system, singular when the fits are exactly determined: two surface particles alone in a
    // corner (each fit: the other particle and the four copies), where the quadratic ((x − x₁)·m)², m ⊥ x₂
    // − x₁, vanishes with its gradient at both parents and not at the copies (σ_min = 0 measured at 3.0, 3.4
    // and 4.4 mm). A parent is tied when its fit sees an unknown outside the group (a fluid particle, a copy
    // with a two-point row) or a copy of a tied parent; the group is this round's surface marks with the
    // earlier rounds' one-point parents, whose ties a new member can close. Tied parents get the one-point
    // rows, the others p = 0 copies.
    std::vector<index_t> group;
    for (index_t i = 0; i < n; ++i)
      if (own_loop_one_point_[static_cast<std::size_t>(i)]) group.push_back(i);
    const std::size_t earlier = group.size();
    for (const index_t i : marked)
      if (surface_[static_cast<std::size_t>(i)]) {
        group.push_back(i);
        own_loop_one_point_[static_cast<std::size_t>(i)] = 2;  // a member, for the ties below
      }
    if (!group.empty()) {
      const auto member_copy = [&](index_t j) {
        return j >= n && j < nc_ && own_loop_one_point_[static_cast<std::size_t>(parent(j))];
      };
      std::vector<std::uint8_t> tied(group.size(), 0);
      for (std::size_t g = 0; g < group.size(); ++g)
        nl_.for_each_neighbour(x, group[g], support(), [&](index_t j, const vec<D>&, double) {
          // this round's p = 0 marks are known in the next solve
          const bool unknown = !known(j) && !(j < n && own_loop_dirichlet_[static_cast<std::size_t>(j)]);
          if (participates(j) && unknown && !member_copy(j)) tied[g] = 1;
        });
      for (bool changed = true; changed;) {  // ties spread through shared copies (groups of a few particles)
        changed = false;
        for (std::size_t g = 0; g < group.size(); ++g) {
          if (tied[g]) continue;
          nl_.for_each_neighbour(x, group[g], support(), [&](index_t j, const vec<D>&, double) {
            if (tied[g] || !member_copy(j)) return;
            const auto h = std::find(group.begin(), group.end(), parent(j));
            if (h != group.end() && tied[static_cast<std::size_t>(h - group.begin())])
              tied[g] = changed = true;
          });
        }
      }
      for (std::size_t g = 0; g < group.size(); ++g) {
        const std::size_t i = static_cast<std::size_t>(group[g]);
        own_loop_one_point_[i] = tied[g];
        if (tied[g] && g >= earlier) ++c_.own_loop_one_point;
        if (!tied[g]) {
          own_loop_zero_copies_[i] = 1;
          ++c_.own_loop_dirichlet;
        }
      }
    }
    return static_cast<index_t>(marked.size());
  }

  /// The PPE with the own-loop guard's p = 0 rows and the active set of lsmps_params::active_set_solves
  /// (p ≥ 0; ours, docs/lsmps_scheme.md deviation 13): particles whose solved pressure is negative join the
  /// set (Dirichlet p = 0) and the system is built and solved again. A primal active-set iteration for the
  /// complementarity problem p ≥ 0 of Miyamoto & Koshizuka (arXiv:2302.14245, an MPS-family method with the
  /// incompressibility constraint as an LCP). By default without its release step: the set only grows within
  /// a step. With active_set_release, particles held at p = 0 whose row says they are compressed leave the
  /// set between the solves (the primal–dual active-set iteration; measured in docs/lsmps_scheme.md); with
  /// active_set_warm_start the set starts from the one the last solve ended with, and the releases are tested
  /// after the first solve too. The repeats reuse the first build's rows (active_set_reuse_rows;
  /// 1.41× → 1.23× the wall time without the set at 4 mm), except after a release, which brings rows back:
  /// the next solve builds them all.
  void solve_pressure_with_set(double dt) {
    const index_t n = s_.n_real();
    auto& pres = s_.template get<field::pressure>();
    active_set_.assign(static_cast<std::size_t>(s_.size()), 0);
    if (p_.own_loop.enabled)
      for (index_t i = 0; i < n; ++i)
        if (own_loop_dirichlet_[static_cast<std::size_t>(i)]) active_set_[static_cast<std::size_t>(i)] = 1;
    const bool warm = p_.active_set_warm_start && warm_start_active_set() > 0;
    bool rebuild = false;  // a release brings rows back: the next solve builds them all again
    for (int repeat = 0;; ++repeat) {
      if (repeat == 0 || !p_.active_set_reuse_rows || rebuild) solve_pressure_once(dt);
      else if (drop_active_set_rows() > 0) assemble_and_solve();
      if (p_.active_set_solves == 0) return;
      const bool last = repeat == p_.active_set_solves;  // what is found now is kept and counted
      // Releases first, among the particles held at p = 0 in this solve (not those joining now).
      release_.clear();
      const long released = p_.active_set_release && (repeat > 0 || warm) ? mark_active_set_releases(dt) : 0;
      long joined = 0;
      for (index_t i = 0; i < (p_.active_set_copies ? nc_ : n); ++i)
        if (unk_[static_cast<std::size_t>(i)] != npos && pres[i] < 0.0) {
          ++joined;
          if (!last) active_set_[static_cast<std::size_t>(i)] = 1;
        }
      if (joined == 0 && released == 0) return keep_active_set();
      if (last) {  // a negative pressure, or a member its row would release (held at p = 0), is left: counted
        ++c_.active_set_unfinished;
        return keep_active_set();
      }
      for (const index_t i : release_) active_set_[static_cast<std::size_t>(i)] = 0;
      rebuild = released > 0;
      c_.active_set_rows += joined;
      c_.active_set_released += released;
      ++c_.active_set_solves;
    }
  }

  /// Real particle i is held at p = 0 by the active set itself (not by the own-loop guard's Dirichlet rows).
  bool active_set_member(index_t i) const {
    const std::size_t k = static_cast<std::size_t>(i);
    return active_set_[k] && !(p_.own_loop.enabled && own_loop_dirichlet_[k]);
  }

  /// lsmps_params::active_set_warm_start: holds at p = 0 the real fluid particles of held_ids_ (the set the
  /// previous pressure solve ended with) that are neither surface nor isolated now. Returns their number.
  index_t warm_start_active_set() {
    const index_t n = s_.n_real();
    const auto& ids = s_.ids();
    index_t held = 0;
    for (index_t i = 0; i < n; ++i) {
      const std::size_t k = static_cast<std::size_t>(i);
      if (!surface_[k] && !excluded_[k] && !active_set_[k] &&
          std::binary_search(held_ids_.begin(), held_ids_.end(), ids[k])) {
        active_set_[k] = 1;
        ++held;
      }
    }
    return held;
  }

  /// With lsmps_params::active_set_warm_start: the ids of the real particles the set holds at the end of this
  /// solve (not the own-loop guard's), sorted, for the next solve's start.
  void keep_active_set() {
    if (!p_.active_set_warm_start) return;
    const index_t n = s_.n_real();
    const auto& ids = s_.ids();
    held_ids_.clear();
    for (index_t i = 0; i < n; ++i)
      if (active_set_member(i)) held_ids_.push_back(ids[static_cast<std::size_t>(i)]);
    std::sort(held_ids_.begin(), held_ids_.end());
  }

  /// The releases of lsmps_params::active_set_release: the real fluid particles held at p = 0 by the active
  /// set (not by the own-loop guard) whose own PPE row, built as an unknown's and evaluated at the current
  /// pressures, has w = b − Σ_j a_ij p_j < 0 with a diagonal a_ii < 0 — freed, the particle would take p ≈ w
  /// / a_ii > 0 (it is being compressed). Listed in release_ (applied by the caller after this solve's
  /// joins); returns their number. The rows do not depend on the set, so this is the row the particle had
  /// before it joined. (Keeping the first build's rows of the members, for this and for the solve after a
  /// release, instead of building them again: tried 2026-12-05, the same results (bitwise in the tests),
  /// slower at 5 mm in 3 rounds.)
  long mark_active_set_releases(double dt) {
    const index_t n = s_.n_real();
    const auto& pres = s_.template get<field::pressure>();
    release_candidates_.clear();
    for (index_t i = 0; i < n; ++i)
      if (active_set_member(i)) release_candidates_.push_back(i);
    const index_t m = static_cast<index_t>(release_candidates_.size());
    if (static_cast<index_t>(release_buf_.size()) < m) release_buf_.resize(static_cast<std::size_t>(m));
    release_flag_.assign(static_cast<std::size_t>(m), 0);
    for_each_particle(exec::par{}, m, [&](index_t k) {
      const index_t i = release_candidates_[static_cast<std::size_t>(k)];
      op::row_entries& row = release_buf_[static_cast<std::size_t>(k)];
      const double b = build_ppe_row(i, dt, row);
      if (!(row.diagonal() < 0.0)) return;  // a wrong-sign row (deviation 10) frees nothing
      double ap = 0.0;
      for_each_entry(row, i, [&](index_t j, double a) { ap += a * pres[j]; });
      release_flag_[static_cast<std::size_t>(k)] = b - ap < 0.0;
    });
    for (index_t k = 0; k < m; ++k)
      if (release_flag_[static_cast<std::size_t>(k)])
        release_.push_back(release_candidates_[static_cast<std::size_t>(k)]);
    return static_cast<long>(release_.size());
  }

  /// One PPE row (stage 8) of unknown particle i at the current ut_, comp_ and dpdn_: its coefficients in
  /// `row` (merged), its right-hand side returned, before the known neighbours' values are moved into it.
  double build_ppe_row(index_t i, double dt, op::row_entries& row) const {
    const index_t n = s_.n_real();
    const points<D>& x = s_.x();
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    double b = 0.0;
    if (i >= n && p_.copy_row == copy_row_kind::parent_gradient) {
      // The copy's unknown makes its parent's corrected normal velocity vanish (a deviation, docs/solver.md):
      // (1/ρ) n_k·⟨∇p⟩_parent = (u′_parent − u_wall)·n_k/Δt, the parent's own LSMPS gradient stencil.
      const index_t ip = parent(i);
      row.reset(ip);
      op_.build_row(x, nl_, ip,
                    typename op_type::vector(op_type::directional_selector(normal_.col(i)) / p_.rho),
                    participates, row);
      b = dpdn_[i] / p_.rho - row.constant();
      if (p_.copy_two_point > 0.0) {
        // The two-point form of eq. 83 between the copy and its parent (copy_two_point; a parent closer
        // than 1e-3 L to the wall has no usable distance and keeps the gradient row alone).
        const double d = (x.col(ip) - x.col(i)).dot(normal_.col(i));
        // the own-loop guard's fallback at a surface parent (own_loop_guard_params) drops the term
        if (d > 1e-3 * L_[ip] && !(own_loop_one_point_.size() > static_cast<std::size_t>(ip) &&
                                   own_loop_one_point_[static_cast<std::size_t>(ip)])) {
          const double a = p_.copy_two_point / (p_.rho * d);
          row.add(ip, a);
          row.add(i, -a);
          b += p_.copy_two_point * dpdn_[i] / p_.rho;
        }
      }
    } else if (i >= n && p_.copy_row == copy_row_kind::neumann) {
      // Eq. 83 as the copy's row: (1/ρ) n·∇p = (u′_w − u_wall)·n/Δt.
      row.reset(i);
      op_.build_row(x, nl_, i,
                    typename op_type::vector(op_type::directional_selector(normal_.col(i)) / p_.rho),
                    participates, row);
      b = dpdn_[i] / p_.rho - row.constant();
    } else {
      mat<D> A = mat<D>::Identity();
      const mat<D> G = detail::component_gradients(op_, x, nl_, i, comp_, participates);
      for (int a = 0; a < D; ++a) A.row(a) += dt * G.row(a);
      row.reset(i);
      if (p_.pressure == pressure_operator::nested_gradient) {
        build_nested_row(i, ppe::det_f::cofactor<D>(A) / p_.rho, row);
      } else {
        const auto sel = ppe::det_f::selector<op_type, D>(A, p_.rho);
        if (neumann_points()) pressure_op().build_row(x, nl_, i, sel, participates, row);
        else op_.build_row(x, nl_, i, sel, participates, row, op::neumann_rows{&dpdn_});
      }
      // Copies have no volume correction of their own; nor do particles near a free surface, a wall or a
      // pressure boundary (c′ = 1, above).
      const double c_i = i < n && !fixed_volume_[static_cast<std::size_t>(i)] ? c_pack_[i] : 1.0;
      b = source_.template rhs<D>(A, c_i, dt) - row.constant();
    }
    row.merge();
    return b;
  }

  /// One build and solve of the PPE (stage 8); the unknowns exclude the active set.
  void solve_pressure_once(double dt) {
    const index_t n = s_.n_real(), nt = s_.size();
    const points<D>& x = s_.x();
    auto& pres = s_.template get<field::pressure>();
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    // Neumann data at copies: ∂p/∂n = ρ (u′_w − u_wall)·n / Δt (eq. 83; n toward the fluid). Set before the
    // unknowns: with Neumann-point rows the correction's gradient (stage 9) reads it at the copies even when
    // there is nothing to solve (every fluid particle a surface one; until 2026-11-29 it was set after the
    // m = 0 return, and such a step read an empty or the previous step's vector).
    dpdn_.setZero(nt);
    for (index_t k = n; k < nc_; ++k)
      dpdn_[k] = p_.rho * (ut_.col(k) - s_.u().col(k)).dot(normal_.col(k)) / dt;
    // The rows are built twice when a fluid row's operator has a non-negative diagonal (wrong_sign_rows
    // below): its particle becomes a Dirichlet p = 0 row and the unknowns, the c′ = 1 band and the right-hand
    // sides are made again (the rows' coefficients do not depend on which particles are unknowns, so one
    // repeat suffices).
    index_t m = 0;
    for (int pass = 0; pass < 2; ++pass) {
      unk_.assign(static_cast<std::size_t>(nt), npos);
      rows_.clear();
      for (index_t i = 0; i < nt; ++i) {
        // Unknowns: non-surface participating particles; with the parent-gradient wall row also the copies of
        // surface particles (their row makes the parent's normal velocity vanish; p = 0 there put a wrong
        // Dirichlet value on a copy below its parent on an inclined wall: 1.6 % of ρ g H at the first step),
        // except the copies the own-loop guard made p = 0 rows and those in the active set
        // (active_set_copies); with surface_copies_zero none (p = 0, the paper's reading), with
        // surface_copies_zero_below not those of parents with c below it.
        if (i >= nc_) continue;  // pressure-boundary particles: Dirichlet p = P_b (Tanaka §4.5.2)
        const bool copy_unknown =
            i >= n && p_.copy_row == copy_row_kind::parent_gradient && !p_.surface_copies_zero &&
            !(c_pack_[parent(i)] < p_.surface_copies_zero_below) &&
            !(p_.own_loop.enabled && own_loop_zero_copies_[static_cast<std::size_t>(parent(i))]) &&
            !active_set_[static_cast<std::size_t>(i)];  // active_set_copies
        if (i >= n && neumann_points()) continue;  // copies are data, not unknowns
        const bool known = surface_[static_cast<std::size_t>(i)] || active_set_[static_cast<std::size_t>(i)];
        if (participates(i) && (!known || copy_unknown)) {
          unk_[static_cast<std::size_t>(i)] = static_cast<index_t>(rows_.size());
          rows_.push_back(i);
        }
      }
      for (index_t i = 0; i < nt; ++i)
        if (unk_[static_cast<std::size_t>(i)] == npos) pres[i] = 0.0;
      if constexpr (has_pressure_boundary) pres.segment(nc_, nt - nc_) = pb_->pressures();
      m = static_cast<index_t>(rows_.size());
      one_sided_.assign(static_cast<std::size_t>(n), 0);  // stays 0 when there is nothing to solve
      if (m == 0) return;

      // Near the free surface the packing ratio measures the void above, not a compression: the row below
      // the surface of a lattice at rest has c = 0.90 < c_min, so eq. 62 compressed it every step (measured:
      // the 2D tank at rest then failed within 343 steps). c′ = 1 for particles with a surface particle
      // closer than the largest packing-ratio radius R_i − L_i/2 (eq. 39); a deviation, docs/lsmps_scheme.md.
      // The same next to a pressure boundary (a deviation, docs/channel.md): the boundary particles sit on
      // the face with nothing beyond it, and an outflow column approaching them raised c above c_max, so
      // eq. 62 pushed it out through the face (measured: p −11 Pa instead of +0.02 Pa beside the outlet at
      // t = 0.02 s). The same next to a wall (a deviation, docs/lsmps_scheme.md): the copies on the wall bias
      // c (1.08–1.20 within 2 L of a wall at rest in 2D, 1.09–1.32 in 3D), so eq. 62 expanded the 3D box at
      // rest (3e-2 √(gH) within 10 steps) and, in Tanaka's dam break, held the rows above the floor at −6 to
      // −14 kPa. The same sweep flags the one-sided band of the velocity filter (stage 9b): a surface
      // particle, or one with a copy, a pressure-boundary or a surface particle among its neighbours, or
      // (multi-resolution) a neighbour whose diameter differs by more than boundary_filter.size_ratio: a
      // mixed-size stencil is as asymmetric as a one-sided one (measured, docs/resolution.md: a refined disc
      // in a tank at rest, 2:1, grew to 0.5 √(gH) by 4 √(H/g) without it and stayed at 1.3e-4 with it).
      fixed_volume_.assign(static_cast<std::size_t>(nt), 0);
      const double rs = p_.boundary_filter.size_ratio;
      const bool mixed_sizes = n > 0 && L_.head(n).maxCoeff() > rs * L_.head(n).minCoeff();
      if (has_surface || has_pressure_boundary || has_walls || mixed_sizes) {
        for_each_particle(exec::par{}, n, [&](index_t i) {
          const double reach = p_.op.re_ratio * L_[i] - 0.5 * L_[i];
          bool near = false, band = surface_[static_cast<std::size_t>(i)] != 0;
          nl_.for_each_neighbour(x, i, support(), [&](index_t j, const vec<D>&, double r2) {
            // a copy (of a participating parent), a pressure-boundary particle, a surface particle
            const bool open = (j >= n && participates(j)) || (j < n && surface_[static_cast<std::size_t>(j)]);
            if (open && r2 < reach * reach) near = true;
            band = band || j >= n || surface_[static_cast<std::size_t>(j)] != 0 ||
                   (mixed_sizes && participates(j) && (L_[j] > rs * L_[i] || L_[i] > rs * L_[j]));
          });
          fixed_volume_[static_cast<std::size_t>(i)] = near;
          one_sided_[static_cast<std::size_t>(i)] = band;
        });
      }
      // ∇u′ at every row: copies carry the extrapolated u′ (default) or the wall velocity.
      for (int a = 0; a < D; ++a) {
        comp_[a] = ut_.row(a).transpose();
        if (p_.copy_velocity == copy_velocity_in_source::wall)
          for (index_t k = n; k < nc_; ++k) comp_[a][k] = s_.u()(a, k);
      }

      // Each row as (particle column, coefficient) entries, sorted by particle, plus its right-hand side.
      // Each row in a reused row_entries (capacity kept across steps), merged and sorted by particle.
      if (static_cast<index_t>(row_buf_.size()) < m) row_buf_.resize(static_cast<std::size_t>(m));
      b_.resize(m);
      dirichlet_.assign(static_cast<std::size_t>(m), 0);
      for_each_particle(exec::par{}, m, [&](index_t r) {
        const index_t i = rows_[static_cast<std::size_t>(r)];
        op::row_entries& row = row_buf_[static_cast<std::size_t>(r)];
        b_[r] = build_ppe_row(i, dt, row);
        bool dir = false;
        for_each_entry(row, i, [&](index_t j, double a) {
          if (unk_[static_cast<std::size_t>(j)] == npos && a != 0.0) {
            dir = true;           // a known neighbour: surface (p = 0) or pressure boundary (p = P_b)
            b_[r] -= a * pres[j];  // its value moves to the right-hand side
          }
        });
        dirichlet_[static_cast<std::size_t>(r)] = dir;
      });
      if (pass > 0 || p_.wrong_sign_rows != wrong_sign_row::dirichlet || !demote_wrong_sign_rows(m)) break;
    }
    if (p_.active_set_solves > 0 && p_.active_set_reuse_rows) b_kept_ = b_;  // before the pinning changes b_
    assemble_and_solve();
  }

  /// For a repeat of the active set (active_set_reuse_rows): drops the rows of the particles that joined the
  /// set (p = 0 from now on) from the last build's rows, renumbers the unknowns and restores the right-hand
  /// sides as built (before pinning). A joined particle is known with p = 0, so it moves nothing to the
  /// right-hand side of a remaining row; only the rows' Dirichlet flags change. Returns the rows left.
  index_t drop_active_set_rows() {
    auto& pres = s_.template get<field::pressure>();
    const index_t m = static_cast<index_t>(rows_.size());
    index_t w = 0;
    for (index_t r = 0; r < m; ++r) {
      const index_t i = rows_[static_cast<std::size_t>(r)];
      if (active_set_[static_cast<std::size_t>(i)]) {
        unk_[static_cast<std::size_t>(i)] = npos;
        pres[i] = 0.0;
        continue;
      }
      if (w != r) {
        rows_[static_cast<std::size_t>(w)] = i;
        std::swap(row_buf_[static_cast<std::size_t>(w)], row_buf_[static_cast<std::size_t>(r)]);
        b_kept_[w] = b_kept_[r];
      }
      unk_[static_cast<std::size_t>(i)] = w++;
    }
    rows_.resize(static_cast<std::size_t>(w));
    b_kept_.conservativeResize(w);
    b_ = b_kept_;
    dirichlet_.assign(static_cast<std::size_t>(w), 0);
    for_each_particle(exec::par{}, w, [&](index_t r) {
      bool dir = false;
      for_each_entry(row_buf_[static_cast<std::size_t>(r)], rows_[static_cast<std::size_t>(r)],
                     [&](index_t j, double a) {
                       if (unk_[static_cast<std::size_t>(j)] == npos && a != 0.0) dir = true;
                     });
      dirichlet_[static_cast<std::size_t>(r)] = dir;
    });
    return w;
  }

  /// The PPE of the built rows (rows_, row_buf_, b_, dirichlet_): CSR, floating parts pinned, solved; the
  /// pressures written back (copies of the Neumann-point rows from their parents).
  void assemble_and_solve() {
    const index_t n = s_.n_real();
    const points<D>& x = s_.x();
    auto& pres = s_.template get<field::pressure>();
    const index_t m = static_cast<index_t>(rows_.size());
    // CSR: unknown columns kept (particle order = unknown order), known (surface, p = 0) dropped.
    std::vector<std::ptrdiff_t> outer(static_cast<std::size_t>(m + 1), 0);
    for (index_t r = 0; r < m; ++r) {
      std::ptrdiff_t cnt = 0;
      for_each_entry(row_buf_[static_cast<std::size_t>(r)], rows_[static_cast<std::size_t>(r)],
                     [&](index_t j, double) {
                       if (unk_[static_cast<std::size_t>(j)] != npos) ++cnt;
                     });
      outer[static_cast<std::size_t>(r + 1)] = outer[static_cast<std::size_t>(r)] + cnt;
    }
    A_.resize(m, m);
    A_.resizeNonZeros(outer.back());
    std::copy(outer.begin(), outer.end(), A_.outerIndexPtr());
    std::ptrdiff_t* inner = A_.innerIndexPtr();
    double* val = A_.valuePtr();
    for_each_particle(exec::par{}, m, [&](index_t r) {
      std::ptrdiff_t at = outer[static_cast<std::size_t>(r)];
      for_each_entry(row_buf_[static_cast<std::size_t>(r)], rows_[static_cast<std::size_t>(r)],
                     [&](index_t j, double a) {
                       const index_t cj = unk_[static_cast<std::size_t>(j)];
                       if (cj == npos) return;
                       inner[at] = cj;
                       val[at++] = a;
                     });
    });
    const bool same_unknowns = same_unknowns_as_before();
    pin_floating_parts(same_unknowns);

    Eigen::VectorXd sol(m);
    for (index_t r = 0; r < m; ++r) sol[r] = pres[rows_[static_cast<std::size_t>(r)]];
    const long factorised = incomplete_factorisations();
    last_solve_ = ppe::solve_checked(solver_, A_, b_, sol, p_.solver, c_.steps, t_,
                                     [&](index_t r) { return describe(rows_[static_cast<std::size_t>(r)]); },
                                     same_unknowns, to_previous_.empty() ? nullptr : &to_previous_);
    if (c_.ppe_solves > solves_before_step_) {  // not the step's first solve: a repeat
      ++c_.ppe_repeat_solves;
      c_.ppe_repeat_iterations += last_solve_.iterations;
    }
    ++c_.ppe_solves;
    c_.ppe_factorisations += incomplete_factorisations() - factorised;
    c_.ppe_lagged_retries += last_solve_.lagged_retry;
    c_.ppe_fallbacks += last_solve_.fallback;
    c_.ppe_breakdown_restarts += last_solve_.breakdown_restart;
    c_.ppe_cold_restarts += last_solve_.cold_restart;
    c_.ppe_iterations += last_solve_.iterations;
    c_.ppe_iterations_max = std::max(c_.ppe_iterations_max, last_solve_.iterations);
    for (index_t r = 0; r < m; ++r) {
      double v = sol[r];
      if (p_.negative == negative_pressure::clamp_to_zero && v < 0.0) {
        v = 0.0;
        ++c_.negative_clamped;
      }
      pres[rows_[static_cast<std::size_t>(r)]] = v;
    }
    if (neumann_points())  // copies (output, probes): the two-point form of eq. 83
      for (index_t k = n; k < nc_; ++k) {
        const index_t ip = parent(k);
        pres[k] = pres[ip] - (x.col(ip) - x.col(k)).dot(normal_.col(k)) * dpdn_[k];
      }
  }

  /// ILUT or ILU(0) factorisations the pressure solver has made so far (ppe::with_fallback forwards its
  /// primary's); 0 for solvers without incomplete factors.
  long incomplete_factorisations() const {
    if constexpr (requires { solver_.factorisations(); }) return solver_.factorisations();
    else return 0;
  }

  /// True when this step's unknowns are the previous step's, in the same order: fluid rows by particle id,
  /// copy rows by (parent id, polygon set, element). Lets a solver keep a factorisation
  /// (solver_params::ilut_reuse); any change of the set or the order refactorises.
  bool same_unknowns_as_before() {
    if (p_.solver.ilut_reuse <= 1) return false;
    const index_t n = s_.n_real();
    key_.clear();
    key_.reserve(rows_.size());
    for (const index_t i : rows_) {
      if (i < n) {
        key_.push_back({static_cast<std::int64_t>(id_of(i)), -1, -1});
        continue;
      }
      const auto& cp = copies_[static_cast<std::size_t>(i - n)];
      key_.push_back({static_cast<std::int64_t>(id_of(parent(i))), static_cast<std::int64_t>(cp.set),
                      static_cast<std::int64_t>(cp.element)});
    }
    const bool same = key_ == prev_key_;
    to_previous_.clear();
    if (!same &&
        p_.solver.ilut_reuse_across_changes) {  // row of each unknown in the previous system, by identity
      std::vector<index_t> order(prev_key_.size());
      for (std::size_t q = 0; q < order.size(); ++q) order[q] = static_cast<index_t>(q);
      std::sort(order.begin(), order.end(), [&](index_t a, index_t b) {
        return prev_key_[static_cast<std::size_t>(a)] < prev_key_[static_cast<std::size_t>(b)];
      });
      to_previous_.assign(key_.size(), -1);
      for (std::size_t r = 0; r < key_.size(); ++r) {
        const auto it = std::lower_bound(order.begin(), order.end(), key_[r], [&](index_t q, const auto& k) {
          return prev_key_[static_cast<std::size_t>(q)] < k;
        });
        if (it != order.end() && prev_key_[static_cast<std::size_t>(*it)] == key_[r]) to_previous_[r] = *it;
      }
    }
    std::swap(key_, prev_key_);
    return same;
  }

  /// Fluid rows (not copies, not boundary particles) of the m built rows whose diagonal is ≥ 0 (or not a
  /// number): their particles are flagged free surface (p = 0), as are their copies, as the surface test
  /// would have done. Returns true when any was found (the rows are then built again).
  bool demote_wrong_sign_rows(index_t m) {
    const index_t n = s_.n_real();
    long found = 0;
    for (index_t r = 0; r < m; ++r) {
      const index_t i = rows_[static_cast<std::size_t>(r)];
      if (i >= n || row_buf_[static_cast<std::size_t>(r)].diagonal() < 0.0) continue;
      surface_[static_cast<std::size_t>(i)] = 1;
      s_.flags()[static_cast<std::size_t>(i)] |= flag::surface;
      ++found;
    }
    if (found == 0) return false;
    for (index_t k = n; k < nc_; ++k)
      if (surface_[static_cast<std::size_t>(parent(k))]) {
        surface_[static_cast<std::size_t>(k)] = 1;
        s_.flags()[static_cast<std::size_t>(k)] |= flag::surface;
      }
    c_.wrong_sign_rows += found;
    return true;
  }

  /// Row i of (1/ρ) Σ_ab cof(A)_ab ∂_b⟨∇_a p⟩ with S = cof(A)/ρ: the LSMPS-A gradient (eq. 41) of the LSMPS-A
  /// gradient, i.e. the linearisation of det(A − (Δt²/ρ) ∇⟨∇p⟩) (eq. 58, Jacobi's formula) with the velocity
  /// correction's own operator, so that the corrected velocity satisfies the discrete condition exactly.
  /// ⟨∂_b f⟩_i = Σ_j c_ij,b (f_j − f_i), so the row is Σ_j q_j·[(Gp)_j − (Gp)_i] with q_j = Sᵀ-contracted
  /// c_ij; a copy j carries its parent's gradient (its velocity is the parent's in ∇u′,
  /// copy_velocity = extrapolated). Two neighbour generations wide (≈ 80 entries per 2D row against ≈ 27).
  void build_nested_row(index_t i, const mat<D>& S, op::row_entries& row) const {
    const index_t n = s_.n_real();
    const points<D>& x = s_.x();
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    // q · (G p)_j: the gradient row of j (a copy: of its parent) weighted by q.
    const auto add_gradient_row = [&](index_t j, const vec<D>& q) {
      const index_t jj = j >= n ? parent(j) : j;
      op_.for_each_gradient_weight(x, nl_, jj, participates, [&](index_t k, const vec<D>& c) {
        const double a = q.dot(c);
        row.add(k, a);
        row.add(jj, -a);
      });
    };
    vec<D> sum_q = vec<D>::Zero();
    op_.for_each_gradient_weight(x, nl_, i, participates, [&](index_t j, const vec<D>& c) {
      const vec<D> q = S * c;  // q_a = Σ_b S_ab c_ij,b: the weight of (G_a p)_j in Σ_ab S_ab ∂_b (G_a p)
      sum_q += q;
      add_gradient_row(j, q);
    });
    add_gradient_row(i, -sum_q);
  }

  /// Calls f(j, a) over a merged row in increasing particle order: its columns with the coefficient of the
  /// row particle (row.row(), the diagonal) in place, and a zero at `self` when the row has no entry there
  /// (a copy's parent-gradient row is built at its parent: the copy's own column is then a neighbour
  /// entry, and the matrix must hold every diagonal).
  template <class F>
  static void for_each_entry(const op::row_entries& row, index_t self, F&& f) {
    const index_t d = row.row();
    bool diag_done = false, self_done = false;
    const auto emit = [&](index_t j, double a) {
      self_done |= j == self;
      f(j, a);
    };
    for (const auto& [j, a] : row.columns()) {
      if (!diag_done && d < j) {
        if (!self_done && self < d) emit(self, 0.0);
        emit(d, row.diagonal());
        diag_done = true;
      }
      if (!self_done && self < j && self != d) emit(self, 0.0);
      emit(j, a);
    }
    if (!diag_done) {
      if (!self_done && self < d) emit(self, 0.0);
      emit(d, row.diagonal());
    }
    if (!self_done) emit(self, 0.0);
  }

  /// Parts of the unknowns' graph with no Dirichlet neighbour (periodic boxes) are singular: p is defined up
  /// to a constant and the system is solvable only for a right-hand side orthogonal to the left null vector
  /// y (Aᵀ y = 0). The LSMPS matrix is not symmetric, so y is not constant, and removing the mean source
  /// is not enough (measured on the Taylor–Green vortex: the dropped row's residual exceeded |b|_max
  /// within 5 steps and the run blew up near the pinned particle at t ≈ 0.2 s). So, per floating part:
  ///  1. y from Aᵀ with the pinned row replaced by y_pin = 1 (one extra solve, floating parts only);
  ///  2. b ← b − (yᵀb / yᵀV) V (a uniform source correction, V the particle volumes: the discrete form of
  ///     removing the mean source);
  ///  3. the pinned row replaced by p_pin = 0 (lowest-id particle). The solution then satisfies every row.
  /// Counted in pinned_components.
  /// same_unknowns: this step's unknowns are the previous step's (same_unknowns_as_before()).
  void pin_floating_parts(bool same_unknowns) {
    const auto floating = ppe::find_floating_parts(
        A_, dirichlet_, false, [this](index_t r) { return id_of(rows_[static_cast<std::size_t>(r)]); });
    // The adjoint solver's factors are the previous step's only if that step solved with it as well.
    const bool adjoint_same = same_unknowns && floating_before_;
    floating_before_ = !floating.empty();
    if (floating.empty()) return;
    const index_t m = A_.rows();
    c_.pinned_components += static_cast<long>(floating.size());
    // 1. Left null vectors: B = Aᵀ, rows outside floating parts → y = 0, pinned rows → y = 1.
    ppe::matrix B = A_.transpose();
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(m), y = Eigen::VectorXd::Zero(m);
    std::vector<std::uint8_t> keep(static_cast<std::size_t>(m), 0);
    for (const ppe::floating_part& part : floating)
      for (index_t r : part.members) keep[static_cast<std::size_t>(r)] = 1;
    for (const ppe::floating_part& part : floating) {
      keep[static_cast<std::size_t>(part.pin)] = 0;
      rhs[part.pin] = 1.0;
    }
    for (index_t r = 0; r < m; ++r) {
      if (keep[static_cast<std::size_t>(r)]) continue;
      for (ppe::matrix::InnerIterator it(B, r); it; ++it) it.valueRef() = it.index() == r ? 1.0 : 0.0;
    }
    for (index_t r = 0; r < m; ++r) y[r] = keep[static_cast<std::size_t>(r)] || rhs[r] != 0.0 ? 1.0 : 0.0;
    const ppe::solve_report adjoint = ppe::solve_checked(
        adjoint_solver_, B, rhs, y, p_.solver, c_.steps, t_,
        [&](index_t r) {
          return "the left-null-vector row of " + describe(rows_[static_cast<std::size_t>(r)]);
        },
        adjoint_same);
    c_.ppe_lagged_retries += adjoint.lagged_retry;
    c_.ppe_fallbacks += adjoint.fallback;
    c_.ppe_breakdown_restarts += adjoint.breakdown_restart;
    c_.ppe_cold_restarts += adjoint.cold_restart;
    // 2.–3. Compatible right-hand side, then the pin.
    const auto& V = s_.template get<field::volume>();
    for (const ppe::floating_part& part : floating) {
      const index_t pin = part.pin;
      double yb = 0.0, yv = 0.0;
      for (index_t r : part.members) {
        yb += y[r] * b_[r];
        yv += y[r] * V[rows_[static_cast<std::size_t>(r)]];
      }
      if (yv != 0.0)
        for (index_t r : part.members) b_[r] -= yb / yv * V[rows_[static_cast<std::size_t>(r)]];
      for (ppe::matrix::InnerIterator it(A_, pin); it; ++it) it.valueRef() = it.index() == pin ? 1.0 : 0.0;
      b_[pin] = 0.0;
    }
  }

  /// 12. Resolution stage (docs/resolution.md): split/merge on this step's list, diameters, normals and flags
  /// (the ghosts are dropped by its one resize); diameters refreshed for diameter().
  /// frozen (optional, one entry per real particle): particles that take part in no event this step (those
  /// leaving through a pressure boundary), passed to split/merge with the isolated bit set.
  void resolve_sizes(const std::vector<std::uint8_t>* frozen = nullptr) {
    const auto participates = [this](index_t j) { return !excluded_[static_cast<std::size_t>(j)]; };
    const std::vector<flag::type>* flags = nullptr;
    if (frozen) {
      frozen_flags_ = s_.flags();
      for (std::size_t i = 0; i < frozen->size(); ++i)
        if ((*frozen)[i]) frozen_flags_[i] |= flag::isolated;
      flags = &frozen_flags_;
    }
    last_resolution_ =
        detail::run_resolution_stage<resolution_type>(s_, nl_, L_, normal_, walls_, xold_, op_, participates,
                                                      p_.resolution, ledger_, flags, p_.walls.alpha_w);
    c_.splits += static_cast<long>(last_resolution_.splits);
    c_.merges += static_cast<long>(last_resolution_.merges);
    sizes_from_volumes();
  }

  /// The constructor's and restore()'s checks of the particles (no ghosts, fluid only, volumes finite > 0).
  static void check_particles(const state_type& s, const char* what) {
    if (s.n_ghost() != 0) fail("lsmps_semi_implicit: ", what, " has ghosts");
    s.validate();
    const auto& V = s.template get<field::volume>();
    for (index_t i = 0; i < s.n_real(); ++i) {
      if (!(std::isfinite(V[i]) && V[i] > 0.0))
        fail("lsmps_semi_implicit: ", what, ": particle ", i, " has volume ", V[i],
             ": must be finite and > 0 (V = L^D)");
      const kind k = s.kinds()[static_cast<std::size_t>(i)];
      if (k != kind::fluid)
        fail("lsmps_semi_implicit: ", what, ": particle ", i, " is ", name(k),
             ": this scheme takes fluid particles only (walls are polygons)");
    }
  }

  void check_finite() const {
    for (index_t i = 0; i < s_.n_real(); ++i)
      if (!s_.x().col(i).allFinite() || !s_.u().col(i).allFinite() ||
          !std::isfinite(s_.template get<field::pressure>()[i]))
        fail("non-finite position, velocity or pressure at step ", c_.steps, ", t = ", t_, " s: particle ", i,
             " (id ", id_of(i), ")");
  }

  params_type p_;
  op_type op_, op_p_;  ///< op_p_: the pressure operator with Neumann points (copy_row = neumann_points)
  /// Offset of particle i's first wall copy after n (make_copies); without walls there are none.
  index_t first_copy(index_t i) const {
    if constexpr (has_walls) return first_copy_[static_cast<std::size_t>(i)];
    else {
      (void)i;
      return 0;
    }
  }
  /// Copies are Neumann points of the pressure fits (copy_row = neumann_points, a scene with walls).
  bool neumann_points() const { return has_walls && p_.copy_row == copy_row_kind::neumann_points; }
  const op_type& pressure_op() const { return neumann_points() ? op_p_ : op_; }
  source_type source_;
  time_step_controller dt_ctrl_;
  solver_type solver_, adjoint_solver_;
  state_type s_;
  const geometry_type* walls_ = nullptr;
  const pressure_boundary_type* pb_ = nullptr;
  index_t nc_ = 0;  ///< end of the copies in the ghost range (pressure-boundary particles follow)
  /// copies of particle i: [n + first_copy_[i], n + first_copy_[i + 1]) (make_copies)
  std::vector<index_t> first_copy_;
  boundary::pressure_flux last_flux_{};
  search::neighbour_list<D> nl_;
  Eigen::VectorXd L_, c_pack_, dpdn_;
  std::array<Eigen::VectorXd, D> comp_;
  points<D> ut_, xold_, normal_, wall_normal_, wall_normal2_, dx_, filter_du_, u_new_;
  std::vector<std::uint8_t> excluded_, surface_, copy_mark_, dirichlet_, normal_degenerate_, fixed_volume_,
      one_sided_;
  points<D> collision_du_;                // Δu of the collision stage (9c)
  // held at p = 0 by the active set this step (stage 8; copies too: active_set_copies)
  std::vector<std::uint8_t> active_set_;
  // active_set_warm_start: the set the last pressure solve ended with (ids)
  std::vector<particle_id> held_ids_;
  std::vector<index_t> release_candidates_,
      release_;  // active_set_release: the set's fluid members, those released
  std::vector<op::row_entries> release_buf_;            // their rows (capacity kept across steps)
  std::vector<std::uint8_t> release_flag_;
  // the own-loop guard's marks this step: p = 0 rows, and surface parents whose copies lost the two-point
  // term
  std::vector<std::uint8_t> own_loop_dirichlet_, own_loop_one_point_;
  std::vector<std::uint8_t> own_loop_zero_copies_;  // surface parents whose copies the guard made p = 0 rows
  Eigen::VectorXd own_loop_gain_;  // ρ(B_i) of the guard's last check (NaN: not checked)
  std::vector<wall::imaginary_copy<D>> copies_;
  std::vector<index_t> unk_, rows_;
  std::vector<op::row_entries> row_buf_;  ///< PPE rows of the step (reused: capacity kept)
  ppe::matrix A_;
  Eigen::VectorXd b_, b_kept_;  // b_kept_: the right-hand sides as built, for the active set's repeats
  ppe::solve_report last_solve_{};
  long solves_before_step_ = 0;  // counters().ppe_solves when this step's pressure stage began
  std::vector<std::array<std::int64_t, 3>> key_, prev_key_;  // unknowns' identities (same_unknowns_as_before)
  // row of each unknown in the previous system (ilut_reuse_across_changes)
  std::vector<index_t> to_previous_;
  // the previous step had floating parts (its adjoint solver holds their factors)
  bool floating_before_ = false;
  lsmps_counters c_{};
  resolution::conservation_ledger<D> ledger_{};
  std::vector<flag::type> frozen_flags_;  // the state's flags with frozen particles marked isolated
  resolution::split_merge_report<D> last_resolution_{};
  double t_ = 0.0, dt_ = 0.0;
};

}  // namespace mpskit::scheme
