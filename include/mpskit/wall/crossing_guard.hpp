#pragma once
/// \file wall/crossing_guard.hpp
/// \brief Wall-crossing guard (issue #7 item 6; a documented deviation: Tanaka 2018 has no such
/// mechanism): a particle whose move x_old → x_new enters a wall element is put back at ε L_i on the
/// fluid side of the crossing point, loses its velocity component normal to the wall (relative to the
/// wall's velocity), is flagged `flag::guarded` and counted. See docs/walls.md.
#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/geometry/motion.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/geometry/wall_collection.hpp"
#include "mpskit/wall/detail/wall_sets.hpp"

namespace mpskit::wall {

/// Parameters of the wall-crossing guard.
struct guard_params {
  /// ε: a guarded particle is put back at ε L_i from the wall on the fluid side. Range (0, 1).
  double epsilon = 0.01;

  /// Throws mpskit::error naming the bad value and its accepted range.
  void validate() const {
    if (!(epsilon > 0.0 && epsilon < 1.0))
      fail("wall::guard_params: epsilon = ", epsilon, ", accepted range (0, 1)");
  }
};

namespace detail {

template <int D>
struct entered {
  geometry::crossing<D> c;
  index_t set = npos;
};

/// First element entered on a → b over all sets (smallest t, ties to the lower set); `poses` (one per
/// set, or null) are the sets' previous poses for moving walls.
template <int D>
std::optional<entered<D>> first_entered(const set_view<D>& sets, const vec<D>& a, const vec<D>& b,
                                        const std::vector<geometry::rigid_transform<D>>* poses) {
  std::optional<entered<D>> best;
  for (index_t k = 0; k < sets.size(); ++k) {
    const std::optional<geometry::crossing<D>> c =
        poses ? sets[k].first_entering_crossing(a, b, (*poses)[static_cast<std::size_t>(k)])
              : sets[k].first_entering_crossing(a, b);
    if (c && (!best || c->t < best->c.t)) best = entered<D>{*c, k};
  }
  return best;
}

template <int D, Execution E>
index_t guard_crossings(E e, const points<D>& x_old, points<D>& x_new, points<D>& u, const Eigen::VectorXd& L,
                        index_t n, const set_view<D>& sets, const guard_params& p,
                        std::vector<flag::type>* flags,
                        const std::vector<geometry::rigid_transform<D>>* poses) {
  p.validate();
  if (n < 0) fail("wall::guard_crossings: n = ", n, ", accepted range [0, inf)");
  if (x_old.cols() < n || x_new.cols() < n || u.cols() < n || L.size() < n)
    fail("wall::guard_crossings: n = ", n, " particles but x_old has ", x_old.cols(), ", x_new ",
         x_new.cols(), ", u ", u.cols(), " columns and L ", L.size(), " entries");
  if (flags && static_cast<index_t>(flags->size()) < n)
    fail("wall::guard_crossings: flags has ", flags->size(), " entries for n = ", n, " particles");
  if (poses && static_cast<index_t>(poses->size()) != sets.size())
    fail("wall::guard_crossings: ", poses->size(), " previous poses for ", sets.size(), " polygon sets");
  check_diameters("wall::guard_crossings", L, n);
  std::vector<char> hit(static_cast<std::size_t>(n), 0);
  for_each_particle(e, n, [&](index_t i) {
    vec<D> a = x_old.col(i);
    const vec<D> b = x_new.col(i);
    const std::optional<entered<D>> c = first_entered<D>(sets, a, b, poses);
    if (!c) return;
    if (poses) {  // the start point as carried by the crossed set (the segment that was tested)
      const geometry::rigid_transform<D>& prev = (*poses)[static_cast<std::size_t>(c->set)];
      const vec<D> a_ref = prev.rotation.transpose() * (a - prev.translation);
      a = sets[c->set].pose().apply(a_ref);
    }
    const vec<D> n_w = c->c.normal;
    // Put back at ε L_i along the crossed element's fluid-side normal from the crossing point. If that
    // point is itself behind another element (a corner narrower than ε L), keep the start point.
    vec<D> back = c->c.point + p.epsilon * L[i] * n_w;
    if (first_entered<D>(sets, a, back, nullptr)) back = a;
    x_new.col(i) = back;
    // Remove the normal component of the velocity relative to the wall: (u − v_w)·n = 0 afterwards.
    const vec<D> v_w = sets[c->set].velocity(c->c.point);
    const double un = (u.col(i) - v_w).dot(n_w);
    u.col(i) -= un * n_w;
    if (flags) (*flags)[static_cast<std::size_t>(i)] |= flag::guarded;
    hit[static_cast<std::size_t>(i)] = 1;
  });
  index_t count = 0;
  for (char h : hit) count += h;
  return count;
}

}  // namespace detail

/// Wall-crossing guard over particles [0, n): every move x_old → x_new that enters a wall element is
/// undone to ε L_i in front of the crossing point, (u − v_wall)·n is removed, flag::guarded is set
/// (flags, if given, has at least n entries; other bits are kept). Returns the number of guarded
/// particles. Walls are tested in their current pose (fixed walls, or slow motion).
template <int D, Execution E>
index_t guard_crossings(E e, const points<D>& x_old, points<D>& x_new, points<D>& u, const Eigen::VectorXd& L,
                        index_t n, const geometry::polygon_set<D>& walls, const guard_params& p,
                        std::vector<flag::type>* flags = nullptr) {
  return detail::guard_crossings<D>(e, x_old, x_new, u, L, n, detail::view_of(walls), p, flags, nullptr);
}

/// The same over several polygon sets.
template <int D, Execution E>
index_t guard_crossings(E e, const points<D>& x_old, points<D>& x_new, points<D>& u, const Eigen::VectorXd& L,
                        index_t n, const geometry::wall_collection<D>& walls, const guard_params& p,
                        std::vector<flag::type>* flags = nullptr) {
  return detail::guard_crossings<D>(e, x_old, x_new, u, L, n, detail::view_of(walls), p, flags, nullptr);
}

/// Sequential form (the interface of issue #7's stepper); identical results to exec::par.
template <int D>
index_t guard_crossings(const points<D>& x_old, points<D>& x_new, points<D>& u, const Eigen::VectorXd& L,
                        index_t n, const geometry::polygon_set<D>& walls, const guard_params& p,
                        std::vector<flag::type>* flags = nullptr) {
  return guard_crossings<D>(exec::seq{}, x_old, x_new, u, L, n, walls, p, flags);
}

/// Sequential form over several polygon sets.
template <int D>
index_t guard_crossings(const points<D>& x_old, points<D>& x_new, points<D>& u, const Eigen::VectorXd& L,
                        index_t n, const geometry::wall_collection<D>& walls, const guard_params& p,
                        std::vector<flag::type>* flags = nullptr) {
  return guard_crossings<D>(exec::seq{}, x_old, x_new, u, L, n, walls, p, flags);
}

/// Moving walls: `previous_pose` is the set's pose at the start of the step; x_old is carried with the
/// wall to the current pose before the test (polygon_set::first_entering_crossing, three arguments),
/// so a particle at rest swept by a moving wall is caught.
template <int D, Execution E>
index_t guard_crossings_moving(E e, const points<D>& x_old, points<D>& x_new, points<D>& u,
                               const Eigen::VectorXd& L, index_t n, const geometry::polygon_set<D>& walls,
                               const geometry::rigid_transform<D>& previous_pose, const guard_params& p,
                               std::vector<flag::type>* flags = nullptr) {
  const std::vector<geometry::rigid_transform<D>> poses{previous_pose};
  return detail::guard_crossings<D>(e, x_old, x_new, u, L, n, detail::view_of(walls), p, flags, &poses);
}

}  // namespace mpskit::wall
