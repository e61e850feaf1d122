#pragma once
/// \file resolution/split_merge.hpp
/// \brief Particle splitting and merging of Tanaka, Cardoso & Bahai 2018, §4.4 (eqs. 65–74):
/// resolution::split_merge<Trigger = tanaka_thresholds, Pattern = two_way> (issue #9 item 1,
/// docs/resolution.md).
///
/// One call of split_merge<>::apply(exec, state, inputs, params, grad_u, ledger) at the end of a step:
///  1. L*_i = params.target_diameter at every real fluid particle (called sequentially, in index order);
///     the trigger decides: split when L* < β_s L (eq. 66), merge when L* > β_m L (eq. 71).
///  2. Splits (non-isolated fluid only): the direction t from a fixed candidate set (2D: N_θ angles over
///     [0, π); 3D: a Fibonacci hemisphere; surface particles: N_θ directions of the plane t·n = 0, in 2D the
///     one tangent) minimising e_i (eqs. 68–69) with e_i < α_e, children x ± (α_t/2) L′ t (eqs. 65, 67)
///     whose signed wall distance is ≥ wall_clearance · L′; velocities u ± ⟨∇u⟩ (α_t/2) L′ t (eq. 70).
///     Then, sequentially in id order, a split whose children clash with those of a neighbour split decided
///     before it chooses again with that neighbour's children in its place, or is refused (ours:
///     resolve_neighbour_splits, docs/resolution.md Choices 11).
///  3. Merges: i (L*_i > β_m L_i) with j, both non-isolated fluid and not asking to split, r_ij < α_r L_ij,
///     and only if the merged particle would not split at once (trigger at x′ with L′). Pairs are formed
///     by iterated mutual nearest neighbours: eligible pairs are taken in increasing (rank, r_ij², lower id,
///     higher id) order (rank 0 when both ask to merge, 1 otherwise: merge_partners::alike_first), each taken
///     when both ends are still free (greedy matching on a strict total order = repeated mutual-nearest
///     pairing), so the pairs depend on neither the thread count nor the input order. Eqs. 72–74 give x′, u′,
///     V′ = V_i + V_j.
///  4. Every event is checked by the conservation ledger (resolution/ledger.hpp), then all events go through
///     ONE particle_state::gather (children and merged particles are new particles with new ids; ghosts are
///     dropped), and the global ΣV, ΣVu before/after are compared with the events' sum.
/// One event per particle per step.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/resolution/concepts.hpp"
#include "mpskit/resolution/ledger.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::resolution {

/// 2^(1/D) (exact constants: constexpr std::pow is not portable C++20).
template <int D>
constexpr double root2() {
  return D == 2 ? std::numbers::sqrt2 : 1.2599210498948731647672106072782284;
}

/// Tanaka's thresholds (eqs. 66 and 71): split when L* < β_s L, merge when L* > β_m L.
struct tanaka_thresholds final {
  /// β_s = ½ {(½)^(1/d) + 1} (eq. 66): halfway between L and the split diameter L′ = (½)^(1/d) L (eq. 65).
  /// 2D: 0.853553, 3D: 0.896850.
  template <int D>
  static constexpr double beta_s() {
    return 0.5 * (1.0 / root2<D>() + 1.0);
  }
  /// β_m = 2^(1/d) (eq. 71): the diameter of two equal particles merged (eq. 74). 2D: 1.414214, 3D: 1.259921.
  template <int D>
  static constexpr double beta_m() {
    return root2<D>();
  }
  /// What a particle of diameter L with target L_target asks for.
  template <int D>
  static want decide(double L_target, double L) {
    if (L_target < beta_s<D>() * L) return want::split;
    if (L_target > beta_m<D>() * L) return want::merge;
    return want::none;
  }
};

/// Two children per split, two parents per merge (Tanaka §4.4: the only pattern of the paper).
struct two_way final {
  static constexpr int children = 2;
  /// L′ / L = (½)^(1/d) (eq. 65).
  template <int D>
  static constexpr double child_ratio() {
    return 1.0 / root2<D>();
  }
};

static_assert(Trigger<tanaka_thresholds> && !Trigger<int>);
static_assert(SplitPattern<two_way> && !SplitPattern<int>);

/// Where a target diameter is asked for (a callable may read any of it).
template <int D>
struct target_point {
  vec<D> x = vec<D>::Zero();  ///< position (m)
  /// Signed distance to the walls (m, positive in the fluid); +inf when no walls are given.
  double wall_distance = std::numeric_limits<double>::infinity();
  /// Distance to the nearest free-surface particle among the list's neighbours (m; 0 on the surface, the
  /// smaller of the two parents' for a merged position); +inf when none is within the list's radius.
  double surface_distance = std::numeric_limits<double>::infinity();
  index_t index = npos;  ///< particle index (npos at a merged particle's position)
};

/// The target diameter L*: any callable taking the position (`double(const vec<D>&)`, also generic lambdas
/// `[](const auto& x)`) or the whole target_point (`double(const target_point<D>&)`, which makes the module
/// compute the wall and surface distances). Must return a finite number > 0.
template <int D>
class target_diameter_fn {
 public:
  target_diameter_fn() = default;
  /// Wraps f (see the class comment for the accepted signatures).
  template <class F>
    requires(!std::is_same_v<std::remove_cvref_t<F>, target_diameter_fn>)
  target_diameter_fn(F f) {  // NOLINT: implicit on purpose (params.target_diameter = lambda)
    if constexpr (std::is_invocable_r_v<double, F&, const vec<D>&>) {
      f_ = [g = std::move(f)](const target_point<D>& p) mutable { return static_cast<double>(g(p.x)); };
      context_ = false;
    } else {
      static_assert(std::is_invocable_r_v<double, F&, const target_point<D>&>,
                    "mpskit: target_diameter must be callable as double(const vec<D>&) or "
                    "double(const resolution::target_point<D>&)");
      f_ = std::move(f);
      context_ = true;
    }
  }
  /// True when a callable is set.
  explicit operator bool() const { return static_cast<bool>(f_); }
  /// True when the callable reads wall / surface distances.
  bool wants_context() const { return context_; }
  /// L* at p.
  double operator()(const target_point<D>& p) const { return f_(p); }
  /// The target_point at a position where there is no particle (a start lattice, an inflow point): the wall
  /// distance from `wall_distance(x)`, called only when the callable reads the context; surface distance +inf
  /// and index npos. split_merge, which also fills the surface distance and the index, builds its own.
  template <class WallDistance>
  target_point<D> point(const vec<D>& x, const WallDistance& wall_distance) const {
    target_point<D> p;
    p.x = x;
    if (context_) p.wall_distance = wall_distance(x);
    return p;
  }
  /// L* at p, refused unless finite and > 0; the message reads "<who>: target_diameter returned L* at
  /// <where()>: accepted range (0, inf)". `where` returns the place as a string and is called only on failure
  /// (the check runs per particle per step). Used by split_merge and by the stepper's pressure-face check.
  template <class Where>
  double checked(const target_point<D>& p, const char* who, const Where& where) const {
    const double Ls = f_(p);
    if (!(std::isfinite(Ls) && Ls > 0.0))
      fail(who, ": target_diameter returned ", Ls, " at ", where(), ": accepted range (0, inf)");
    return Ls;
  }

 private:
  std::function<double(const target_point<D>&)> f_;
  bool context_ = false;
};

/// Which merge partners are paired first (§4.4.2: "the difference of the diameters during the merging
/// process should be as small as possible"; the paper pairs i with "a neighbouring particle j").
enum class merge_partners {
  /// Pairs of two particles that both ask to merge first (nearest first), then a particle that asks with
  /// one that does not (ours, the default): a child leaving a refined region merges with its sibling-sized
  /// neighbour before it takes a coarse one (volume 1.5 V, which splits twice on re-entry).
  alike_first,
  /// Only partners that ask to merge too (ours): sizes stay within the steps of the trigger.
  both_ask,
  /// Nearest eligible partner whatever it asks (the paper's text read literally).
  nearest,
};

/// Runtime numbers of split/merge with Tanaka 2018's defaults (Table 2) where the paper gives them.
template <int D>
struct split_merge_params {
  target_diameter_fn<D> target_diameter;  ///< L*(x) (required)
  double alpha_e = 0.6;  ///< α_e: a direction is accepted only with e_i < α_e (eq. 68; Table 2)
  double alpha_t = 0.7;  ///< α_t: children at x ± (α_t/2) L′ t (eq. 67; Table 2)
  double alpha_r = 1.5;  ///< α_r: merge partners within r_ij < α_r L_ij (§4.4.2; Table 2)
  /// N_θ: 2D candidate angles kπ/N_θ, k < N_θ; 3D: directions in the tangent plane of a surface particle.
  /// Not in the paper (it does not say how e_i is minimised): 36 (5°) includes the axes and diagonals.
  int n_theta = 36;
  /// 3D candidate directions (Fibonacci hemisphere). Not in the paper: 256 (mean spacing ≈ 9°).
  int n_directions_3d = 256;
  /// Children keep a signed wall distance ≥ wall_clearance · L′ (issue #9: L′/2).
  double wall_clearance = 0.5;
  /// Children of a parent in contact with a wall (signed distance ≤ split_merge_inputs::wall_reach · L, the
  /// wall model's α_w: it has a copy) keep the wall in contact: the nearer child within wall_contact · L′ of
  /// it (ours; the paper asks only for the clearance). Without it a first row split three times in a row sat
  /// 1.06–1.41 L′ above the floor, beyond α_w L′, so no copy held the wall there and the PPE failed two steps
  /// later (docs/resolution.md "Hard cases"). Contact means with any wall (in a corner the side wall may
  /// satisfy a floor-touching parent), and the rule is stricter than α_w: it can refuse a split whose nearer
  /// child would still be copied (up to α_w L′), leaving such a particle coarse (counted as
  /// refusal::wall_contact). Off by default (inf): with 0.75 the multi-diameter channel's PPE stopped
  /// converging at step 162 (t = 0.068 s; not yet understood). Accepted [wall_clearance, inf]; 0.75 is the
  /// measured value for a fluid at rest.
  double wall_contact = std::numeric_limits<double>::infinity();
  /// When the contact rule refuses every direction the other rules admit, split anyway along the direction
  /// whose nearer child comes closest to the wall, if that child is within split_merge_inputs::wall_reach ·
  /// L′ (the wall model copies it: it holds the wall through its own copies). Ours, opt-in (needs a finite
  /// wall_contact). Without it a parent whose centre lies between (wall_contact · L′ + δ) and wall_reach · L
  /// from a wall is in contact but can never keep a child within wall_contact · L′ (δ = (α_t/2) L′, eq. 67;
  /// in 2D with α_w = 1 and wall_contact = 0.75: between 0.78 L and L), so it stays coarse however small its
  /// target: seen 2026-12-05, a 5 mm particle 4.6 mm above the floor at the edge of the 1 mm zone of the
  /// obstacle case at ratio 5, beside two 0.88 mm particles that left at 73 and 169 m/s in the step the run
  /// blew up (the refusal inferred, not printed; docs/resolution.md "Hard cases" 2b). Counted in
  /// split_merge_report::contact_fallbacks. The nearest child is chosen, not the least e_i within the copy
  /// band (that alternative was run at one spacing only, "Hard cases" 2b).
  bool wall_contact_fallback = false;
  /// Pairing order of the merges (docs/resolution.md): alike_first (default, ours) or nearest.
  merge_partners partners = merge_partners::alike_first;
  bool split = true;  ///< allow splitting
  bool merge = true;  ///< allow merging
  ledger_params ledger{};  ///< per-event tolerances (4 and 8 ulp) and the density of the reports

  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("split_merge_params");
    v.require(static_cast<bool>(target_diameter), "target_diameter", "is not set: give a callable L*(x) (m)");
    v.require(alpha_e > 0.0 && alpha_e <= 1.0, "alpha_e",
              mpskit::detail::concat("= ", alpha_e, ": must be in (0, 1] (e_ij is in [0, 1], eq. 69)"));
    v.require(alpha_t > 0.0 && alpha_t <= 2.0, "alpha_t",
              mpskit::detail::concat("= ", alpha_t, ": must be in (0, 2] (children α_t L′ apart, eq. 67)"));
    v.require(alpha_r > 0.0 && alpha_r <= 3.0, "alpha_r",
              mpskit::detail::concat("= ", alpha_r,
                                     ": must be in (0, 3] (partners within α_r L_ij; lists reach 3.1 L)"));
    v.in_range("n_theta", n_theta, 1, 100000);
    v.in_range("n_directions_3d", n_directions_3d, 1, 1000000);
    v.in_range("wall_clearance", wall_clearance, 0.0, 10.0);
    v.require(wall_contact >= wall_clearance, "wall_contact",
              mpskit::detail::concat("= ", wall_contact, ": must be in [wall_clearance = ", wall_clearance,
                                     ", inf]"));
    v.require(!wall_contact_fallback || std::isfinite(wall_contact), "wall_contact_fallback",
              "is on but wall_contact is infinite (no contact rule to fall back from): set wall_contact too");
    v.throw_if_any();
    ledger.validate();
  }
};

/// The inputs split/merge reads (pointers: the caller's arrays, not copied). Arrays cover every particle of
/// the state, real and ghost.
template <int D>
struct split_merge_inputs {
  /// Neighbour list over the state (real + ghosts), holding at least every pair with r_ij < max(α_r, 2
  /// + α_t/2) L_ij (a list at R_e = 3.1 does). Required.
  const search::neighbour_list<D>* neighbours = nullptr;
  const Eigen::VectorXd* L = nullptr;  ///< diameters L = V^(1/D) (required)
  const points<D>* normals = nullptr;  ///< outward unit normals (required if a surface particle splits)
  const std::vector<flag::type>* flags = nullptr;   ///< surface / isolated bits; nullptr: the state's flags
  const geometry::polygon_set<D>* walls = nullptr;  ///< walls for the children's clearance check (optional)
  /// A parent within wall_reach · L of a wall is in contact with it (split_merge_params::wall_contact): the
  /// wall model's copy distance α_w (wall::imaginary_params::alpha_w; the LSMPS scheme passes its own).
  double wall_reach = 1.0;
};

/// Why a wanted event did not happen.
enum class refusal : std::uint8_t {
  isolated = 0,    ///< the particle is isolated (only non-isolated fluid particles change size)
  error_function,  ///< split: no direction with e_i < α_e
  wall,  ///< split: every direction with e_i < α_e puts a child within wall_clearance·L′ of a wall
  wall_contact,  ///< split: the parent touches a wall and every remaining direction leaves it out of contact
  degenerate_normal,   ///< split: a surface particle without a usable normal
  neighbour_children,  ///< split: its children clashed with those of a neighbour split earlier in the same
                       ///< call (lower id), and no direction is admissible (eqs. 68–69 and the wall rules)
                       ///< once that neighbour's children replace it
  no_partner,     ///< merge: no eligible neighbour with r_ij < α_r L_ij
  would_split,    ///< merge: every merged particle would split at once (L*(x′) < β_s L′)
  partner_taken,  ///< merge: every eligible partner merged with another particle
  disabled,       ///< splitting or merging switched off in params
  count_
};
inline constexpr int refusal_count = static_cast<int>(refusal::count_);
/// Name of a refusal reason.
constexpr const char* name(refusal r) {
  switch (r) {
    case refusal::isolated: return "isolated";
    case refusal::error_function: return "error_function";
    case refusal::wall: return "wall";
    case refusal::wall_contact: return "wall_contact";
    case refusal::degenerate_normal: return "degenerate_normal";
    case refusal::neighbour_children: return "neighbour_children";
    case refusal::no_partner: return "no_partner";
    case refusal::would_split: return "would_split";
    case refusal::partner_taken: return "partner_taken";
    case refusal::disabled: return "disabled";
    default: return "unknown";
  }
}

/// One split.
template <int D>
struct split_event {
  particle_id parent_id = no_id;           ///< the particle split (removed)
  index_t parent_index = npos;             ///< its index before the resize
  vec<D> t = vec<D>::Zero();               ///< direction (unit)
  double e = 0.0;                          ///< e_i of the chosen direction (eqs. 68–69)
  std::array<index_t, 2> child{npos, npos};          ///< children's indices after the resize (x + δt, x − δt)
  std::array<particle_id, 2> child_id{no_id, no_id};  ///< children's new ids
  event_balance<D> balance{};              ///< what the event changed
};

/// One merge.
template <int D>
struct merge_event {
  std::array<particle_id, 2> parent_id{no_id, no_id};  ///< the two particles (lower id first; removed)
  std::array<index_t, 2> parent_index{npos, npos};     ///< their indices before the resize
  double r = 0.0;                          ///< r_ij
  index_t merged = npos;                   ///< the merged particle's index after the resize
  particle_id merged_id = no_id;           ///< its new id
  event_balance<D> balance{};              ///< what the event changed
};

/// What one call did.
template <int D>
struct split_merge_report {
  index_t wanted_split = 0;       ///< real fluid particles whose trigger asked for a split
  index_t wanted_merge = 0;       ///< ... for a merge
  index_t splits = 0;             ///< splits done
  index_t merges = 0;             ///< merges done
  index_t redirected = 0;         ///< splits whose direction was chosen again against a neighbour's children
  index_t contact_fallbacks = 0;  ///< splits done by split_merge_params::wall_contact_fallback
  std::array<index_t, refusal_count> refused{};  ///< wanted events not done, by reason
  std::vector<split_event<D>> split_events;      ///< every split, in old index order
  std::vector<merge_event<D>> merge_events;      ///< every merge, in pairing order
  resize_report resize{};                        ///< the one resize (empty when nothing happened)
  ledger_step<D> ledger{};                       ///< this call's events as the ledger summed them
  /// Refusals for one reason.
  index_t refused_for(refusal r) const { return refused[static_cast<std::size_t>(r)]; }
};

/// The candidate directions: 2D, N_θ angles kπ/N_θ; 3D, a Fibonacci hemisphere of n points (z > 0,
/// z_k = 1 − (k + ½)/n, azimuth k·π(3 − √5)). t and −t give the same pair of children.
template <int D>
std::vector<vec<D>> split_directions(int n_theta, int n_3d) {
  std::vector<vec<D>> t;
  if constexpr (D == 2) {
    for (int k = 0; k < n_theta; ++k) {
      const double th = std::numbers::pi * k / n_theta;
      t.push_back(vec<D>(std::cos(th), std::sin(th)));
    }
  } else {
    const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
    for (int k = 0; k < n_3d; ++k) {
      const double z = 1.0 - (k + 0.5) / n_3d;
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      const double ph = golden * k;
      t.push_back(vec<D>(r * std::cos(ph), r * std::sin(ph), z));
    }
  }
  return t;
}

/// Directions of the plane t·n = 0 (n unit): 2D the one tangent (−n_y, n_x), exactly perpendicular;
/// 3D, N_θ angles kπ/N_θ in the basis e1 = (a × n)/|a × n| (a the axis least aligned with n), e2 = n × e1.
template <int D>
std::vector<vec<D>> tangent_directions(const vec<D>& n, int n_theta) {
  std::vector<vec<D>> t;
  if constexpr (D == 2) {
    t.push_back(vec<D>(-n[1], n[0]));
  } else {
    int a = 0;
    for (int b = 1; b < 3; ++b)
      if (std::abs(n[b]) < std::abs(n[a])) a = b;
    vec<D> ax = vec<D>::Zero();
    ax[a] = 1.0;
    const vec<D> e1 = ax.cross(n).normalized();
    const vec<D> e2 = n.cross(e1);
    for (int k = 0; k < n_theta; ++k) {
      const double th = std::numbers::pi * k / n_theta;
      t.push_back(vec<D>(std::cos(th) * e1 + std::sin(th) * e2));
    }
  }
  return t;
}

/// Tanaka 2018's particle splitting and merging (§4.4); see the file comment and docs/resolution.md.
/// \tparam Trigger models Trigger (when to split / merge); \tparam Pattern models SplitPattern (two_way)
template <class Trigger_ = tanaka_thresholds, class Pattern_ = two_way>
struct split_merge final {
  static_assert(Trigger<Trigger_>, "mpskit: split_merge<Trigger>: Trigger must model resolution::Trigger");
  static_assert(SplitPattern<Pattern_>, "mpskit: split_merge<..., Pattern>: Pattern must model SplitPattern");
  static_assert(Pattern_::children == 2,
                "mpskit: split_merge implements Tanaka's two-way pattern only (eqs. 65–74)");
  using trigger = Trigger_;
  using pattern = Pattern_;
  using fields = field_list<field::volume>;  ///< size is stored as volume (exact halving)

  /// Decides, checks and applies every split and merge of the step through one resize; see the file comment.
  /// grad_u(i) → mat<D> is ⟨∇u⟩_i with (∇u)_ab = ∂u_a/∂x_b (eq. 70), called once per split particle,
  /// sequentially. The ledger, if given, receives every event (else a local one checks them).
  template <Execution E, int D, class Fields, class GradU>
  static split_merge_report<D> apply(E e, particle_state<D, Fields>& s, const split_merge_inputs<D>& in,
                                     const split_merge_params<D>& p, GradU&& grad_u,
                                     conservation_ledger<D>* ledger = nullptr) {
    static_assert(particle_state<D, Fields>::template has<field::volume>,
                  "mpskit: split_merge needs the volume field (size is stored as volume)");
    p.validate();
    conservation_ledger<D> local(p.ledger);
    conservation_ledger<D>& led = ledger ? *ledger : local;
    worker<D, Fields> w(s, in, p);
    w.decide(e);
    split_merge_report<D> rep = w.commit(std::forward<GradU>(grad_u), led);
    rep.ledger = summary(rep);
    return rep;
  }

 private:
  /// This call's events summed as the ledger sums a step (fluxes are not split/merge's).
  template <int D>
  static ledger_step<D> summary(const split_merge_report<D>& r) {
    ledger_step<D> d;
    d.splits = r.splits;
    d.merges = r.merges;
    const auto add = [&d](const event_balance<D>& b) {
      d.dV += b.dV;
      d.dVu += b.dVu;
      d.dKE += b.dKE;
      d.dL += b.dL;
      d.max_volume_ulps = std::max(d.max_volume_ulps, b.volume_ulps());
      d.max_momentum_ulps = std::max(d.max_momentum_ulps, b.momentum_ulps());
    };
    for (const auto& ev : r.split_events) add(ev.balance);
    for (const auto& ev : r.merge_events) add(ev.balance);
    return d;
  }

  /// relative tolerance under which two directions tie (lower index wins)
  static constexpr double tie = 1e-12;

  template <int D, class Fields>
  class worker {
   public:
    using state = particle_state<D, Fields>;
    worker(state& s, const split_merge_inputs<D>& in, const split_merge_params<D>& p)
        : s_(s), in_(in), p_(p) {
      check_inputs();
    }

    void decide(auto e) {
      const index_t n = s_.n_real();
      const auto& x = s_.x();
      Lt_.assign(static_cast<std::size_t>(n), 0.0);
      want_.assign(static_cast<std::size_t>(n), want::none);
      eligible_.assign(static_cast<std::size_t>(n), 0);
      // 1. Target diameters (sequential: the user's callable need not be thread-safe) and the trigger.
      const bool ctx = p_.target_diameter.wants_context();
      for (index_t i = 0; i < n; ++i) {
        if (kind_of(i) != kind::fluid) continue;
        target_point<D> tp;
        tp.x = x.col(i);
        tp.index = i;
        if (ctx) {
          tp.wall_distance = wall_distance(tp.x);
          tp.surface_distance = surface_distance(i);
        }
        const double Ls = p_.target_diameter.checked(tp, "split_merge", [&] {
          return mpskit::detail::concat("particle ", i, " (id ", id_of(i), ", x = ", fmt(tp.x), ")");
        });
        Lt_[static_cast<std::size_t>(i)] = Ls;
        const want wi = Trigger_::template decide<D>(Ls, L(i));
        want_[static_cast<std::size_t>(i)] = wi;
        const bool iso = (flag_of(i) & flag::isolated) != 0;
        if (wi == want::split) ++rep_.wanted_split;
        if (wi == want::merge) ++rep_.wanted_merge;
        if (wi != want::none && iso) ++rep_.refused[static_cast<std::size_t>(refusal::isolated)];
        eligible_[static_cast<std::size_t>(i)] = !iso;
      }
      // 2. Splits.
      for (index_t i = 0; i < n; ++i)
        if (want_[static_cast<std::size_t>(i)] == want::split && eligible_[static_cast<std::size_t>(i)])
          split_cand_.push_back(i);
      if (!p_.split) {
        rep_.refused[static_cast<std::size_t>(refusal::disabled)] += static_cast<index_t>(split_cand_.size());
        split_cand_.clear();
      }
      if (!in_.normals)
        for (index_t i : split_cand_)
          if (flag_of(i) & flag::surface)
            fail("split_merge: surface particle ", i, " (id ", id_of(i),
                 ") asks to split but inputs.normals is null "
                 "(a surface split is perpendicular to n)");
      choice_.assign(split_cand_.size(), split_choice{});
      const std::vector<vec<D>> dirs = split_directions<D>(p_.n_theta, p_.n_directions_3d);
      for_each_particle(e, static_cast<index_t>(split_cand_.size()), [&](index_t k) {
        choice_[static_cast<std::size_t>(k)] =
            choose_direction(split_cand_[static_cast<std::size_t>(k)], dirs);
      });
      resolve_neighbour_splits(dirs);
      for (const split_choice& c : choice_)
        if (!c.ok) ++rep_.refused[static_cast<std::size_t>(c.why)];
      // 3. Merges.
      if (p_.merge) pair_up(e);
      else
        for (index_t i = 0; i < n; ++i)
          if (want_[static_cast<std::size_t>(i)] == want::merge && eligible_[static_cast<std::size_t>(i)])
            ++rep_.refused[static_cast<std::size_t>(refusal::disabled)];
    }

    template <class GradU>
    split_merge_report<D> commit(GradU&& grad_u, conservation_ledger<D>& led) {
      const index_t n = s_.n_real();
      auto& x = s_.x();
      auto& u = s_.u();
      auto& V = s_.template get<field::volume>();
      const auto& dom = in_.neighbours->dom();
      // Global sums before (exact), to check the resize against the events.
      detail::exact_sum V0, V1;
      std::array<detail::exact_sum, D> M0{}, M1{};
      for (index_t i = 0; i < n; ++i) {
        V0.add(V[i]);
        for (int a = 0; a < D; ++a) M0[static_cast<std::size_t>(a)].add_product(V[i], u(a, i));
      }
      // Splits: children data (eqs. 65, 67, 70) and the ledger.
      struct child_data {
        std::array<vec<D>, 2> x, u;
        double V;
      };
      std::vector<child_data> kids;
      std::vector<index_t> split_of(static_cast<std::size_t>(n), npos);
      for (std::size_t k = 0; k < choice_.size(); ++k) {
        const split_choice& c = choice_[k];
        if (!c.ok) continue;
        if (c.contact_fallback) ++rep_.contact_fallbacks;
        const index_t i = split_cand_[k];
        const vec<D> d = half_offset(i) * c.t;  // eq. 67 (the offset resolve_neighbour_splits assumed)
        const mat<D> G = grad_u(i);
        if (!G.allFinite()) fail("split_merge: grad_u of particle ", i, " (id ", id_of(i), ") is not finite");
        // eq. 70: u_i′ = u_i + ⟨∇u⟩_i (x_i′ − x_i), computed once for ± (exact cancellation)
        const vec<D> a = G * d;
        child_data cd;
        cd.V = 0.5 * V[i];  // exact
        cd.x = {vec<D>(x.col(i) + d), vec<D>(x.col(i) - d)};
        cd.u = {vec<D>(u.col(i) + a), vec<D>(u.col(i) - a)};
        const std::array<particle_view<D>, 1> pb{{{V[i], x.col(i), u.col(i)}}};
        const std::array<particle_view<D>, 2> pa{{{cd.V, cd.x[0], cd.u[0]}, {cd.V, cd.x[1], cd.u[1]}}};
        const std::array<particle_id, 1> ids{id_of(i)};
        split_event<D> ev;
        ev.parent_id = id_of(i);
        ev.parent_index = i;
        ev.t = c.t;
        ev.e = c.e;
        ev.balance = led.record("split", ids, pb, pa);
        led.count_split();
        cd.x[0] = dom.wrap(cd.x[0]);
        cd.x[1] = dom.wrap(cd.x[1]);
        split_of[static_cast<std::size_t>(i)] = static_cast<index_t>(kids.size());
        kids.push_back(cd);
        rep_.split_events.push_back(ev);
      }
      // Merges (eqs. 72–74), ledger, then the merged values written into the first member's old slot (the
      // resize copies that slot into the new particle: intensive fields volume-weighted).
      std::vector<index_t> merge_first(static_cast<std::size_t>(n), npos),
          merge_second(static_cast<std::size_t>(n), npos);
      struct merged_data {
        vec<D> x, u;
        double V;
      };
      std::vector<merged_data> merged;
      for (const auto& pr : pairs_) {
        const index_t i = pr.i, j = pr.j;  // i: lower id
        merged_data m;
        m.V = V[i] + V[j];                                   // eq. 74 (V = L^d)
        const vec<D> xij = in_.neighbours->displacement(x, i, j);
        m.x = merged_position(i, xij, V[j], m.V);            // eq. 72
        // eq. 73 (with the stored V′: V′u′ = ΣVu to rounding)
        m.u = (V[i] * u.col(i) + V[j] * u.col(j)) / m.V;
        const std::array<particle_view<D>, 2> pb{
            {{V[i], x.col(i), u.col(i)}, {V[j], vec<D>(x.col(i) + xij), u.col(j)}}};
        const std::array<particle_view<D>, 1> pa{{{m.V, m.x, m.u}}};
        const std::array<particle_id, 2> ids{id_of(i), id_of(j)};
        merge_event<D> ev;
        ev.parent_id = ids;
        ev.parent_index = {i, j};
        ev.r = xij.norm();
        ev.balance = led.record("merge", ids, pb, pa);
        led.count_merge();
        m.x = dom.wrap(m.x);
        const index_t first = std::min(i, j), second = std::max(i, j);
        merge_first[static_cast<std::size_t>(first)] = static_cast<index_t>(merged.size());
        merge_second[static_cast<std::size_t>(second)] = static_cast<index_t>(merged.size());
        merged.push_back(m);
        rep_.merge_events.push_back(ev);
      }
      for (std::size_t q = 0; q < merged.size(); ++q) {
        const index_t i = pairs_[q].i, j = pairs_[q].j;
        const index_t first = std::min(i, j), other = first == i ? j : i;
        average_fields(first, other, V[first], V[other], merged[q].V);
        x.col(first) = merged[q].x;
        u.col(first) = merged[q].u;
        V[first] = merged[q].V;
      }
      rep_.splits = static_cast<index_t>(rep_.split_events.size());
      rep_.merges = static_cast<index_t>(rep_.merge_events.size());
      if (rep_.splits == 0 && rep_.merges == 0) return std::move(rep_);

      // The one resize: survivors in order, a split's two children in its slot, a merge in its lower slot.
      std::vector<index_t> src;
      std::vector<std::uint8_t> born;
      src.reserve(static_cast<std::size_t>(n + rep_.splits));
      born.reserve(src.capacity());
      std::vector<index_t> first_slot_of_split(kids.size(), npos), slot_of_merge(merged.size(), npos);
      for (index_t i = 0; i < n; ++i) {
        const std::size_t is = static_cast<std::size_t>(i);
        if (split_of[is] != npos) {
          first_slot_of_split[static_cast<std::size_t>(split_of[is])] = static_cast<index_t>(src.size());
          src.insert(src.end(), {i, i});
          born.insert(born.end(), {1, 1});
        } else if (merge_first[is] != npos) {
          slot_of_merge[static_cast<std::size_t>(merge_first[is])] = static_cast<index_t>(src.size());
          src.push_back(i);
          born.push_back(1);
        } else if (merge_second[is] == npos) {
          src.push_back(i);
          born.push_back(0);
        }
      }
      rep_.resize = s_.gather(src, born);
      auto& x2 = s_.x();
      auto& u2 = s_.u();
      auto& V2 = s_.template get<field::volume>();
      auto& fl = s_.flags();
      for (std::size_t q = 0; q < kids.size(); ++q) {
        const index_t k0 = first_slot_of_split[q];
        for (int c = 0; c < 2; ++c) {
          const index_t k = k0 + c;
          x2.col(k) = kids[q].x[static_cast<std::size_t>(c)];
          u2.col(k) = kids[q].u[static_cast<std::size_t>(c)];
          V2[k] = kids[q].V;
          fl[static_cast<std::size_t>(k)] |= flag::split_marked;
          rep_.split_events[q].child[static_cast<std::size_t>(c)] = k;
          rep_.split_events[q].child_id[static_cast<std::size_t>(c)] = s_.ids()[static_cast<std::size_t>(k)];
        }
      }
      for (std::size_t q = 0; q < merged.size(); ++q) {
        const index_t k = slot_of_merge[q];
        fl[static_cast<std::size_t>(k)] |= flag::merge_marked;
        rep_.merge_events[q].merged = k;
        rep_.merge_events[q].merged_id = s_.ids()[static_cast<std::size_t>(k)];
      }
      // Global check: the resize changed ΣV and ΣVu by exactly what the events did (no particle lost or
      // counted twice).
      const index_t m = s_.n_real();
      for (index_t i = 0; i < m; ++i) {
        V1.add(V2[i]);
        for (int a = 0; a < D; ++a) M1[static_cast<std::size_t>(a)].add_product(V2[i], u2(a, i));
      }
      double ev_dV = 0.0, scale_u = 0.0;
      vec<D> ev_dVu = vec<D>::Zero();
      for (const auto& ev : rep_.split_events) {
        ev_dV += ev.balance.dV;
        ev_dVu += ev.balance.dVu;
      }
      for (const auto& ev : rep_.merge_events) {
        ev_dV += ev.balance.dV;
        ev_dVu += ev.balance.dVu;
      }
      for (index_t i = 0; i < m; ++i) scale_u += V2[i] * u2.col(i).norm();
      const double eps = std::numeric_limits<double>::epsilon();
      const double resV = V1.minus(V0) - ev_dV;
      vec<D> resU;
      for (int a = 0; a < D; ++a)
        resU[a] = M1[static_cast<std::size_t>(a)].minus(M0[static_cast<std::size_t>(a)]) - ev_dVu[a];
      if (!(std::abs(resV) <= p_.ledger.volume_ulp * eps * V0.value()) ||
          !(resU.norm() <= p_.ledger.momentum_ulp * eps * std::max(scale_u, 1e-300)))
        fail("split_merge: the resize changed ΣV by ", resV, " and ΣVu by ", resU.norm(),
             " more than the events did (a particle lost or duplicated)");
      return std::move(rep_);
    }

   private:
    struct split_choice {
      bool ok = false;
      refusal why = refusal::error_function;
      vec<D> t = vec<D>::Zero();
      double e = 1.0;
      bool contact_fallback = false;  // chosen by split_merge_params::wall_contact_fallback
    };
    struct pair_t {
      index_t i = npos, j = npos;  // i: lower id
    };
    struct edge {
      double r2;
      particle_id lo, hi;
      index_t i, j;  // i = index of lo
      int rank = 0;  // merge_partners::alike_first: 0 when both ask to merge, else 1
      bool operator<(const edge& o) const {
        if (rank != o.rank) return rank < o.rank;
        if (r2 != o.r2) return r2 < o.r2;
        if (lo != o.lo) return lo < o.lo;
        return hi < o.hi;
      }
    };

    void check_inputs() const {
      const index_t nt = s_.size();
      if (!in_.neighbours)
        fail("split_merge: inputs.neighbours is null (a neighbour list over the state is required)");
      if (in_.neighbours->rows() != nt)
        fail("split_merge: the neighbour list has ", in_.neighbours->rows(), " rows, the state ", nt,
             " particles (build it over real + ghosts of this state)");
      if (!in_.L) fail("split_merge: inputs.L is null (per-particle diameters are required)");
      if (!(std::isfinite(in_.wall_reach) && in_.wall_reach > 0.0))
        fail("split_merge: inputs.wall_reach = ", in_.wall_reach,
             ", accepted range (0, inf) (the wall model's alpha_w)");
      if (in_.L->size() != nt)
        fail("split_merge: inputs.L has ", in_.L->size(), " entries for ", nt, " particles");
      if (in_.normals && in_.normals->cols() != nt)
        fail("split_merge: inputs.normals has ", in_.normals->cols(), " columns for ", nt, " particles");
      if (in_.flags && static_cast<index_t>(in_.flags->size()) != nt)
        fail("split_merge: inputs.flags has ", in_.flags->size(), " entries for ", nt, " particles");
      const auto& V = s_.template get<field::volume>();
      for (index_t i = 0; i < s_.n_real(); ++i) {
        const double Li = (*in_.L)[i];
        if (!(std::isfinite(Li) && Li > 0.0) || !(std::isfinite(V[i]) && V[i] > 0.0))
          fail("split_merge: particle ", i, " (id ", id_of(i), ") has L = ", Li, ", V = ", V[i],
               ": both must be finite and > 0");
        const double Lv = D == 2 ? std::sqrt(V[i]) : std::cbrt(V[i]);
        if (!(std::abs(Li - Lv) <= 1e-10 * Lv))
          fail("split_merge: particle ", i, " (id ", id_of(i), ") has L = ", Li, " but V^(1/D) = ", Lv,
               ": the diameters must be those of the stored volumes");
      }
    }

    /// Chooses t for particle i (eqs. 67–69): the admissible candidate (e_i < α_e) with the smallest e_i,
    /// ties (|Δρ| ≤ 1e-12 ρ; e_i = 0 is a tie of all clear directions) broken by the larger clearance
    /// ρ = min_j r_i′j / L_ij over the neighbours within 2 L_ij + δ, then by the lower candidate index; the
    /// first in that order whose children pass the wall check.
    split_choice choose_direction(index_t i, const std::vector<vec<D>>& dirs,
                                  bool with_children = false) const {
      split_choice out;
      const auto& x = s_.x();
      const double Li = L(i);
      const double Lc = Pattern_::template child_ratio<D>() * Li;  // eq. 65
      const double delta = half_offset(i);                        // eq. 67
      const bool surface = (flag_of(i) & flag::surface) != 0;
      std::vector<vec<D>> tangents;
      const std::vector<vec<D>>* cand = &dirs;
      if (surface) {
        vec<D> nrm = vec<D>::Zero();
        if (in_.normals) nrm = in_.normals->col(i);
        const double nn = nrm.norm();
        if (!(std::isfinite(nn) && nn > 0.5 && nn < 2.0)) {
          out.why = refusal::degenerate_normal;
          return out;
        }
        tangents = tangent_directions<D>(vec<D>(nrm / nn), p_.n_theta);
        cand = &tangents;
      }
      // Neighbours close enough to matter: r_ij < 2 L_ij + δ.
      std::vector<std::pair<vec<D>, double>> near;
      for (const auto jj : in_.neighbours->neighbours(i)) {
        const index_t j = static_cast<index_t>(jj);
        if (j == i) continue;
        const vec<D> xij = in_.neighbours->displacement(x, i, j);
        // (The list has exactly s_.size() rows, checked in check_inputs, so j < done_.size() always holds;
        // ghost rows never split, and an earlier split's wall copies still stand for its parent:
        // conservative.)
        if (with_children && j < static_cast<index_t>(done_.size()) &&
            done_[static_cast<std::size_t>(j)] != npos) {
          // j splits in this call (decided before i): its children take its place (resolve_neighbour_splits).
          for (const vec<D>& xc : children_offsets(j, xij)) {
            const double Lij = 0.5 * (Li + Pattern_::template child_ratio<D>() * L(j));
            const double reach = 2.0 * Lij + delta;
            if (xc.squaredNorm() < reach * reach) near.emplace_back(xc, Lij);
          }
          continue;
        }
        const double Lij = 0.5 * (Li + L(j));  // eq. 69: L_ij = (L_i + L_j)/2 with the parent's L_i
        const double reach = 2.0 * Lij + delta;
        if (xij.squaredNorm() < reach * reach) near.emplace_back(xij, Lij);
      }
      const std::size_t nc = cand->size();
      std::vector<double> rho(nc, std::numeric_limits<double>::infinity());
      for (std::size_t c = 0; c < nc; ++c) {
        const vec<D> d = delta * (*cand)[c];
        double m = std::numeric_limits<double>::infinity();
        for (const auto& [xij, Lij] : near) {
          const double rp = (xij - d).norm() / Lij;  // child x_i + d
          const double rm = (xij + d).norm() / Lij;  // child x_i − d
          m = std::min(m, std::min(rp, rm));
        }
        rho[c] = m;
      }
      const auto e_of = [](double r) {
        return r >= 1.0 ? 0.0 : 1.0 - r;
      };  // eqs. 68–69: max_j e_ij = 1 − min ρ
      std::vector<std::uint8_t> out_of_play(nc, 0);
      bool any_admissible = false, lost_contact = false;
      const double reach = in_.walls ? in_.wall_reach * Li : 0.0;
      const bool contact = in_.walls && std::isfinite(p_.wall_contact) &&
                           in_.walls->signed_distance(vec<D>(x.col(i))) <= reach;
      // wall_contact_fallback: of the directions refused by the contact rule alone, the one whose nearer
      // child is nearest the wall (the first in the e_i order on ties), if that child is within
      // wall_reach · L′: the bound is one ulp above wall_reach · L′, so that one strict comparison admits the
      // first direction at that distance.
      std::size_t fallback = nc;
      double fallback_distance = std::nextafter(in_.wall_reach * Lc, std::numeric_limits<double>::infinity());
      for (;;) {
        std::size_t best = nc;
        for (std::size_t c = 0; c < nc; ++c) {
          if (out_of_play[c] || !(e_of(rho[c]) < p_.alpha_e)) continue;
          if (best == nc || better(rho[c], rho[best])) best = c;
        }
        if (best == nc) break;
        any_admissible = true;
        const vec<D> d = delta * (*cand)[best];
        if (in_.walls) {
          const auto& dom = in_.neighbours->dom();
          const double need = p_.wall_clearance * Lc;
          const double sp = in_.walls->signed_distance(dom.wrap(vec<D>(x.col(i) + d)));
          const double sm = in_.walls->signed_distance(dom.wrap(vec<D>(x.col(i) - d)));
          if (!(sp >= need && sm >= need)) {
            out_of_play[best] = 1;
            continue;
          }
          const double nearer = std::min(sp, sm);  // the nearer child's distance from the wall
          if (contact && !(nearer <= p_.wall_contact * Lc)) {
            out_of_play[best] = 1;
            lost_contact = true;
            if (p_.wall_contact_fallback && nearer < fallback_distance) {
              fallback = best;
              fallback_distance = nearer;
            }
            continue;
          }
        }
        out.ok = true;
        out.t = (*cand)[best];
        out.e = e_of(rho[best]);
        return out;
      }
      if (fallback != nc) {
        out.ok = true;
        out.t = (*cand)[fallback];
        out.e = e_of(rho[fallback]);
        out.contact_fallback = true;
        return out;
      }
      out.why = !any_admissible ? refusal::error_function
                : lost_contact  ? refusal::wall_contact
                                : refusal::wall;
      return out;
    }
    /// δ = (α_t/2) L′ (eq. 67, L′ of eq. 65): the distance of each child from its parent.
    double half_offset(index_t i) const {
      return 0.5 * p_.alpha_t * (Pattern_::template child_ratio<D>() * L(i));
    }
    /// Offsets from particle i of the two children of j (decided split k = done_[j]), given x_ij.
    std::array<vec<D>, 2> children_offsets(index_t j, const vec<D>& xij) const {
      const split_choice& cj = choice_[static_cast<std::size_t>(done_[static_cast<std::size_t>(j)])];
      const vec<D> dj = half_offset(j) * cj.t;  // eq. 67
      return {vec<D>(xij + dj), vec<D>(xij - dj)};
    }

    /// Neighbouring splits in one call (ours; the paper is silent). Eqs. 68–69 measure a candidate's
    /// children against the neighbours as they are, so when two neighbours split in the same step each
    /// child is checked against the other's parent, which is about to vanish, and not against its children:
    /// measured, two second-generation children 0.27 L apart at a 3D wall (docs/resolution.md). The
    /// choices are therefore revisited in increasing id order (deterministic, independent of threads and
    /// input order): a split whose children come within (1 − α_e) L_ij of the children of a neighbour
    /// decided before it chooses its direction again with those children in place of that neighbour
    /// (counted in `redirected`), or is refused (`neighbour_children`) and may split in a later step.
    void resolve_neighbour_splits(const std::vector<vec<D>>& dirs) {
      done_.assign(static_cast<std::size_t>(s_.size()), npos);
      std::vector<std::size_t> order;
      for (std::size_t k = 0; k < choice_.size(); ++k)
        if (choice_[k].ok) order.push_back(k);
      if (order.size() < 2) {
        for (std::size_t k : order) done_[static_cast<std::size_t>(split_cand_[k])] = static_cast<index_t>(k);
        return;
      }
      std::sort(order.begin(), order.end(),
                [&](std::size_t a, std::size_t b) { return id_of(split_cand_[a]) < id_of(split_cand_[b]); });
      const auto& x = s_.x();
      for (const std::size_t k : order) {
        const index_t i = split_cand_[k];
        const double Li = L(i);
        const vec<D> d = half_offset(i) * choice_[k].t;
        bool clash = false;
        for (const auto jj : in_.neighbours->neighbours(i)) {
          if (clash) break;
          const index_t j = static_cast<index_t>(jj);
          if (j == i || j >= static_cast<index_t>(done_.size()) || done_[static_cast<std::size_t>(j)] == npos)
            continue;
          const double Lij = 0.5 * (Li + Pattern_::template child_ratio<D>() * L(j));
          for (const vec<D>& xc : children_offsets(j, in_.neighbours->displacement(x, i, j)))
            if (std::min((xc - d).norm(), (xc + d).norm()) / Lij <= 1.0 - p_.alpha_e) clash = true;
        }
        if (clash) {
          split_choice c = choose_direction(i, dirs, true);
          if (!c.ok) {
            choice_[k] = split_choice{};
            choice_[k].why = refusal::neighbour_children;
            continue;
          }
          choice_[k] = c;
          ++rep_.redirected;
        }
        done_[static_cast<std::size_t>(i)] = static_cast<index_t>(k);
      }
    }

    static bool better(double a, double b) {
      if (std::isinf(a) || std::isinf(b)) return a > b;
      return a > b * (1.0 + tie);
    }

    /// Eq. 72 in the periodic-safe form x′ = x_i + (V_j/V′) x_ij (x_ij by the minimum image).
    vec<D> merged_position(index_t i, const vec<D>& xij, double Vj, double Vm) const {
      return vec<D>(s_.x().col(i) + (Vj / Vm) * xij);
    }

    /// Iterated mutual-nearest pairing (see the file comment).
    void pair_up(auto e) {
      const index_t n = s_.n_real();
      const auto& x = s_.x();
      const auto& V = s_.template get<field::volume>();
      std::vector<index_t> cand;
      for (index_t i = 0; i < n; ++i)
        if (want_[static_cast<std::size_t>(i)] == want::merge && eligible_[static_cast<std::size_t>(i)])
          cand.push_back(i);
      const auto partner_ok = [&](index_t j) {
        return j < n && kind_of(j) == kind::fluid && eligible_[static_cast<std::size_t>(j)] &&
               want_[static_cast<std::size_t>(j)] != want::split &&
               (p_.partners != merge_partners::both_ask || want_[static_cast<std::size_t>(j)] == want::merge);
      };
      std::vector<std::vector<edge>> per(cand.size());
      for_each_particle(e, static_cast<index_t>(cand.size()), [&](index_t k) {
        const index_t i = cand[static_cast<std::size_t>(k)];
        auto& out = per[static_cast<std::size_t>(k)];
        for (const auto jj : in_.neighbours->neighbours(i)) {
          const index_t j = static_cast<index_t>(jj);
          if (j == i || !partner_ok(j)) continue;
          const vec<D> xij = in_.neighbours->displacement(x, i, j);
          const double Lij = 0.5 * (L(i) + L(j));
          const double r2 = xij.squaredNorm();
          const double lim = p_.alpha_r * Lij;
          if (!(r2 < lim * lim)) continue;
          const bool i_lo = id_of(i) < id_of(j);
          const int rank =
              p_.partners == merge_partners::alike_first && want_[static_cast<std::size_t>(j)] != want::merge
                  ? 1
                  : 0;
          out.push_back(
              {r2, i_lo ? id_of(i) : id_of(j), i_lo ? id_of(j) : id_of(i), i_lo ? i : j, i_lo ? j : i, rank});
        }
      });
      std::vector<edge> edges;
      std::vector<std::uint8_t> had_edge(static_cast<std::size_t>(n), 0),
          had_valid(static_cast<std::size_t>(n), 0);
      for (std::size_t k = 0; k < cand.size(); ++k) {
        if (!per[k].empty()) had_edge[static_cast<std::size_t>(cand[k])] = 1;
        edges.insert(edges.end(), per[k].begin(), per[k].end());
      }
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end(),
                              [](const edge& a, const edge& b) {
                                return a.lo == b.lo && a.hi == b.hi && a.rank == b.rank;
                              }),
                  edges.end());
      // The merge-then-split guard (sequential: it calls the target callable).
      const bool ctx = p_.target_diameter.wants_context();
      std::vector<edge> valid;
      for (const edge& ed : edges) {
        const double Vm = V[ed.i] + V[ed.j];
        const double Lm = D == 2 ? std::sqrt(Vm) : std::cbrt(Vm);  // eq. 74
        target_point<D> tp;
        tp.x = in_.neighbours->dom().wrap(
            merged_position(ed.i, in_.neighbours->displacement(x, ed.i, ed.j), V[ed.j], Vm));
        if (ctx) {
          tp.wall_distance = wall_distance(tp.x);
          tp.surface_distance = std::min(surface_distance(ed.i), surface_distance(ed.j));
        }
        const double Ls = p_.target_diameter.checked(tp, "split_merge", [&] {
          return mpskit::detail::concat("the merged position ", fmt(tp.x), " of ids ", ed.lo, " and ", ed.hi);
        });
        if (Trigger_::template decide<D>(Ls, Lm) == want::split) continue;
        had_valid[static_cast<std::size_t>(ed.i)] = had_valid[static_cast<std::size_t>(ed.j)] = 1;
        valid.push_back(ed);
      }
      // Greedy on the strict order ((rank,) r², lo id, hi id) = iterated mutual nearest neighbours (within
      // each rank).
      std::vector<std::uint8_t> taken(static_cast<std::size_t>(n), 0);
      for (const edge& ed : valid) {
        if (taken[static_cast<std::size_t>(ed.i)] || taken[static_cast<std::size_t>(ed.j)]) continue;
        taken[static_cast<std::size_t>(ed.i)] = taken[static_cast<std::size_t>(ed.j)] = 1;
        pairs_.push_back({ed.i, ed.j});
      }
      for (index_t i : cand) {
        const std::size_t is = static_cast<std::size_t>(i);
        if (taken[is]) continue;
        const refusal r = !had_edge[is]    ? refusal::no_partner
                          : !had_valid[is] ? refusal::would_split
                                           : refusal::partner_taken;
        ++rep_.refused[static_cast<std::size_t>(r)];
      }
    }

    /// Volume-weighted average of every scalar and vector field except position, velocity and volume (they
    /// are intensive: pressure, temporary velocity, ...), written into slot a; other fields keep slot a's.
    void average_fields(index_t a, index_t b, double Va, double Vb, double Vm) {
      particle_state<D, Fields>::for_each_field([&](auto tag) {
        using T = decltype(tag);
        if constexpr (std::is_same_v<T, field::position> || std::is_same_v<T, field::velocity> ||
                      std::is_same_v<T, field::volume>) {
          return;
        } else if constexpr (T::shape == field_shape::scalar) {
          auto& f = s_.template get<T>();
          f[a] = (Va * f[a] + Vb * f[b]) / Vm;
        } else if constexpr (T::shape == field_shape::vector) {
          auto& f = s_.template get<T>();
          f.col(a) = ((Va * f.col(a) + Vb * f.col(b)) / Vm).eval();
        }
      });
    }

    double wall_distance(const vec<D>& p) const {
      return in_.walls ? in_.walls->signed_distance(p) : std::numeric_limits<double>::infinity();
    }
    double surface_distance(index_t i) const {
      if (flag_of(i) & flag::surface) return 0.0;
      double best = std::numeric_limits<double>::infinity();
      for (const auto jj : in_.neighbours->neighbours(i)) {
        const index_t j = static_cast<index_t>(jj);
        if (j < s_.n_real() && (flag_of(j) & flag::surface))
          best = std::min(best, in_.neighbours->displacement(s_.x(), i, j).norm());
      }
      return best;
    }
    static std::string fmt(const vec<D>& v) {
      std::string s = "(";
      for (int a = 0; a < D; ++a) s += mpskit::detail::concat(a ? ", " : "", v[a]);
      return s + ")";
    }
    double L(index_t i) const { return (*in_.L)[i]; }
    kind kind_of(index_t i) const { return s_.kinds()[static_cast<std::size_t>(i)]; }
    particle_id id_of(index_t i) const { return s_.ids()[static_cast<std::size_t>(i)]; }
    flag::type flag_of(index_t i) const {
      return in_.flags ? (*in_.flags)[static_cast<std::size_t>(i)] : s_.flags()[static_cast<std::size_t>(i)];
    }

    state& s_;
    const split_merge_inputs<D>& in_;
    const split_merge_params<D>& p_;
    std::vector<double> Lt_;
    std::vector<want> want_;
    std::vector<std::uint8_t> eligible_;
    std::vector<index_t> split_cand_;
    std::vector<split_choice> choice_;
    std::vector<index_t> done_;  ///< per particle: its decided split (slot in choice_), npos otherwise
                                 ///< (resolve_neighbour_splits)
    std::vector<pair_t> pairs_;
    split_merge_report<D> rep_{};
  };
};

}  // namespace mpskit::resolution
