#pragma once
// The scene of Tanaka's dam break with SparseLU behind the default BiCGSTAB-Jacobi (ppe::with_fallback,
// docs/run.md "A direct fallback"): `tanaka_dam_break --fallback` and `bench_impact_ensemble --fallback`. Its
// own header so that the test translation units that run the dam break (cases/tanaka_dam_break_run.hpp) do
// not parse SparseLU.
#include "mpskit/ppe/fallback.hpp"
#include "mpskit/ppe/sparse_lu.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// The default 2D scene (lsmps_defaults<2>) whose PPE solver falls back to SparseLU when BiCGSTAB-Jacobi
/// fails.
struct tanaka_fallback_scene : lsmps_defaults<2> {
  using solver = ppe::with_fallback<ppe::bicgstab_jacobi, ppe::sparse_lu>;
};

}  // namespace mpskit::cases
