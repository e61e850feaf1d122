#pragma once
/// \file scheme/detail/resolution_stage.hpp
/// \brief The resolution stage of the LSMPS stepper (issue #9 item 5, docs/resolution.md "In the LSMPS
/// stepper"): `Scene::resolution` (default resolution::uniform) and one call of split_merge at the end of a
/// step on that step's list, diameters, normals and flags, then one resize. Kept out of the stepper's file.
#include <array>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/geometry/polygon_set.hpp"
#include "mpskit/resolution/concepts.hpp"
#include "mpskit/scheme/detail/component_fits.hpp"
#include "mpskit/resolution/ledger.hpp"
#include "mpskit/resolution/split_merge.hpp"
#include "mpskit/resolution/uniform.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::scheme::detail {

/// Scene::resolution if the scene names one, else resolution::uniform.
template <class Scene>
struct scene_resolution {
  using type = resolution::uniform;
};
template <class Scene>
  requires requires { typename Scene::resolution; }
struct scene_resolution<Scene> {
  using type = typename Scene::resolution;
};
template <class Scene>
using scene_resolution_t = typename scene_resolution<Scene>::type;

/// True for resolution::split_merge<Trigger, Pattern>.
template <class R>
struct is_split_merge : std::false_type {};
template <class T, class P>
struct is_split_merge<resolution::split_merge<T, P>> : std::true_type {};

/// Runs split/merge R on the stepper's data at the end of a step. x_k: the real particles' positions at the
/// start of the step (where the operator's moments were computed), so ⟨∇u⟩ of eq. 70 is evaluated with the
/// same positions as the moments; copies keep theirs. The state's flags (or `flags`, when given) carry the
/// step's surface/isolated bits.
template <class R, int D, class Fields, class Op, class Participates>
resolution::split_merge_report<D> run_resolution_stage(
    particle_state<D, Fields>& s, const search::neighbour_list<D>& nl, const Eigen::VectorXd& L,
    const points<D>& normals, const geometry::polygon_set<D>* walls, const points<D>& x_k, const Op& op,
    const Participates& participates, const resolution::split_merge_params<D>& p,
    resolution::conservation_ledger<D>& ledger, const std::vector<flag::type>* flags = nullptr,
    double wall_reach = 1.0) {
  const index_t n = s.n_real();
  points<D> xg;  // positions of the moments (built on the first split only)
  std::array<Eigen::VectorXd, D> comp;
  bool ready = false;
  const auto grad_u = [&](index_t i) {
    if (!ready) {
      xg = s.x();
      xg.leftCols(n) = x_k.leftCols(n);
      for (int a = 0; a < D; ++a) comp[static_cast<std::size_t>(a)] = s.u().row(a).transpose();
      ready = true;
    }
    return component_gradients(op, xg, nl, i, comp, participates);
  };
  const resolution::split_merge_inputs<D> in{&nl, &L, &normals, flags, walls, wall_reach};
  return R::apply(exec::par{}, s, in, p, grad_u, &ledger);
}

}  // namespace mpskit::scheme::detail
