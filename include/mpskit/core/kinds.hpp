#pragma once
/// \file core/kinds.hpp
/// \brief Persistent particle kinds, per-step flag bits and ghost roles (ARCHITECTURE.md §3).
#include <cstdint>

namespace mpskit {

/// What a particle is, for its whole life.
enum class kind : std::uint8_t {
  fluid = 0,              ///< fluid particle
  wall = 1,               ///< wall particle (in the PPE; first layer of a dummy-layer wall)
  dummy = 2,              ///< dummy particle (outer wall layers, Neumann pressure)
  body = 3,               ///< particle of a rigid body
  pressure_boundary = 4,  ///< pressure inflow/outflow boundary particle
};

/// Human-readable name of a kind.
constexpr const char* name(kind k) {
  switch (k) {
    case kind::fluid: return "fluid";
    case kind::wall: return "wall";
    case kind::dummy: return "dummy";
    case kind::body: return "body";
    case kind::pressure_boundary: return "pressure_boundary";
  }
  return "unknown";
}

/// Per-step flag bits, recomputed every step (never persistent state).
namespace flag {
using type = std::uint32_t;
inline constexpr type surface = 1u << 0;       ///< on the free surface (Dirichlet p = 0)
inline constexpr type isolated = 1u << 1;      ///< isolated (excluded from operators, moves ballistically)
inline constexpr type split_marked = 1u << 2;  ///< marked for splitting this step
inline constexpr type merge_marked = 1u << 3;  ///< marked for merging this step
inline constexpr type guarded = 1u << 4;       ///< put back by the wall-crossing guard this step
inline constexpr type degenerate = 1u << 5;    ///< operator fell back (degenerate neighbourhood)
}  // namespace flag

/// Role of a ghost (entries in the ghost range, regenerated every step).
enum class ghost_role : std::uint8_t {
  none = 0,        ///< a real particle
  imaginary = 1,   ///< copy on a polygon wall (Tanaka 2018 §4.5.1)
  fictitious = 2,  ///< BMMR fictitious fine particle (bmmr.md §3.4)
  mirror = 3,      ///< mirror image (reserved; ERP stores none)
  pressure = 4,  ///< pressure-boundary particle placed in advance on an in/outflow face (Tanaka 2018 §4.5.2)
};

}  // namespace mpskit
