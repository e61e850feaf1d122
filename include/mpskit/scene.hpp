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
#include "mpskit/op/lsmps_a.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/ppe/eigen_iterative.hpp"
#include "mpskit/ppe/sources.hpp"
#include "mpskit/regularize/collision.hpp"
#include "mpskit/ppe/det_f.hpp"
#include "mpskit/scheme/lsmps_semi_implicit.hpp"
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
  /// The stepper that runs the scene.
  template <class Scene>
  using stepper = mpskit::scheme::semi_implicit<Scene>;
};

/// The classic scheme's quiet configuration (docs/solver.md, issue #4): defaults<D> with the mixed PPE
/// source (Tanaka eq. 25, α_p = 0.01); run it with scheme::quiet_params<D>() (corrected pressure gradient,
/// one-sided-band velocity filter ε = 0.1, a deviation). Not the default: ε acts per step and wall loads
/// are read from the plain pair form (docs/solver.md).
template <int D>
struct quiet_defaults : defaults<D> {
  using source = mpskit::ppe::mixed;  ///< PPE source (Tanaka eq. 25)
};

/// Tanaka, Cardoso & Bahai 2018's single-resolution LSMPS scheme (scheme/lsmps_semi_implicit.hpp): LSMPS
/// type A of order 2, det F source, BiCGSTAB with Jacobi (the PPE is not symmetric), geometric surface
/// detection, polygon walls with imaginary particles, Tanaka's shifting.
template <int D>
  requires Dimension<D>
struct lsmps_defaults {
  static constexpr int dim = D;                            ///< spatial dimension
  using kernel = mpskit::kernel::quadratic;                ///< Tanaka eq. 29
  using op = mpskit::op::lsmps_a<D, 2, kernel>;            ///< LSMPS type A, second order (eqs. 41–46)
  using source = mpskit::ppe::det_f;                       ///< det F = c′ (eqs. 55–63)
  /// BiCGSTAB + Jacobi (3.4× faster than ILUT on the Taylor–Green PPE)
  using solver = mpskit::ppe::bicgstab_jacobi;
  using surface = mpskit::surface::geometric_detector;     ///< §4.6, both cone tests
  using shifting = mpskit::regularize::tanaka_shift;       ///< eqs. 93–100
  using walls = mpskit::wall::imaginary;                   ///< polygons, copies on the boundary (§4.5.1)
  /// The stepper that runs the scene.
  template <class Scene>
  using stepper = mpskit::scheme::lsmps_semi_implicit<Scene>;
};

/// The stepper of a scene: `Scene::stepper<Scene>` (semi_implicit for `defaults`, lsmps_semi_implicit for
/// `lsmps_defaults`).
template <class Scene>
using simulation = typename Scene::template stepper<Scene>;

}  // namespace mpskit
