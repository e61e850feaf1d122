#pragma once
/// \file scene.hpp
/// \brief Scene composition: a scene is a type naming its policies (ARCHITECTURE.md §2). `defaults<D>`
/// names every policy; a user scene derives from it and overrides what it changes:
///
///     struct my_scene : mpskit::defaults<2> { using source = mpskit::ppe::mixed; };
///     mpskit::simulation<my_scene> sim{params, initial_state};
///
/// Inside a scene derived from `defaults`, spell policies fully qualified (`mpskit::surface::npcd`, not
/// `surface::npcd`): the member names `kernel`, `op`, `surface`, ... hide the namespaces of the same name.
///
/// The defaults are the single-resolution classic MPS of the BMMR paper (bmmr.md §2): quadratic kernel
/// at 2.1 / 3.1 l0, TCPI source with artificial compressibility, NPCD surface detection, Lee et al.'s
/// collision model, CG with incomplete Cholesky, wall + dummy layers.
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"
#include "mpskit/ppe/sources.hpp"
#include "mpskit/regularize/collision.hpp"
#include "mpskit/scheme/semi_implicit.hpp"
#include "mpskit/surface/npcd.hpp"
#include "mpskit/wall/dummy_layers.hpp"

namespace mpskit {

/// Every policy of a scene, with its default.
template <int D>
  requires Dimension<D>
struct defaults {
  static constexpr int dim = D;                            ///< spatial dimension
  using kernel = mpskit::kernel::quadratic;                ///< weight function (Tanaka eq. 29)
  using op = mpskit::op::mps<D, kernel>;                   ///< classic MPS operators
  using source = mpskit::ppe::tcpi;                        ///< PPE source (bmmr.md §2.10)
  using solver = mpskit::ppe::cg_ichol;                    ///< linear solver (symmetric PPE)
  using surface = mpskit::surface::npcd;                   ///< free-surface detection (bmmr.md §2.7)
  using collision = mpskit::regularize::collision;         ///< collision model (bmmr.md §2.6)
  using shifting = mpskit::scheme::no_regularization;      ///< no shifting by default
  using walls = mpskit::wall::dummy_layers;                ///< wall + dummy layers
};

/// The stepper of a scene (the semi-implicit projection scheme for now).
template <class Scene>
using simulation = scheme::semi_implicit<Scene>;

}  // namespace mpskit
