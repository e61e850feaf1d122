#pragma once
/// \file surface/concepts.hpp
/// \brief Concepts of the free-surface area (docs/surface.md): a `SurfaceDetector` sets or clears
/// `flag::surface` (core/kinds.hpp) on candidate particles from a neighbour list and the supports and
/// reference constants of a classic MPS operator (`ClassicSupports`, modelled by op::mps).
#include <concepts>
#include <cstdint>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::surface {

/// Which of the operator's two supports a detector reads (classic MPS: small 2.1 l0, large 3.1 l0).
enum class support_choice : std::uint8_t {
  small,  ///< the gradient / number-density radius (op.re_small(), op.n0_small())
  large,  ///< the Laplacian radius (op.re_large(), op.n0_large())
};

/// Every particle counts as a neighbour (default `participates` predicate).
struct all_participate {
  constexpr bool operator()(index_t) const noexcept { return true; }
};

/// What a detector needs from an operator: dimension, kernel, l0, both supports with their radius
/// ratios, radii and reference number densities (op::mps models it).
template <class Op>
concept ClassicSupports = requires(const Op& op) {
  requires Dimension<Op::dim>;
  requires Kernel<typename Op::kernel_type>;
  { op.params().l0 } -> std::convertible_to<double>;
  { op.params().re_small } -> std::convertible_to<double>;
  { op.params().re_large } -> std::convertible_to<double>;
  { op.re_small() } -> std::convertible_to<double>;
  { op.re_large() } -> std::convertible_to<double>;
  { op.n0_small() } -> std::convertible_to<double>;
  { op.n0_large() } -> std::convertible_to<double>;
  { op.small_support() } -> std::same_as<search::support<search::uniform_radius>>;
  { op.large_support() } -> std::same_as<search::support<search::uniform_radius>>;
};

/// A free-surface detector for operator Op: `s.detect(exec, x, list, op, participates, candidate,
/// flags)` sets or clears flag::surface where candidate[i] != 0 and leaves every other bit and particle
/// alone; `s.value(x, list, op, participates, i)` is the per-particle quantity it thresholds and
/// `s.threshold(op)` the number it is compared with (diagnostics); `S::params_type` holds its numbers.
template <class S, class Op>
concept SurfaceDetector =
    ClassicSupports<Op> &&
    requires(const S& s, const Op& op, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl,
             std::span<const std::uint8_t> candidate, std::vector<flag::type>& flags, index_t i) {
      typename S::params_type;
      { s.params() } -> std::convertible_to<const typename S::params_type&>;
      s.detect(exec::seq{}, x, nl, op, all_participate{}, candidate, flags);
      s.detect(exec::par{}, x, nl, op, all_participate{}, candidate, flags);
      { s.value(x, nl, op, all_participate{}, i) } -> std::convertible_to<double>;
      { s.threshold(op) } -> std::convertible_to<double>;
    };

}  // namespace mpskit::surface
