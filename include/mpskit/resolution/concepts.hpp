#pragma once
/// \file resolution/concepts.hpp
/// \brief Concepts of the resolution area: a Trigger decides from the target diameter L* and the diameter L
/// whether a particle wants to split or merge; a SplitPattern says into how many children a particle splits.
/// And the one wall model the split/merge method refuses (wall::dummy_layers, Tanaka 2018 §4.5.1).
#include <concepts>
#include <cstdint>
#include <type_traits>

#include "mpskit/wall/dummy_layers.hpp"

namespace mpskit::resolution {

/// What the trigger asks of one particle.
enum class want : std::uint8_t {
  none = 0,   ///< keep the particle
  split = 1,  ///< the target is much smaller than the particle
  merge = 2   ///< the target is much larger than the particle
};

/// A trigger: `T::template decide<D>(L_target, L)` → want (2D and 3D).
template <class T>
concept Trigger = requires(double a, double b) {
  { T::template decide<2>(a, b) } -> std::same_as<want>;
  { T::template decide<3>(a, b) } -> std::same_as<want>;
};

/// A split pattern: `P::children` particles of volume V / children each, of diameter
/// `P::template child_ratio<D>()` · L (only two_way exists).
template <class P>
concept SplitPattern = requires {
  { P::children } -> std::convertible_to<int>;
  { P::template child_ratio<2>() } -> std::convertible_to<double>;
  { P::template child_ratio<3>() } -> std::convertible_to<double>;
} && (P::children >= 2);

/// Wall models split/merge accepts. wall::dummy_layers is refused: smaller fluid particles leak between
/// larger wall particles once the size difference is large enough (Tanaka 2018 §4.5.1, second paragraph),
/// and wall particles of one size cannot follow the fluid's resolution.
template <class Walls>
concept ResolutionCompatibleWalls = !std::is_same_v<std::remove_cvref_t<Walls>, wall::dummy_layers>;

/// For a stepper: `require_compatible_walls<Scene::walls>();` fails to compile with a readable message.
template <class Walls>
constexpr void require_compatible_walls() {
  static_assert(
      ResolutionCompatibleWalls<Walls>,
      "mpskit: resolution::split_merge cannot run with wall::dummy_layers: small fluid particles leak "
      "between larger wall particles (Tanaka 2018 §4.5.1); use polygon walls (wall::imaginary)");
}

}  // namespace mpskit::resolution
