#pragma once
/// \file kernel/concepts.hpp
/// \brief The Kernel concept: a weight w(r, re) with compact support r < re.
#include <concepts>
#include <string_view>

namespace mpskit {

/// A weight function of MPS type: `K::w(r, re)` for 0 <= r, zero for r >= re (mpskit's inclusion rule
/// r < re, search/radius.hpp); `K::finite_at_zero` says whether w(0, re) is finite (required by the
/// Neumann-constrained LSMPS, Tanaka 2018 eqs. 85–87); `K::name` for reports.
template <class K>
concept Kernel = requires(double r, double re) {
  { K::w(r, re) } -> std::same_as<double>;
  { K::finite_at_zero } -> std::convertible_to<bool>;
  { K::name } -> std::convertible_to<std::string_view>;
};

}  // namespace mpskit
