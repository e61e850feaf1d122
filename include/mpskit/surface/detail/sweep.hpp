#pragma once
/// \file surface/detail/sweep.hpp
/// \brief Shared pieces of the surface detectors: size checks, support selection, kernel sums and the
/// one per-particle sweep that sets or clears flag::surface on candidates (each particle writes only
/// its own slot, so results do not depend on the thread count).
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string_view>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/concepts.hpp"

namespace mpskit::surface::detail {

/// Throws mpskit::error when the list, candidate mask or flags do not have one entry per particle.
template <int D>
void check_sizes(std::string_view who, const points<D>& x, const search::neighbour_list<D>& nl,
                 std::span<const std::uint8_t> candidate, const std::vector<flag::type>& flags) {
  const index_t n = x.cols();
  if (nl.rows() != n)
    fail(who, ": the neighbour list has ", nl.rows(), " rows for ", n, " particles (rebuild it)");
  if (static_cast<index_t>(candidate.size()) != n)
    fail(who, ": candidate has ", candidate.size(), " entries for ", n, " particles");
  if (static_cast<index_t>(flags.size()) != n)
    fail(who, ": flags has ", flags.size(), " entries for ", n, " particles");
}

/// The support (radius, rule) of `choice`.
template <ClassicSupports Op>
search::support<search::uniform_radius> support_of(const Op& op, support_choice c) {
  return c == support_choice::small ? op.small_support() : op.large_support();
}
/// The radius re (m) of `choice`.
template <ClassicSupports Op>
double re_of(const Op& op, support_choice c) {
  return c == support_choice::small ? op.re_small() : op.re_large();
}
/// The radius ratio re / l0 of `choice`.
template <ClassicSupports Op>
double ratio_of(const Op& op, support_choice c) {
  return c == support_choice::small ? op.params().re_small : op.params().re_large;
}
/// The reference number density n0 of `choice`.
template <ClassicSupports Op>
double n0_of(const Op& op, support_choice c) {
  return c == support_choice::small ? op.n0_small() : op.n0_large();
}

/// Name of a support choice (messages, docs).
constexpr std::string_view name(support_choice c) { return c == support_choice::small ? "small" : "large"; }

/// Calls f(j, x_ij, r, w_ij) for the participating neighbours of i inside support `c` (kernel of Op).
template <ClassicSupports Op, class Participates, class F>
void for_each_weighted(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
                       support_choice c, const Participates& participates, index_t i, F&& f) {
  using K = typename Op::kernel_type;
  const double re = re_of(op, c);
  nl.for_each_neighbour(x, i, support_of(op, c), [&](index_t j, const vec<Op::dim>& d, double r2) {
    if (!participates(j)) return;
    const double r = std::sqrt(r2);
    f(j, d, r, K::w(r, re));
  });
}

/// The sweep: for candidates, `decide(i)` returns {is_surface, value}; the flag bit is set or cleared
/// and `values` (when given) receives the value (NaN for non-candidates). Other bits are untouched.
template <Execution E, class Decide>
void sweep(E e, index_t n, std::span<const std::uint8_t> candidate, std::vector<flag::type>& flags,
           Eigen::VectorXd* values, const Decide& decide) {
  if (values) values->setConstant(n, std::numeric_limits<double>::quiet_NaN());
  for_each_particle(e, n, [&](index_t i) {
    const std::size_t k = static_cast<std::size_t>(i);
    if (candidate[k] == 0) return;
    const auto [surface, value] = decide(i);
    flags[k] = surface ? (flags[k] | flag::surface) : (flags[k] & ~flag::surface);
    if (values) (*values)[i] = value;
  });
}

/// Result of one decision: the flag and the thresholded quantity.
struct decision {
  bool surface = false;  ///< flag::surface to be set
  double value = 0.0;    ///< the quantity compared with the threshold
};

}  // namespace mpskit::surface::detail
