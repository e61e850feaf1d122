#pragma once
// Speed-up of a multi-resolution run at equal error (issue #9, "Speed against error"): the wall time single
// resolution needs for the multi-resolution run's error, read off the single-resolution error-against-time
// curve, divided by the multi-resolution wall time. Between two measured points the curve is taken as a power
// law (linear in log error against log time), which interpolates a convergent run's e ∝ t^(−k) exactly.
// Outside the measured range nothing is extrapolated: the result is a bound (docs/validation.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "mpskit/core/error.hpp"

namespace mpskit::bench {

/// One run: wall time (s) and error (any positive measure, the same for every run compared).
struct cost_point {
  double seconds = 0.0;
  double error = 0.0;
};

/// What speed_up found.
struct speed_up_result {
  enum class kind {
    interpolated,  ///< the multi-resolution error lies on the single-resolution curve: speed_up is a number
    at_most,       ///< the multi error exceeds every single error: single needs ≤ its cheapest run's time
    at_least       ///< the multi error is below every single error: single needs ≥ its dearest run's time
  };
  kind how = kind::interpolated;
  /// Single resolution's time for the multi error (interpolated), or the bounding run's time.
  double single_seconds = std::numeric_limits<double>::quiet_NaN();
  /// single_seconds / the multi-resolution time (a bound unless how == interpolated).
  double speed_up = std::numeric_limits<double>::quiet_NaN();
  /// "interpolated", "at_most" or "at_least" (the CSV column).
  const char* kind_name() const {
    return how == kind::interpolated ? "interpolated" : how == kind::at_most ? "at_most" : "at_least";
  }
  /// "", "<= " or ">= ": how a printed single_seconds or speed_up is to be read.
  const char* bound_prefix() const { return how == kind::interpolated ? "" : how == kind::at_most ? "<= " : ">= "; }
};

/// Speed-up of `multi` against the single-resolution runs `single` (at least one). The runs are taken in order
/// of wall time and the first segment whose two errors bracket the multi error gives the time, log-log linear
/// (a curve whose error grows with cost, as the dam break's front, is read at its cheapest crossing). Throws
/// mpskit::error on an empty curve or a non-positive or non-finite time or error.
inline speed_up_result speed_up(std::vector<cost_point> single, const cost_point& multi) {
  const auto bad = [](const cost_point& p) {
    return !(std::isfinite(p.seconds) && p.seconds > 0.0 && std::isfinite(p.error) && p.error > 0.0);
  };
  if (single.empty()) fail("speed_up: no single-resolution run");
  for (const cost_point& p : single)
    if (bad(p)) fail("speed_up: single-resolution run (", p.seconds, " s, error ", p.error, "): both must be finite and > 0");
  if (bad(multi)) fail("speed_up: multi-resolution run (", multi.seconds, " s, error ", multi.error, "): both must be finite and > 0");
  std::sort(single.begin(), single.end(), [](const cost_point& a, const cost_point& b) { return a.seconds < b.seconds; });
  speed_up_result r;
  const double e = multi.error;
  for (std::size_t k = 0; k < single.size(); ++k) {
    const cost_point& a = single[k];
    if (a.error == e) {
      r.single_seconds = a.seconds;
      break;
    }
    if (k + 1 == single.size()) break;
    const cost_point& b = single[k + 1];
    if ((a.error - e) * (b.error - e) < 0.0) {
      const double s = std::log(e / a.error) / std::log(b.error / a.error);
      r.single_seconds = std::exp(std::log(a.seconds) + s * std::log(b.seconds / a.seconds));
      break;
    }
  }
  if (std::isnan(r.single_seconds)) {  // no segment brackets e: it lies above or below every single error
    const bool above = e > single.front().error;
    r.how = above ? speed_up_result::kind::at_most : speed_up_result::kind::at_least;
    r.single_seconds = above ? single.front().seconds : single.back().seconds;
  }
  r.speed_up = r.single_seconds / multi.seconds;
  return r;
}

}  // namespace mpskit::bench
