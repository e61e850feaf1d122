#pragma once
/// \file scheme/semi_implicit.hpp
/// \brief Semi-implicit (projection) MPS with wall + dummy particles: the classic scheme of Koshizuka &
/// Oka 1996 as written in Tanaka 2018 §3.2–3.4 (eqs. 13–25) and bmmr.md §2.9 (eqs. 19–28).
///
/// Stage order of one step (documented in docs/solver.md):
///  1. Δt from the controller (scheme/time_step.hpp); every `reorder_every` steps the state is put in
///     cell order through the one resize path.
///  2. Neighbour list built at x^k (largest radius × (1 + skin)); within the step it is rebuilt whenever
///     a particle has moved more than half the skin since the build, so it stays exact at x′ too.
///  3. Isolated fluid particles (no neighbour within re_small) are flagged, excluded from every operator,
///     and move ballistically under gravity.
///  4. Explicit prediction (eq. 13): u′ = u + Δt (ν ∇²u + g), Laplacian at re_large over fluid, wall
///     and dummy neighbours (walls at rest); temporary positions x′ = x + Δt u′ (eq. 14).
///  5. Collision model on (u′, x′) if the scene names one (bmmr.md eqs. 23–24).
///  6. n′ at x′ (eq. 8, re_small, all neighbours); free-surface detection at x′ on fluid and wall
///     particles (surface wall particles are dry walls: p = 0).
///  7. PPE ∇²p − (ρ α_c/Δt²) p = b (the source policy gives b; α_c the restricted compressibility,
///     eq. 24): unknowns are non-surface, non-isolated fluid and wall particles; surface neighbours are
///     Dirichlet p = 0; dummy neighbours are read relative to the row, P_j = P_i + ρ g·x_ij (bmmr eq. 17),
///     which moves to the right-hand side. Parts of the system with no Dirichlet row are pinned at their
///     lowest-id particle (p = 0) and counted. The matrix M = −L + (ρ α_c/Δt²) I is symmetric.
///  8. Negative pressures clamped to 0 or kept (params); pressure gradient at x′ with the minimum
///     neighbour pressure (eq. 22) or plain (eq. 21); u = u′ − Δt/ρ ∇p (eq. 15);
///     x = x′ + Δt (u − u′) (eq. 16 / bmmr eq. 28).
///  8b. Velocity filter in the one-sided band if params.boundary_filter.strength > 0 (a deviation, off by
///     default; regularize/boundary_filter.hpp).
///  9. Shifting if the scene names one; NaN/inf check naming step, time and particle.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <span>
#include <type_traits>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/ppe/concepts.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"
#include "mpskit/ppe/floating_parts.hpp"
#include "mpskit/ppe/solve.hpp"
#include "mpskit/regularize/boundary_filter.hpp"
#include "mpskit/scheme/time_step.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::scheme {

/// What to do with negative pressures after the solve (Tanaka 2018 §3.4: common practice clamps).
enum class negative_pressure { clamp_to_zero, keep };
/// Which pressure gradient corrects the velocity.
/// `corrected_minimum` is bmmr.md eq. 29 (Wang et al. 2017): the eq. 22 stencil with the correction
/// matrix C_i⁻¹ in place of d/n0, exact for linear fields where p̂_i = p_i (at a free surface, where the
/// plain d/n0 gradient of a half stencil is about half the hydrostatic one); `corrected` uses p̂_i = p_i.
enum class pressure_gradient {
  minimum /* eq. 22 */,
  plain /* eq. 21 */,
  corrected_minimum /* bmmr eq. 29 */,
  corrected
};

/// No regularisation (collision or shifting) stage.
struct no_regularization final {};

/// Runtime numbers of the semi-implicit scheme, with the papers' defaults.
template <int D>
struct semi_implicit_params {
  double rho = 1000.0;    ///< density (kg/m³)
  double nu = 1e-6;       ///< kinematic viscosity (m²/s)
  vec<D> g = gravity();   ///< body force per unit mass (m/s²)
  double l0 = 0.0;        ///< particle spacing (m)
  double re_small = 2.1;  ///< gradient / divergence / number density radius (in l0)
  double re_large = 3.1;  ///< Laplacian radius (in l0)
  /// α_c = 1/(ρ s²) (m s²/kg), Tanaka eq. 24 / BMMR eq. 25 (BMMR dam break: 1e-8)
  double compressibility = 1e-8;
  negative_pressure negative = negative_pressure::clamp_to_zero;  ///< after the solve
  pressure_gradient gradient = pressure_gradient::minimum;        ///< in the correction
  time_step_params time{};                                        ///< Δt controller
  ppe::solver_params solver{};                                    ///< linear solver stopping rule
  double skin = 0.2;       ///< list skin (fraction of the build radius)
  int reorder_every = 25;  ///< steps between cell reorders (0: never)
  /// ε of the velocity filter in the one-sided band (a deviation, regularize/boundary_filter.hpp): fluid
  /// particles with a free-surface fluid particle or a wall particle within re_large get
  /// u_i += ε (û_i − u_i), û_i the LSMPS-B order-2 fit over their neighbours j ≠ i (fluid, wall, dummy;
  /// walls at rest), after the correction. 0 (default) switches it off. With the mixed source and the
  /// corrected gradient, ε = 0.1 keeps the hydrostatic tank at rest (docs/solver.md, issue #4).
  regularize::boundary_filter_params boundary_filter{0.0};

  static vec<D> gravity() {
    vec<D> v = vec<D>::Zero();
    v[D - 1] = -9.81;
    return v;
  }
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("semi_implicit_params");
    v.positive("rho", rho).non_negative("nu", nu).positive("l0", l0);
    for (int a = 0; a < D; ++a) v.finite("g", g[a]);
    v.positive("re_small", re_small).positive("re_large", re_large);
    v.require(re_large >= re_small, "re_large", "must be >= re_small");
    v.non_negative("compressibility", compressibility).in_range("skin", skin, 0.0, 1.0);
    v.in_range("reorder_every", reorder_every, 0, 1e9);
    v.throw_if_any();
    time.validate();
    solver.validate();
    boundary_filter.validate();
  }
};

/// The numbers of the quiet classic configuration (docs/solver.md "Quiet configuration", issue #4): p with
/// the corrected pressure gradient (bmmr.md eq. 29, p̂ = p_i) and the one-sided-band velocity filter at
/// ε = 0.1. Use it with a scene whose source is ppe::mixed (Tanaka eq. 25, α_p = 0.01):
/// mpskit::quiet_defaults<D>. Measured: a tank at rest keeps RMS ≤ 5e-4, max ≤ 3e-3 √(gH) (defaults: 3–5e-2,
/// 0.1).
template <int D>
semi_implicit_params<D> quiet_params(semi_implicit_params<D> p = {}) {
  p.gradient = pressure_gradient::corrected;
  p.boundary_filter.strength = 0.1;
  return p;
}

/// Counters of a run (reported in summaries, kept in checkpoints).
struct semi_implicit_counters {
  long steps = 0;               ///< steps taken
  long ppe_iterations = 0;      ///< solver iterations, summed
  long ppe_iterations_max = 0;  ///< largest per step
  long pinned_components = 0;   ///< PPE parts with no Dirichlet row, pinned (summed over steps)
  long isolated = 0;            ///< isolated particle-steps (excluded from operators)
  long list_builds = 0;         ///< neighbour-list builds
  long reorders = 0;            ///< cell reorders
  long negative_clamped = 0;    ///< pressures clamped to zero (summed)
  /// solves made by the fallback solver after the primary failed (ppe::with_fallback)
  long ppe_fallbacks = 0;
  /// solves restarted from 0 after a Krylov breakdown (solver_params::breakdown_restart)
  long ppe_breakdown_restarts = 0;
  /// warm-started solves repeated from 0 after not converging (solver_params::cold_restart)
  long ppe_cold_restarts = 0;
};

/// semi_implicit_counters in checkpoint order (io/simulation_checkpoint.hpp; a counter added later goes last,
/// and the loader reads older files' shorter lists): the one list that saving and loading walk.
inline constexpr std::array<long semi_implicit_counters::*, 11> semi_implicit_counter_fields{
    &semi_implicit_counters::steps,         &semi_implicit_counters::ppe_iterations,
    &semi_implicit_counters::ppe_iterations_max, &semi_implicit_counters::pinned_components,
    &semi_implicit_counters::isolated,      &semi_implicit_counters::list_builds,
    &semi_implicit_counters::reorders,      &semi_implicit_counters::negative_clamped,
    &semi_implicit_counters::ppe_fallbacks, &semi_implicit_counters::ppe_breakdown_restarts,
    &semi_implicit_counters::ppe_cold_restarts};
// A counter added to semi_implicit_counters without a place in the list above fails here.
static_assert(sizeof(semi_implicit_counters) == semi_implicit_counter_fields.size() * sizeof(long));

/// Particle state of the classic scheme: core fields + pressure + number density.
template <int D>
using semi_implicit_state = particle_state<D, field_list<field::pressure, field::number_density>>;

/// The semi-implicit MPS stepper for a Scene (see scene.hpp: dim, op, source, solver, surface,
/// collision, shifting).
template <class Scene>
class semi_implicit {
 public:
  static constexpr int D = Scene::dim;
  using op_type = typename Scene::op;
  using source_type = typename Scene::source;
  using solver_type = typename Scene::solver;
  using surface_type = typename Scene::surface;
  using collision_type = typename Scene::collision;
  using shifting_type = typename Scene::shifting;
  using state_type = semi_implicit_state<D>;
  using params_type = semi_implicit_params<D>;
  static_assert(ppe::SourceTerm<source_type>,
                "mpskit: Scene::source must model ppe::SourceTerm (ppe/concepts.hpp)");
  static_assert(ppe::LinearSolver<solver_type>,
                "mpskit: Scene::solver must model ppe::LinearSolver (ppe/concepts.hpp)");
  static_assert(op_type::dim == D, "mpskit: Scene::op has another dimension than the scene");

  /// Takes the numbers and the initial particles (fluid, wall, dummy kinds); the policies are built
  /// with their papers' defaults (a policy whose params have an `l0` member gets the scheme's l0).
  semi_implicit(const params_type& p, state_type initial)
      : semi_implicit(p, std::move(initial), make_policy<source_type>(p), make_policy<surface_type>(p),
                      make_policy<collision_type>(p), make_policy<shifting_type>(p)) {}

  /// Takes the numbers, the initial particles and every policy object.
  semi_implicit(const params_type& p, state_type initial, const source_type& source,
                const surface_type& surface, const collision_type& collision, const shifting_type& shifting)
      : p_(checked(p)),
        op_(op::mps_params{p.l0, p.re_small, p.re_large}),
        source_(source),
        surface_(surface),
        collision_(collision),
        shifting_(shifting),
        dt_ctrl_(p.time),
        solver_(p.solver),
        s_(std::move(initial)) {
    source_.validate();
    if (s_.n_ghost() != 0) fail("semi_implicit: the initial state holds ghosts");
    if (s_.n_real() == 0) fail("semi_implicit: the initial state has no particles");
    s_.validate();
    for (kind k : s_.kinds())
      if (k != kind::fluid && k != kind::wall && k != kind::dummy)
        fail("semi_implicit: particle kind '", name(k),
             "' is not handled by this scheme (fluid, wall, dummy)");
  }

  const state_type& state() const { return s_; }          ///< particles
  state_type& state() { return s_; }                      ///< particles (change only between steps)
  double time() const { return t_; }                      ///< simulated time (s)
  double dt() const { return dt_; }                       ///< Δt of the last step (s)
  const semi_implicit_counters& counters() const { return c_; }  ///< counters
  const params_type& params() const { return p_; }        ///< the numbers
  const op_type& op() const { return op_; }               ///< operators (n0, λ0, radii)
  const search::neighbour_list<D>& neighbours() const { return nl_; }  ///< list of the last step
  const ppe::solve_report& last_solve() const { return last_solve_; }  ///< last PPE solve
  /// Force of the fluid on each wall and dummy particle in the last step (N, or N/m in 2D; zero for
  /// fluid); sum any subset for the load on a wall (Newton's third law on the pressure-gradient pairs).
  const points<D>& wall_forces() const { return wall_force_; }
  /// Sum of wall_forces() over the particles i with select(i).
  template <class Select>
  vec<D> wall_force(const Select& select) const {
    vec<D> f = vec<D>::Zero();
    for (index_t i = 0; i < wall_force_.cols(); ++i)
      if (select(i)) f += wall_force_.col(i);
    return f;
  }
  const time_step_controller& time_step() const { return dt_ctrl_; }   ///< Δt controller
  /// Restores time, counters and the Δt controller (checkpoint restart).
  void restore(double t, const semi_implicit_counters& c, const time_step_state& ts) {
    t_ = t;
    c_ = c;
    dt_ctrl_.restore(ts);
  }

  /// Advances one step.
  void step() {
    const index_t n = s_.n_real();
    // 1. Δt from the fastest fluid particle.
    double umax = 0.0;
    index_t fastest = npos;
    for (index_t i = 0; i < n; ++i)
      if (kind_of(i) == kind::fluid) {
        const double u = s_.u().col(i).norm();
        if (u > umax) { umax = u; fastest = i; }
      }
    dt_ctrl_.check_speed(umax, c_.steps, fastest == npos ? npos : id_of(fastest));
    dt_ = dt_ctrl_.next(p_.l0, umax, p_.nu, c_.steps, fastest == npos ? npos : id_of(fastest));
    const double dt = dt_;
    if (p_.reorder_every > 0 && c_.steps % p_.reorder_every == 0) {
      build_list(s_.x());
      s_.reorder(nl_.cells().order());
      ++c_.reorders;
      build_list(s_.x());
    } else {
      // Built at every step start, so a step depends on the particle state only (bitwise restart at any
      // step; measured cost ~5 ns per stored pair, a few % of a step).
      build_list(s_.x());
    }
    const points<D>& x = s_.x();
    points<D>& u = s_.u();
    auto& flags = s_.flags();
    auto& pres = s_.template get<field::pressure>();
    auto& nd = s_.template get<field::number_density>();

    // 3. Isolated fluid particles.
    isolated_.assign(static_cast<std::size_t>(n), 0);
    const auto small = op_.small_support();
    for_each_particle(exec::par{}, n, [&](index_t i) {
      flags[static_cast<std::size_t>(i)] = 0;
      if (kind_of(i) != kind::fluid) return;
      bool any = false;
      nl_.for_each_neighbour(x, i, small, [&](index_t, const vec<D>&, double) { any = true; });
      if (!any) {
        isolated_[static_cast<std::size_t>(i)] = 1;
        flags[static_cast<std::size_t>(i)] |= flag::isolated;
      }
    });
    const auto active = [&](index_t j) { return !isolated_[static_cast<std::size_t>(j)]; };
    c_.isolated += std::count(isolated_.begin(), isolated_.end(), std::uint8_t{1});

    // 4. Explicit prediction.
    ut_.resize(D, n);
    xt_ = x;
    for_each_particle(exec::par{}, n, [&](index_t i) {
      if (kind_of(i) != kind::fluid) {
        ut_.col(i) = u.col(i);
        return;
      }
      vec<D> acc = p_.g;
      if (!isolated_[static_cast<std::size_t>(i)] && p_.nu > 0.0)
        acc += p_.nu * op_.laplacian(x, nl_, i, u, active);
      ut_.col(i) = u.col(i) + dt * acc;
      xt_.col(i) = x.col(i) + dt * ut_.col(i);
    });
    // 5. Collision (policy).
    if constexpr (!std::is_same_v<collision_type, no_regularization>) {
      collision_.apply(
          exec::par{}, xt_, ut_, nl_, active_filter(),
          [&](index_t j) { return kind_of(j) == kind::fluid && !isolated_[static_cast<std::size_t>(j)]; },
          dt);
    }
    ensure_list(xt_);

    // 6. n′ at x′ and surface detection.
    for_each_particle(exec::par{}, n, [&](index_t i) {
      nd[i] = (kind_of(i) == kind::dummy || isolated_[static_cast<std::size_t>(i)])
                  ? 0.0 : op_.number_density(xt_, nl_, i, active);
    });
    candidate_.assign(static_cast<std::size_t>(n), 0);
    for (index_t i = 0; i < n; ++i)
      candidate_[static_cast<std::size_t>(i)] =
          kind_of(i) != kind::dummy && !isolated_[static_cast<std::size_t>(i)];
    surface_.detect(exec::par{}, xt_, nl_, op_, active, std::span<const std::uint8_t>(candidate_), flags);

    // 7. PPE.
    solve_pressure(dt);

    // 8. Correction (p̂ first: the wall forces read it too).
    pmin_.assign(static_cast<std::size_t>(n), 0.0);
    for_each_particle(exec::par{}, n, [&](index_t i) {
      if (kind_of(i) == kind::fluid && !isolated_[static_cast<std::size_t>(i)])
        pmin_[static_cast<std::size_t>(i)] = reference_pressure(i, pres);
    });
    wall_force_.setZero(D, n);
    for_each_particle(exec::par{}, n, [&](index_t j) {
      if (kind_of(j) == kind::wall || kind_of(j) == kind::dummy) wall_force_.col(j) = wall_force_at(j, pres);
    });
    const double inv_rho = 1.0 / p_.rho;
    for_each_particle(exec::par{}, n, [&](index_t i) {
      if (kind_of(i) != kind::fluid) return;
      vec<D> unew = ut_.col(i);
      if (!isolated_[static_cast<std::size_t>(i)]) unew -= dt * inv_rho * pressure_gradient_at(i, pres);
      s_.x().col(i) = xt_.col(i) + dt * (unew - ut_.col(i));
      u.col(i) = unew;
    });
    // 8b. Velocity filter in the one-sided band (params.boundary_filter; off by default).
    if (p_.boundary_filter.strength > 0.0) filter_band();
    // 9. Shifting (policy).
    if constexpr (!std::is_same_v<shifting_type, no_regularization>) {
      ensure_list(s_.x());
      shifting_.apply(
          exec::par{}, s_.x(), nl_, op_, active_filter(),
          [&](index_t j) { return kind_of(j) == kind::fluid && !isolated_[static_cast<std::size_t>(j)]; },
          std::span<const flag::type>(flags));
    }
    t_ += dt;
    ++c_.steps;
    check_finite();
  }

  /// Steps until time() >= t_end (the last step is not shortened), calling observer(*this) after
  /// each step when given.
  template <class Observer>
  void run_until(double t_end, Observer&& observer) {
    step_until(*this, t_end, observer);
  }
  /// Steps until time() >= t_end.
  void run_until(double t_end) {
    run_until(t_end, [](const semi_implicit&) {});
  }

 private:
  template <class T>
  static T make_policy(const params_type& p) {
    if constexpr (requires { typename T::params_type; }) {
      typename T::params_type tp{};
      if constexpr (requires { tp.l0; }) tp.l0 = p.l0;
      return T(tp);
    } else {
      return T{};
    }
  }
  static const params_type& checked(const params_type& p) {
    p.validate();
    return p;
  }
  auto active_filter() const {
    return [this](index_t j) { return !isolated_[static_cast<std::size_t>(j)]; };
  }
  kind kind_of(index_t i) const { return s_.kinds()[static_cast<std::size_t>(i)]; }
  particle_id id_of(index_t i) const { return s_.ids()[static_cast<std::size_t>(i)]; }

  double build_radius() const { return p_.re_large * p_.l0; }
  void build_list(const points<D>& x) {
    nl_.build(exec::par{}, x, search::uniform_radius{build_radius()}, {p_.skin, {}});
    x_built_ = x;
    ++c_.list_builds;
  }
  /// Rebuilds when some particle moved more than half the skin since the build (pairs can approach
  /// by at most twice the largest displacement, so the list then still holds every pair in range).
  void ensure_list(const points<D>& x) {
    if (x_built_.cols() != x.cols() || max_displacement(x) > 0.5 * p_.skin * build_radius()) build_list(x);
  }
  double max_displacement(const points<D>& x) const {
    double m = 0.0;
    for (index_t i = 0; i < x.cols(); ++i) m = std::max(m, (x.col(i) - x_built_.col(i)).squaredNorm());
    return std::sqrt(m);
  }

  /// Pressure of neighbour j seen from row i (dummy: relative to the row, bmmr eq. 17).
  /// In the correction the extrapolated dummy value is floored at 0 when negative pressures are clamped:
  /// above the free surface P_i + ρ g·x_ij is negative and, through the minimum p̂_i of eq. 22, would
  /// push every neighbour of a surface particle next to a wall (measured: the contact-line particles
  /// then ran away within 0.3 s of a hydrostatic tank).
  double pressure_seen(index_t i, index_t j, const Eigen::VectorXd& pres, const vec<D>& xij) const {
    if (kind_of(j) != kind::dummy) return pres[j];
    const double pj = pres[i] + p_.rho * p_.g.dot(xij);
    return p_.negative == negative_pressure::clamp_to_zero ? std::max(pj, 0.0) : pj;
  }

  /// p̂_i of eq. 22 (p_i itself for the plain gradient).
  double reference_pressure(index_t i, const Eigen::VectorXd& pres) const {
    double pmin = pres[i];
    if (p_.gradient == pressure_gradient::minimum || p_.gradient == pressure_gradient::corrected_minimum) {
      nl_.for_each_neighbour(xt_, i, op_.small_support(), [&](index_t j, const vec<D>& d, double) {
        if (!isolated_[static_cast<std::size_t>(j)]) pmin = std::min(pmin, pressure_seen(i, j, pres, d));
      });
    }
    return pmin;
  }

  vec<D> pressure_gradient_at(index_t i, const Eigen::VectorXd& pres) const {
    const double pmin = pmin_[static_cast<std::size_t>(i)];
    // Tanaka eq. 22 (minimum) or eq. 21 (plain: p̂_i = p_i), stencil of eq. 9; with the correction
    // matrix of bmmr.md eq. 29 in place of d/n0 for the corrected forms (C_i over the same neighbours:
    // fluid, wall and dummy, isolated excluded, summed in this sweep; a C_i with fewer than d independent
    // directions falls back to d/n0, as op::mps::correction_matrix does).
    const double re = op_.re_small();
    const bool corrected = p_.gradient == pressure_gradient::corrected_minimum ||
                           p_.gradient == pressure_gradient::corrected;
    vec<D> gsum = vec<D>::Zero();
    mat<D> C = mat<D>::Zero();
    nl_.for_each_neighbour(xt_, i, op_.small_support(), [&](index_t j, const vec<D>& d, double r2) {
      if (isolated_[static_cast<std::size_t>(j)]) return;
      const double w = op_type::kernel_type::w(std::sqrt(r2), re) / r2;
      gsum += ((pressure_seen(i, j, pres, d) - pmin) * w) * d;
      if (corrected) C.noalias() += w * (d * d.transpose());
    });
    if (mat<D> Ci; corrected && op_type::invert_correction(C, Ci)) return Ci * gsum;
    return (double(D) / op_.n0_small()) * gsum;
  }

  /// Force of the fluid on wall/dummy particle j from the antisymmetric pair form of the MPS pressure
  /// gradient (Mitsume et al. 2015 eq. 6, erp.md §1.3): F_j = Σ_fluid i V_i d/n0 (p_i + P_j) x_ij w_ij /
  /// r_ij², V_i = l0^D, P_j as the fluid row sees it. The p̂ form of eq. 22 that moves the fluid is not
  /// antisymmetric (its pair reactions sum to a fraction of the load: 7 % of the weight on a tank bottom,
  /// measured), so loads are read from the momentum-conserving form.
  vec<D> wall_force_at(index_t j, const Eigen::VectorXd& pres) const {
    const double c = std::pow(p_.l0, D) * double(D) / op_.n0_small();
    const double re = op_.re_small();
    vec<D> f = vec<D>::Zero();
    nl_.for_each_neighbour(xt_, j, op_.small_support(), [&](index_t i, const vec<D>& dji, double r2) {
      if (kind_of(i) != kind::fluid || isolated_[static_cast<std::size_t>(i)]) return;
      const vec<D> xij = -dji;  // x_j − x_i seen from fluid particle i
      f += ((pressure_seen(i, j, pres, xij) + pres[i]) *
            op_type::kernel_type::w(std::sqrt(r2), re) / r2) * xij;
    });
    return c * f;
  }

  void solve_pressure(double dt) {
    const index_t n = s_.n_real();
    auto& pres = s_.template get<field::pressure>();
    const auto& flags = s_.flags();
    const auto& nd = s_.template get<field::number_density>();
    // Unknowns: non-surface, non-isolated fluid and wall particles.
    unk_.assign(static_cast<std::size_t>(n), npos);
    rows_.clear();
    for (index_t i = 0; i < n; ++i) {
      const kind k = kind_of(i);
      if ((k == kind::fluid || k == kind::wall) && !isolated_[static_cast<std::size_t>(i)] &&
          !(flags[static_cast<std::size_t>(i)] & flag::surface)) {
        unk_[static_cast<std::size_t>(i)] = static_cast<index_t>(rows_.size());
        rows_.push_back(i);
      }
    }
    const index_t m = static_cast<index_t>(rows_.size());
    for (index_t i = 0; i < n; ++i)
      if (unk_[static_cast<std::size_t>(i)] == npos) pres[i] = 0.0;
    if (m == 0) return;

    // Divergence and current density only when the source asks.
    std::vector<double> div, ncur;
    if constexpr (source_type::needs_divergence) {
      div.assign(static_cast<std::size_t>(m), 0.0);
      for_each_particle(exec::par{}, m, [&](index_t r) {
        const index_t i = rows_[static_cast<std::size_t>(r)];
        // Fluid rows only, over fluid neighbours only: the wall's normal condition is already the
        // dummy rule P_j = P_i + ρ g·x_ij; a divergence that also saw the wall's zero velocity would
        // impose it a second time (measured: twice the hydrostatic gradient after one step from rest).
        if (kind_of(i) != kind::fluid) return;
        div[static_cast<std::size_t>(r)] = op_.divergence(xt_, nl_, i, ut_, [&](index_t j) {
          return !isolated_[static_cast<std::size_t>(j)] && kind_of(j) == kind::fluid;
        });
      });
    }
    if constexpr (source_type::needs_current_density) {
      ncur.assign(static_cast<std::size_t>(m), 0.0);
      for_each_particle(exec::par{}, m, [&](index_t r) {
        const index_t i = rows_[static_cast<std::size_t>(r)];
        ncur[static_cast<std::size_t>(r)] =
            op_.number_density(s_.x(), nl_, i, active_filter());
      });
    }

    // Rows straight into CSR (count, then fill; each row sorted, deterministic).
    const double shift = p_.rho * p_.compressibility / (dt * dt);
    std::vector<std::ptrdiff_t> outer(static_cast<std::size_t>(m + 1), 0);
    dirichlet_.assign(static_cast<std::size_t>(m), 0);
    for_each_particle(exec::par{}, m, [&](index_t r) {
      const index_t i = rows_[static_cast<std::size_t>(r)];
      std::ptrdiff_t cnt = 1;
      op_.for_each_laplacian_weight(xt_, nl_, i, op::all_neighbours{}, [&](index_t j, double) {
        if (unk_[static_cast<std::size_t>(j)] != npos) ++cnt;
      });
      outer[static_cast<std::size_t>(r + 1)] = cnt;
    });
    for (index_t r = 0; r < m; ++r)
      outer[static_cast<std::size_t>(r + 1)] += outer[static_cast<std::size_t>(r)];
    A_.resize(m, m);
    A_.resizeNonZeros(outer.back());
    std::copy(outer.begin(), outer.end(), A_.outerIndexPtr());
    b_.resize(m);
    std::ptrdiff_t* inner = A_.innerIndexPtr();
    double* val = A_.valuePtr();
    for_each_particle(exec::par{}, m, [&](index_t r) {
      const index_t i = rows_[static_cast<std::size_t>(r)];
      std::ptrdiff_t at = outer[static_cast<std::size_t>(r)];
      const std::ptrdiff_t diag_at = at++;
      double diag = shift, rhs_dummy = 0.0;
      bool dir = false;
      op_.for_each_laplacian_weight(xt_, nl_, i, op::all_neighbours{}, [&](index_t j, double a) {
        if (isolated_[static_cast<std::size_t>(j)]) return;  // excluded from others' operators
        const index_t cj = unk_[static_cast<std::size_t>(j)];
        if (cj != npos) {  // unknown column
          inner[at] = cj;
          val[at++] = -a;
          diag += a;
        } else if (kind_of(j) == kind::dummy) {  // relative to the row: a ρ g·x_ij to the right side
          rhs_dummy += a * p_.rho * p_.g.dot(nl_.displacement(xt_, i, j));
        } else {  // surface fluid or dry wall: Dirichlet p = 0
          diag += a;
          dir = true;
        }
      });
      inner[diag_at] = r;
      val[diag_at] = diag;
      sort_row(inner + outer[static_cast<std::size_t>(r)], val + outer[static_cast<std::size_t>(r)],
               outer[static_cast<std::size_t>(r + 1)] - outer[static_cast<std::size_t>(r)]);
      ppe::source_inputs in;
      in.rho = p_.rho;
      in.dt = dt;
      in.l0 = p_.l0;
      in.n0 = op_.n0_small();
      in.n_temporary = nd[i];
      if constexpr (source_type::needs_divergence) in.divergence = div[static_cast<std::size_t>(r)];
      if constexpr (source_type::needs_current_density) in.n_current = ncur[static_cast<std::size_t>(r)];
      // M p = −b + Σ_dummy a ρ g·x_ij with M = −L + (ρ α_c/Δt²) I.
      b_[r] = -source_.rhs(in) + rhs_dummy;
      dirichlet_[static_cast<std::size_t>(r)] = dir || shift > 0.0;
    });
    pin_floating_parts();

    // Solve with warm start.
    Eigen::VectorXd sol(m);
    for (index_t r = 0; r < m; ++r) sol[r] = pres[rows_[static_cast<std::size_t>(r)]];
    last_solve_ = ppe::solve_checked(solver_, A_, b_, sol, p_.solver, c_.steps, t_, [&](index_t r) {
      const index_t i = rows_[static_cast<std::size_t>(r)];
      return mpskit::detail::concat("particle ", i, " (id ", id_of(i), ")");
    });
    c_.ppe_iterations += last_solve_.iterations;
    c_.ppe_iterations_max = std::max(c_.ppe_iterations_max, last_solve_.iterations);
    c_.ppe_fallbacks += last_solve_.fallback;
    c_.ppe_breakdown_restarts += last_solve_.breakdown_restart;
    c_.ppe_cold_restarts += last_solve_.cold_restart;
    long clamped = 0;
    for (index_t r = 0; r < m; ++r) {
      double v = sol[r];
      if (p_.negative == negative_pressure::clamp_to_zero && v < 0.0) {
        v = 0.0;
        ++clamped;
      }
      pres[rows_[static_cast<std::size_t>(r)]] = v;
    }
    c_.negative_clamped += clamped;
  }

  static void sort_row(std::ptrdiff_t* idx, double* val, std::ptrdiff_t len) {
    // Insertion sort: rows are short and nearly sorted when the state is in cell order.
    for (std::ptrdiff_t a = 1; a < len; ++a) {
      const std::ptrdiff_t ki = idx[a];
      const double kv = val[a];
      std::ptrdiff_t b = a - 1;
      while (b >= 0 && idx[b] > ki) {
        idx[b + 1] = idx[b];
        val[b + 1] = val[b];
        --b;
      }
      idx[b + 1] = ki;
      val[b + 1] = kv;
    }
  }

  /// Connected parts of the unknowns' graph with no Dirichlet row get p = 0 at their lowest-id
  /// particle (row and column zeroed, diagonal 1: the matrix stays symmetric). Counted.
  void pin_floating_parts() {
    const auto parts = ppe::find_floating_parts(
        A_, dirichlet_, true, [this](index_t r) { return id_of(rows_[static_cast<std::size_t>(r)]); });
    for (const ppe::floating_part& part : parts) {
      const index_t pin = part.pin;
      ++c_.pinned_components;
      for (matrix_type::InnerIterator it(A_, pin); it; ++it) it.valueRef() = it.index() == pin ? 1.0 : 0.0;
      b_[pin] = 0.0;
      for (index_t r : part.members) {  // only this part's rows: O(nnz) over all parts
        if (r == pin) continue;
        for (matrix_type::InnerIterator it(A_, r); it; ++it)
          if (it.index() == pin) it.valueRef() = 0.0;
      }
    }
  }

  /// 8b. The one-sided band (fluid particles with a surface fluid or a wall particle within re_large,
  /// flags from this step's detection at x′, band found at x^{k+1}) filtered towards the LSMPS-B order-2
  /// fit of its neighbours' velocities (radius re_large, pair-mean rule with L = l0 everywhere).
  void filter_band() {
    const index_t n = s_.n_real();
    const auto& x = s_.x();
    const auto& flags = s_.flags();
    ensure_list(x);
    band_.assign(static_cast<std::size_t>(n), 0);
    for_each_particle(exec::par{}, n, [&](index_t i) {
      if (kind_of(i) != kind::fluid || isolated_[static_cast<std::size_t>(i)]) return;
      bool b = false;
      nl_.for_each_neighbour(x, i, op_.large_support(), [&](index_t j, const vec<D>&, double) {
        if (isolated_[static_cast<std::size_t>(j)]) return;
        if (kind_of(j) == kind::wall ||
            (kind_of(j) == kind::fluid && (flags[static_cast<std::size_t>(j)] & flag::surface)))
          b = true;
      });
      band_[static_cast<std::size_t>(i)] = b;
    });
    L_.setConstant(n, p_.l0);
    const search::support<search::per_particle_radius> sup{{&L_, p_.re_large},
                                                           search::radius_rule::pair_mean};
    op::lsmps_params op;
    op.re_ratio = p_.re_large;
    const auto participates = [&](index_t j) { return !isolated_[static_cast<std::size_t>(j)]; };
    const auto selected = [&](index_t i) { return band_[static_cast<std::size_t>(i)] != 0; };
    regularize::boundary_filter(exec::par{}, x, L_, nl_, sup, op, participates, selected, n,
                                p_.boundary_filter, s_.u(), s_.u(), filter_du_);
  }

  void check_finite() const {
    for (index_t i = 0; i < s_.n_real(); ++i)
      if (!s_.x().col(i).allFinite() || !s_.u().col(i).allFinite() ||
          !std::isfinite(s_.template get<field::pressure>()[i]))
        fail("non-finite position, velocity or pressure at step ", c_.steps, ", t = ", t_, " s: particle ", i,
             " (id ", id_of(i), ", ", name(kind_of(i)), ")");
  }

  using matrix_type = ppe::matrix;
  params_type p_;
  op_type op_;
  source_type source_;
  surface_type surface_;
  collision_type collision_;
  shifting_type shifting_;
  time_step_controller dt_ctrl_;
  solver_type solver_;
  state_type s_;
  search::neighbour_list<D> nl_;
  points<D> x_built_, xt_, ut_, wall_force_;
  std::vector<double> pmin_;
  std::vector<std::uint8_t> isolated_, candidate_, dirichlet_, band_;
  Eigen::VectorXd L_;
  points<D> filter_du_;
  std::vector<index_t> unk_, rows_;
  matrix_type A_;
  Eigen::VectorXd b_;
  ppe::solve_report last_solve_{};
  semi_implicit_counters c_{};
  double t_ = 0.0, dt_ = 0.0;
};

}  // namespace mpskit::scheme
