#pragma once
/// \file io/progress.hpp
/// \brief Run progress and end summary: `progress_sink` (a carriage-return line on a terminal, a plain
/// row per interval otherwise), `step_iterations` (each step's PPE iterations from a scheme's running total),
/// `run_counters` (what a run accumulates) and `run_summary` with its printer.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <limits>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#if __has_include(<unistd.h>)
#include <unistd.h>
#endif

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"

namespace mpskit::io {

/// What one progress report says.
struct progress_info {
  double time = 0.0;  ///< simulated time [s]
  /// simulated end time [s] (NaN: unknown, no ETA)
  double end_time = std::numeric_limits<double>::quiet_NaN();
  index_t step = 0;                              ///< steps done
  double dt = 0.0;                               ///< current time step [s]
  /// linear-solver iterations of the last step, every solve of it summed (step_iterations below)
  index_t ppe_iterations = 0;
  index_t particles = 0;                         ///< real particles
  double wall_seconds = 0.0;                     ///< wall time since the run started [s] (the caller's clock)
};

/// \brief The linear-solver iterations of each step, every solve of the step summed, from a scheme's running
/// total (`counters().ppe_iterations`). A scheme's `last_solve()` is the step's last solve only: the LSMPS
/// scheme repeats solves within a step (the active set's and the own-loop guard's repeats), and a repeat that
/// starts from a converged iterate reports 0 iterations. Called once per step, it gives each step's sum.
struct step_iterations {
  /// The running total at the last call: 0 for a new run; a resumed run sets it to its restored total (or
  /// saves and restores it with its own measures).
  long last = 0;
  /// The iterations since the last call; `total` is the running total now.
  index_t operator()(long total) {
    if (total < last) fail("step_iterations: the running total ", total, " fell below ", last);
    const long d = total - last;
    last = total;
    return static_cast<index_t>(d);
  }
};

/// How a progress sink prints.
enum class progress_mode : std::uint8_t {
  automatic,  ///< terminal when the stream is std::cout/cerr/clog attached to a terminal, plain otherwise
  terminal,   ///< one line rewritten in place ('\r'), a newline at finish()
  plain       ///< one row per interval
};

/// Formats seconds as "1h02m03s", "2m03s" or "4.5s"; "--" when not finite or negative.
inline std::string format_duration(double s) {
  if (!std::isfinite(s) || s < 0.0) return "--";
  std::ostringstream os;
  if (s < 60.0) {
    os << std::fixed << std::setprecision(1) << s << "s";
    return os.str();
  }
  const auto total = static_cast<std::int64_t>(std::llround(s));
  const std::int64_t h = total / 3600, m = total / 60 % 60, sec = total % 60;
  if (h > 0) os << h << "h" << std::setw(2) << std::setfill('0') << m << "m";
  else os << m << "m";
  os << std::setw(2) << std::setfill('0') << sec << "s";
  return os.str();
}

/// The text of one progress report (without line ending): simulated time, step, Δt, PPE iterations,
/// particles and ETA. ETA = (wall − wall₀)/(t − t₀)·(t_end − t), from the first report (t₀, wall₀).
inline std::string format_progress(const progress_info& p, double t0, double wall0) {
  std::ostringstream os;
  os << "t = " << std::setprecision(6) << p.time << " s";
  if (std::isfinite(p.end_time)) os << " / " << p.end_time << " s";
  os << ", step " << p.step << ", dt = " << std::setprecision(3) << std::scientific << p.dt << " s"
     << std::defaultfloat << ", PPE iterations " << p.ppe_iterations << ", particles " << p.particles;
  double eta = std::numeric_limits<double>::quiet_NaN();
  if (std::isfinite(p.end_time) && p.time > t0)
    eta = (p.wall_seconds - wall0) / (p.time - t0) * std::max(0.0, p.end_time - p.time);
  os << ", ETA " << format_duration(eta);
  return os.str();
}

/// \brief Progress output: call update() every step; it prints when `interval` wall seconds have passed
/// since the last print (and on the first call). Time comes from the caller (progress_info::wall_seconds),
/// so output is reproducible in tests.
class progress_sink {
 public:
  /// Prints to `os` at most every `interval` wall seconds (>= 0).
  explicit progress_sink(std::ostream& os = std::cerr, double interval = 1.0,
                         progress_mode mode = progress_mode::automatic)
      : os_(&os), interval_(interval) {
    if (!(interval >= 0.0) || !std::isfinite(interval))
      fail("progress_sink: interval = ", interval, ": must be a finite number of seconds >= 0");
    terminal_ = mode == progress_mode::terminal || (mode == progress_mode::automatic && is_terminal(os));
  }

  /// Reports a step; prints when due. Returns true when it printed.
  bool update(const progress_info& p) {
    if (!started_) {
      started_ = true;
      t0_ = p.time;
      wall0_ = p.wall_seconds;
    } else if (p.wall_seconds - last_ < interval_) {
      return false;
    }
    last_ = p.wall_seconds;
    print(p);
    return true;
  }
  /// Prints the last state now (e.g. at the end) regardless of the interval.
  void print(const progress_info& p) {
    const std::string line = format_progress(p, t0_, wall0_);
    if (terminal_) {
      // Rewrite the line in place; pad over a longer previous line.
      *os_ << '\r' << line;
      if (line.size() < width_) *os_ << std::string(width_ - line.size(), ' ');
      width_ = std::max(width_, line.size());
      os_->flush();
    } else {
      *os_ << line << '\n';
      os_->flush();
    }
    dirty_ = terminal_;
  }
  /// Ends the terminal line (a newline) so later output starts on a fresh line.
  void finish() {
    if (dirty_) *os_ << '\n';
    dirty_ = false;
    os_->flush();
  }
  bool terminal() const { return terminal_; }  ///< true when printing in place

 private:
  static bool is_terminal([[maybe_unused]] const std::ostream& os) {
#if __has_include(<unistd.h>)
    if (&os == &std::cout) return ::isatty(1) != 0;
    if (&os == &std::cerr || &os == &std::clog) return ::isatty(2) != 0;
#endif
    return false;
  }
  std::ostream* os_;
  double interval_;
  bool terminal_ = false, started_ = false, dirty_ = false;
  double t0_ = 0.0, wall0_ = 0.0, last_ = 0.0;
  std::size_t width_ = 0;
};

/// End-of-run summary.
struct run_summary {
  index_t particles = 0;             ///< real particles at the end
  index_t steps = 0;                 ///< steps taken
  double wall_seconds = 0.0;         ///< wall time [s]
  double particle_steps = 0.0;       ///< Σ over steps of the particles in that step
  double ppe_iterations_mean = 0.0;  ///< mean PPE iterations per step
  index_t ppe_iterations_max = 0;    ///< largest PPE iterations of a step
  index_t pinned_components = 0;     ///< Σ over steps of pinned PPE components (no Dirichlet row)
  index_t guarded_particles = 0;     ///< Σ over steps of particles put back by the wall-crossing guard
  index_t excluded_particles = 0;    ///< Σ over steps of particles excluded (isolated, failed operators)
  /// Particle-steps per wall second (0 when no wall time was measured).
  double particle_steps_per_second() const {
    return wall_seconds > 0.0 ? particle_steps / wall_seconds : 0.0;
  }
};

/// \brief Accumulates per-step counters into a run_summary.
class run_counters {
 public:
  /// Records one step.
  void record_step(index_t particles, index_t ppe_iterations, index_t pinned = 0, index_t guarded = 0,
                   index_t excluded = 0) {
    ++steps_;
    particles_ = particles;
    particle_steps_ += static_cast<double>(particles);
    ppe_sum_ += ppe_iterations;
    ppe_max_ = std::max(ppe_max_, ppe_iterations);
    pinned_ += pinned;
    guarded_ += guarded;
    excluded_ += excluded;
  }
  /// The summary after `wall_seconds` of wall time.
  run_summary summary(double wall_seconds) const {
    run_summary s;
    s.particles = particles_;
    s.steps = steps_;
    s.wall_seconds = wall_seconds;
    s.particle_steps = particle_steps_;
    s.ppe_iterations_mean = steps_ > 0 ? static_cast<double>(ppe_sum_) / static_cast<double>(steps_) : 0.0;
    s.ppe_iterations_max = ppe_max_;
    s.pinned_components = pinned_;
    s.guarded_particles = guarded_;
    s.excluded_particles = excluded_;
    return s;
  }
  /// Counters as int64 values for a checkpoint section (restore with from_values).
  std::vector<std::int64_t> values() const {
    std::int64_t ps = 0;
    static_assert(sizeof ps == sizeof particle_steps_);
    std::memcpy(&ps, &particle_steps_, sizeof ps);
    return {steps_, particles_, ps, ppe_sum_, ppe_max_, pinned_, guarded_, excluded_};
  }
  /// Restores counters saved with values().
  void from_values(const std::vector<std::int64_t>& v) {
    if (v.size() != 8) fail("run_counters: ", v.size(), " saved values, expected 8");
    steps_ = v[0];
    particles_ = v[1];
    std::memcpy(&particle_steps_, &v[2], sizeof particle_steps_);
    ppe_sum_ = v[3];
    ppe_max_ = v[4];
    pinned_ = v[5];
    guarded_ = v[6];
    excluded_ = v[7];
  }

 private:
  index_t steps_ = 0, particles_ = 0, ppe_sum_ = 0, ppe_max_ = 0, pinned_ = 0, guarded_ = 0, excluded_ = 0;
  double particle_steps_ = 0.0;
};

/// Prints the summary, one "name: value" line each.
inline void print_summary(std::ostream& os, const run_summary& s) {
  std::ostringstream o;
  o << "mpskit run summary\n"
    << "  particles:                 " << s.particles << "\n"
    << "  steps:                     " << s.steps << "\n"
    << "  wall time:                 " << format_duration(s.wall_seconds) << " (" << std::setprecision(6)
    << s.wall_seconds << " s)\n"
    << "  particle-steps per second: " << std::setprecision(4) << std::scientific
    << s.particle_steps_per_second() << std::defaultfloat << "\n"
    << "  PPE iterations:            mean " << std::fixed << std::setprecision(2) << s.ppe_iterations_mean
    << std::defaultfloat << ", max " << s.ppe_iterations_max << "\n"
    << "  pinned components:         " << s.pinned_components << "\n"
    << "  guarded particles:         " << s.guarded_particles << "\n"
    << "  excluded particles:        " << s.excluded_particles << "\n";
  os << o.str();
}

}  // namespace mpskit::io
