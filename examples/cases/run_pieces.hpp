#pragma once
// Long runs in pieces through a checkpoint (io/lsmps_checkpoint.hpp), shared by the cases that run for hours at the
// papers' sizes: the multi-diameter channel (cases/multi_diameter_channel.hpp) and Tanaka's dam break
// (cases/tanaka_dam_break_run.hpp). docs/run.md "Checkpoint and restart".
#include <chrono>
#include <cmath>
#include <string>

#include "mpskit/core/error.hpp"

namespace mpskit::cases {

/// Where and when a run writes its checkpoint. With `checkpoint` set, the run is written there every
/// `checkpoint_interval` wall seconds (> 0; 0: only at the end) and when it reaches its end; `stop_after` > 0 ends
/// the run after that many wall seconds of this process (after at least one step), checkpoint written, result
/// partial. `resume` names such a file to continue from (each case says what it checks).
struct run_pieces {
  std::string checkpoint, resume;
  double checkpoint_interval = 0.0, stop_after = 0.0;
  /// Refuses intervals and stop times without a file, and negative or non-finite ones (`who` names the caller).
  void validate(const char* who) const {
    if (checkpoint.empty() && (checkpoint_interval != 0.0 || stop_after != 0.0))
      fail(who, ": checkpoint_interval (--every) and stop_after (--stop-after) need a checkpoint file (--checkpoint)");
    if (!(checkpoint_interval >= 0.0 && std::isfinite(checkpoint_interval)) ||
        !(stop_after >= 0.0 && std::isfinite(stop_after)))
      fail(who, ": checkpoint_interval (", checkpoint_interval, " s) and stop_after (", stop_after,
           " s) must be finite and >= 0");
  }
};

/// The wall clock of one piece: when to write the checkpoint and when to stop.
class piece_clock {
 public:
  explicit piece_clock(const run_pieces& p) : p_(p), t0_(std::chrono::steady_clock::now()) {}
  piece_clock(run_pieces&&) = delete;  // keeps a reference: not to a temporary
  /// Wall seconds of this process's piece.
  double wall() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
  /// After a step's measurements: calls `save()` when the interval has passed, and when this piece has run
  /// stop_after seconds and the run has not reached its end (`more`) saves and returns true (stop). Nothing without a
  /// checkpoint file.
  template <class Save>
  bool after_step(Save&& save, bool more) {
    if (p_.checkpoint.empty()) return false;
    if (p_.checkpoint_interval > 0.0 && wall() - last_save_ >= p_.checkpoint_interval) {
      save();
      last_save_ = wall();
    }
    if (p_.stop_after > 0.0 && wall() >= p_.stop_after && more) {
      save();
      return true;
    }
    return false;
  }

 private:
  const run_pieces& p_;
  std::chrono::steady_clock::time_point t0_;
  double last_save_ = 0.0;
};

}  // namespace mpskit::cases
