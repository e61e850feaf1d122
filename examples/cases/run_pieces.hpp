#pragma once
// Long runs in pieces through a checkpoint (io/lsmps_checkpoint.hpp), shared by the cases that run for hours
// at the papers' sizes: the multi-diameter channel (cases/multi_diameter_channel.hpp) and Tanaka's dam break
// (cases/tanaka_dam_break_run.hpp). docs/run.md "Checkpoint and restart".
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/io/checkpoint.hpp"

namespace mpskit::cases {

/// Where and when a run writes its checkpoint. With `checkpoint` set, the run is written there every
/// `checkpoint_interval` wall seconds (> 0; 0: only at the end) and when it reaches its end; `stop_after` > 0
/// ends the run after that many wall seconds of this process (after at least one step), checkpoint written,
/// result partial. `resume` names such a file to continue from (each case says what it checks).
struct run_pieces {
  std::string checkpoint, resume;
  double checkpoint_interval = 0.0, stop_after = 0.0;
  /// Refuses intervals and stop times without a file, and negative or non-finite ones (`who` names the
  /// caller).
  void validate(const char* who) const {
    if (checkpoint.empty() && (checkpoint_interval != 0.0 || stop_after != 0.0))
      fail(who,
           ": checkpoint_interval (--every) and stop_after (--stop-after) need a checkpoint file "
           "(--checkpoint)");
    if (!(checkpoint_interval >= 0.0 && std::isfinite(checkpoint_interval)) ||
        !(stop_after >= 0.0 && std::isfinite(stop_after)))
      fail(who, ": checkpoint_interval (", checkpoint_interval, " s) and stop_after (", stop_after,
           " s) must be finite and >= 0");
  }
};

/// The wall clock of one piece: when to write the checkpoint and when to stop. It counts from its
/// construction, which the runners place before a resumed file is loaded (the load is part of the piece's
/// wall time).
class piece_clock {
 public:
  explicit piece_clock(const run_pieces& p) : p_(p), t0_(std::chrono::steady_clock::now()) {}
  piece_clock(run_pieces&&) = delete;  // keeps a reference: not to a temporary
  /// Wall seconds of this process's piece.
  double wall() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }
  /// After a step's measurements: calls `save()` when the interval has passed, and when this piece has run
  /// stop_after seconds and the run has not reached its end (`more`) saves and returns true (stop). Nothing
  /// without a checkpoint file.
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
  /// When the run has reached its end: calls `save()` if there is a checkpoint file.
  template <class Save>
  void at_end(Save&& save) const {
    if (!p_.checkpoint.empty()) save();
  }

 private:
  const run_pieces& p_;
  std::chrono::steady_clock::time_point t0_;
  double last_save_ = 0.0;
};

/// A run's scalar measurements as one ordered list of places, written to a checkpoint section and read back
/// in the same order (so the order is stated once). Integers and flags are stored as doubles: an integer
/// beyond 2^53 in magnitude, which a double would round, is refused when written, not stored rounded.
class measure_list {
 public:
  measure_list& operator()(double& v) {
    return add([&v] { return v; }, [&v](double x) { v = x; });
  }
  template <std::integral I>
  measure_list& operator()(I& v) {
    static_assert(std::numeric_limits<I>::digits <= 64, "measure_list: integers of at most 64 bits");
    if constexpr (std::same_as<I, bool>)
      return add([&v] { return v ? 1.0 : 0.0; },
                 [&v](double x) {
                   if (x != 0.0 && x != 1.0) fail("measure_list: ", x, " read for a flag (0 or 1 expected)");
                   v = x != 0.0;
                 });
    else
      return add(
          [&v] {
            if constexpr (std::numeric_limits<I>::digits > 53) {  // |v| <= 2^53, tested without overflow
              constexpr auto exact = std::uint64_t{1} << 53;
              bool fits = true;
              if constexpr (std::is_signed_v<I>)
                fits = v >= 0 ? static_cast<std::uint64_t>(v) <= exact
                              : static_cast<std::uint64_t>(-(v + 1)) < exact;
              else
                fits = static_cast<std::uint64_t>(v) <= exact;
              if (!fits)
                fail("measure_list: the integer ", v, " is beyond 2^53 and would be rounded as a double");
            }
            return static_cast<double>(v);
          },
          [&v](double x) {  // a whole number inside I's range, or refused (a cast would be undefined)
            constexpr int digits = std::numeric_limits<I>::digits;
            const double hi = std::ldexp(1.0, digits), lo = std::is_signed_v<I> ? -hi : 0.0;
            if (!(std::isfinite(x) && x == std::trunc(x) && x >= lo && x < hi))
              fail("measure_list: ", x, " read for an integer of ", digits, " bits");
            v = static_cast<I>(x);
          });
  }
  /// A value written and read through functions (e.g. the wall time: the earlier pieces' plus this piece's so
  /// far).
  measure_list& add(std::function<double()> get, std::function<void(double)> set) {
    places_.emplace_back(std::move(get), std::move(set));
    return *this;
  }
  std::size_t size() const { return places_.size(); }
  std::vector<double> values() const {
    std::vector<double> v;
    v.reserve(places_.size());
    for (const auto& p : places_) v.push_back(p.first());
    return v;
  }
  /// Reads `size()` values from m[offset] on (refused unless m holds exactly offset + size() values).
  void assign(const std::vector<double>& m, std::size_t offset = 0) const {
    if (m.size() != offset + places_.size())
      fail("measure_list: ", m.size(), " values for ", offset, " + ", places_.size(), " places");
    for (std::size_t k = 0; k < places_.size(); ++k) places_[k].second(m[offset + k]);
  }
  /// Writes the values as section `name`.
  void save(io::checkpoint_sections& s, std::string name) const { s.add_doubles(std::move(name), values()); }
  /// Reads section `name` (refused, naming `who` and `file`, unless it holds exactly `size()` values).
  void load(const io::checkpoint_sections& s, const std::string& name, const char* who,
            const std::string& file) const {
    const std::vector<double> m = s.get_doubles(name);
    if (m.size() != places_.size())
      fail(who, ": '", file, "': section '", name, "' holds ", m.size(), " values, expected ",
           places_.size());
    assign(m);
  }

 private:
  std::vector<std::pair<std::function<double()>, std::function<void(double)>>> places_;
};

/// Equal-length sample vectors as one section of doubles, one after the other (a front's T, Z, ...); refused
/// when there are none or their lengths differ.
inline void add_columns(io::checkpoint_sections& s, std::string name,
                        std::initializer_list<const std::vector<double>*> columns) {
  if (columns.size() == 0) fail("add_columns: section '", name, "': no columns");
  std::vector<double> v;
  for (const auto* c : columns) {
    if (c->size() != (*columns.begin())->size())
      fail("add_columns: section '", name, "': columns of ", (*columns.begin())->size(), " and ", c->size(),
           " values");
    v.insert(v.end(), c->begin(), c->end());
  }
  s.add_doubles(std::move(name), v);
}

/// Reads a section written by add_columns into `columns` (refused unless its length is a multiple of their
/// number; `who` and `file` name the caller and the checkpoint in the message).
inline void get_columns(const io::checkpoint_sections& s, const std::string& name,
                        std::initializer_list<std::vector<double>*> columns, const char* who,
                        const std::string& file) {
  if (columns.size() == 0) fail(who, ": section '", name, "': no columns to read");
  const std::vector<double> v = s.get_doubles(name);
  if (v.size() % columns.size() != 0)
    fail(who, ": '", file, "': section '", name, "' holds ", v.size(), " values, not a multiple of ",
         columns.size());
  const auto n = static_cast<std::ptrdiff_t>(v.size() / columns.size());
  auto from = v.begin();
  for (auto* c : columns) {
    c->assign(from, from + n);
    from += n;
  }
}

}  // namespace mpskit::cases
