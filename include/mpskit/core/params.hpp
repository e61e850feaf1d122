#pragma once
/// \file core/params.hpp
/// \brief Validation of runtime `params` aggregates: every number is checked once at construction and
/// each bad value gets its own line naming the parameter, its value and the accepted range
/// (ARCHITECTURE.md §2, §6). Nothing is clamped.
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "mpskit/core/error.hpp"

namespace mpskit {

/// Collects the problems of a parameter set; `throw_if_any()` throws one mpskit::error listing all.
class validator {
 public:
  /// `what` names the aggregate (e.g. "search_params").
  explicit validator(std::string_view what) : what_(what) {}

  /// v must be finite.
  validator& finite(std::string_view name, double v) {
    if (!std::isfinite(v)) add(name, v, "a finite number");
    return *this;
  }
  /// v must be finite and > 0.
  validator& positive(std::string_view name, double v) {
    if (!(std::isfinite(v) && v > 0.0)) add(name, v, "a finite number > 0");
    return *this;
  }
  /// v must be finite and >= 0.
  validator& non_negative(std::string_view name, double v) {
    if (!(std::isfinite(v) && v >= 0.0)) add(name, v, "a finite number >= 0");
    return *this;
  }
  /// lo <= v <= hi.
  validator& in_range(std::string_view name, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi)) add(name, v, detail::concat("in [", lo, ", ", hi, "]"));
    return *this;
  }
  /// lo < v < hi.
  validator& in_open_range(std::string_view name, double v, double lo, double hi) {
    if (!(v > lo && v < hi)) add(name, v, detail::concat("in (", lo, ", ", hi, ")"));
    return *this;
  }
  /// A free-form condition with its own explanation.
  validator& require(bool ok, std::string_view name, std::string_view explanation) {
    if (!ok) problems_.push_back(detail::concat(what_, ".", name, ": ", explanation));
    return *this;
  }
  /// The problems found so far.
  const std::vector<std::string>& problems() const { return problems_; }
  /// Throws mpskit::error with one line per problem.
  void throw_if_any() const {
    if (problems_.empty()) return;
    std::string msg = detail::concat("mpskit: invalid ", what_, " (", problems_.size(), " problem",
                                     problems_.size() > 1 ? "s" : "", "):");
    for (const auto& p : problems_) msg += "\n  " + p;
    throw error(msg);
  }

 private:
  void add(std::string_view name, double v, std::string_view accepted) {
    problems_.push_back(detail::concat(what_, ".", name, " = ", v, ": must be ", accepted));
  }
  std::string what_;
  std::vector<std::string> problems_;
};

/// Throws mpskit::error naming the first of the particles [0, n) whose diameter L[i] is not a finite
/// number > 0 (`who` prefixes the message). Called before a parallel loop: nothing may throw inside one.
template <class Sizes>
void check_diameters(std::string_view who, const Sizes& L, std::int64_t n) {
  for (std::int64_t i = 0; i < n; ++i)
    if (!(std::isfinite(L[i]) && L[i] > 0.0))
      fail(who, ": particle ", i, " has diameter L = ", L[i], ", accepted range (0, inf)");
}

}  // namespace mpskit
