#pragma once
// A scene with BiCGSTAB-ILU(0) (ppe::bicgstab_ilu0, docs/performance.md "ILU(0) for the LSMPS PPE") in place
// of its solver: the LSMPS dam-break test with ILU(0) (label dam_break_lsmps), bench_ilu0 and the obstacle
// reporter's `--solver ilu0`. Its own header so that translation units that do not name it do not parse
// ILU(0).
#include "mpskit/ppe/ilu0.hpp"
#include "mpskit/scene.hpp"

namespace mpskit::cases {

/// Scene with its PPE solver replaced by BiCGSTAB-ILU(0); everything else (resolution, walls, ...) Scene's.
template <class Scene = lsmps_defaults<2>>
struct with_ilu0 : Scene {
  using solver = ppe::bicgstab_ilu0;
};

/// The default 2D LSMPS scene with BiCGSTAB-ILU(0).
using tanaka_ilu0_scene = with_ilu0<>;

}  // namespace mpskit::cases
