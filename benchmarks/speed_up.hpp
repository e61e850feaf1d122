#pragma once
// Speed-up of a multi-resolution run at equal error (issue #9, "Speed against error"): the wall time single
// resolution needs for the multi-resolution run's error, read off the single-resolution error-against-time
// curve, divided by the multi-resolution wall time. Between two measured points the curve is taken as a power
// law (linear in log error against log time), which interpolates a convergent run's e ∝ t^(−k) exactly.
// Outside the measured range nothing is extrapolated: the result is a bound (docs/validation.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
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
  /// Single runs left out because a cheaper run had an error as low or lower (the curve is not monotone
  /// there; the reporters print it).
  int dominated = 0;
  /// "interpolated", "at_most" or "at_least" (the CSV column).
  const char* kind_name() const {
    return how == kind::interpolated ? "interpolated" : how == kind::at_most ? "at_most" : "at_least";
  }
  /// "" or, when runs were dropped, " (N single-resolution run(s) left out: a cheaper run had as low an
  /// error)".
  std::string dominated_note() const {
    return dominated == 0 ? std::string()
                          : " (" + std::to_string(dominated) + " single-resolution run" +
                                (dominated > 1 ? "s" : "") + " left out: a cheaper run had as low an error)";
  }
  /// "", "<= " or ">= ": how a printed single_seconds or speed_up is to be read.
  const char* bound_prefix() const {
    return how == kind::interpolated ? "" : how == kind::at_most ? "<= " : ">= ";
  }
};

/// Speed-up of `multi` against the single-resolution runs `single` (at least one). The runs are taken in
/// order of wall time, and a run whose error is not below that of a cheaper run is dropped (counted in
/// `dominated`): single resolution would not pay more for a worse error, so the curve read is the lower
/// envelope, whose error falls strictly with time. The segment of the envelope whose two errors bracket the
/// multi error gives the time, log-log linear. (Before 2026-12-03 the first bracketing segment of the whole
/// curve was read: on a curve that rises somewhere, as the obstacle study's 5 mm outlier, that interpolated
/// on the rising part and overstated the time single resolution needs.) Throws mpskit::error on an empty
/// curve or a non-positive or non-finite time or error.
inline speed_up_result speed_up(std::vector<cost_point> single, const cost_point& multi) {
  const auto bad = [](const cost_point& p) {
    return !(std::isfinite(p.seconds) && p.seconds > 0.0 && std::isfinite(p.error) && p.error > 0.0);
  };
  if (single.empty()) fail("speed_up: no single-resolution run");
  for (const cost_point& p : single)
    if (bad(p))
      fail("speed_up: single-resolution run (", p.seconds, " s, error ", p.error,
           "): both must be finite and > 0");
  if (bad(multi))
    fail("speed_up: multi-resolution run (", multi.seconds, " s, error ", multi.error,
         "): both must be finite and > 0");
  std::sort(single.begin(), single.end(),
            [](const cost_point& a, const cost_point& b) { return a.seconds < b.seconds; });
  speed_up_result r;
  // The lower envelope: keep a run only when its error is below every cheaper run's.
  std::vector<cost_point> kept;
  for (const cost_point& p : single)
    if (kept.empty() || p.error < kept.back().error) kept.push_back(p);
  r.dominated = static_cast<int>(single.size() - kept.size());
  single = std::move(kept);
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
