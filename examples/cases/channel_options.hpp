#pragma once
// The command line of examples/channel.cpp: its modes (the first argument), their options and positional
// numbers, their reading and their refusals. In a header so that they are tested (label bad_input) although
// the examples are not built in CI.
#include <cstdio>
#include <string>
#include <vector>

#include "cases/cli.hpp"
#include "cases/duct.hpp"
#include "cases/multi_diameter_channel.hpp"
#include "cases/pipe.hpp"
#include "cases/poiseuille.hpp"

namespace mpskit::cases {

/// channel's modes: the first argument names one (none: the plane Poiseuille channel).
enum class channel_mode { poiseuille, pipe, duct, duct_multires, a2, multi };

/// The mode named by argv[1] (channel_mode::poiseuille when it names none).
inline channel_mode read_channel_mode(int argc, const char* const* argv) {
  if (argc < 2) return channel_mode::poiseuille;
  const std::string m = argv[1];
  if (m == "--pipe") return channel_mode::pipe;
  if (m == "--duct") return channel_mode::duct;
  if (m == "--duct-multires") return channel_mode::duct_multires;
  if (m == "--a2") return channel_mode::a2;
  if (m == "--multi") return channel_mode::multi;
  return channel_mode::poiseuille;
}

/// The usage line of a mode.
inline const char* channel_usage(channel_mode mode) {
  switch (mode) {
    case channel_mode::pipe:
      return "channel --pipe [t_end]";
    case channel_mode::duct:
      return "channel --duct [t_end] [L]";
    case channel_mode::duct_multires:
      return "channel --duct-multires [t_end]";
    case channel_mode::a2:
      return "channel --a2 [t_end] [--ratio R] [--pressure] [--no-single]";
    case channel_mode::multi:
      return "channel --multi [L] [t_end] [--refine R [--graded]] [--neumann-points] [--thin-walls] "
             "[--dt-ratio r] [--progress S] [--checkpoint FILE [--every S] [--stop-after S]] [--resume FILE] "
             "[--ilut-across]";
    case channel_mode::poiseuille:
      break;
  }
  return "channel [--full] [--periodic-only] [L] [t_end]   (modes: --pipe, --duct, --duct-multires, --a2, "
         "--multi)";
}

/// channel's options, mode by mode (the usage lines: channel_usage); each mode reads only its own.
struct channel_options {
  channel_mode mode = channel_mode::poiseuille;
  /// default mode: the 10 mm channel, 20 mm long between pressure faces (and its periodic twin); [L] sets
  /// the diameter and Δt = 0.1 L²/ν with it, [t_end] the end; --full the paper's 100 mm; --periodic-only.
  poiseuille_config poiseuille = [] {
    poiseuille_config c;
    c.length = 0.02;
    return c;
  }();
  bool full = false, periodic_only = false;
  /// --pipe [t_end]: the 3D pipe, probed at 0.05 s.
  pipe_config pipe = [] {
    pipe_config c;
    c.probe_times = {0.05};
    return c;
  }();
  /// --duct [t_end] [L], --duct-multires [t_end]: the 3D square duct.
  duct_config duct{};
  /// --a2 [t_end] [--ratio R] [--pressure] [--no-single]: Tanaka A2.
  double a2_t_end = 0.1, a2_ratio = 4.0;
  bool a2_pressure = false, a2_single = true;
  /// --multi [L] [t_end] [options]: the multi-diameter channel; refine = 0: single resolution, else split
  /// to L / refine entering the narrow section.
  multi_diameter_config multi{};
  double refine = 0.0;

  /// Refuses what reading alone cannot (mpskit::error naming the option or the parameter): --multi's t_end
  /// not beyond its balance window, --graded without --refine, a --dt-ratio outside [1.001, 2] (the time-step
  /// controller's check), --every or --stop-after without --checkpoint (run_pieces' check).
  void validate() const {
    if (mode != channel_mode::multi) return;
    multi.params.time.validate();
    multi.pieces.validate("channel --multi");
    if (!(multi.t_end > multi.window)) {
      char text[96];  // %g: the numbers as given, not to 17 digits
      std::snprintf(text, sizeof text, "t_end %g must exceed the %g s balance window", multi.t_end,
                    multi.window);
      fail("channel --multi: ", text);
    }
    if (multi.graded_start && refine == 0.0)
      fail("channel --multi: --graded needs --refine R (the target diameter it grades to)");
  }
};

/// Reads channel's command line: the mode from argv[1], then its options and positional numbers. Every number
/// is wholly a finite number > 0 (ratios >= 1); a positional beyond the mode's, an option of another mode, a
/// missing value and an unknown option are refused (mpskit::error naming the mode and the option or text).
inline channel_options read_channel_options(int argc, const char* const* argv) {
  channel_options o;
  o.mode = read_channel_mode(argc, argv);
  const int first = o.mode == channel_mode::poiseuille ? 1 : 2;  // the first argument after the mode
  const std::string who = first == 1 ? std::string("channel") : "channel " + std::string(argv[1]);
  // the mode's positional numbers, in order
  const std::vector<std::string> slots = [&]() -> std::vector<std::string> {
    switch (o.mode) {
      case channel_mode::pipe:
      case channel_mode::duct_multires:
      case channel_mode::a2:
        return {"t_end"};
      case channel_mode::duct:
        return {"t_end", "L"};
      case channel_mode::multi:
      case channel_mode::poiseuille:
        break;
    }
    return {"L", "t_end"};
  }();
  std::size_t positional = 0;
  // read_command_line walks argv[1 ..]: it is given the arguments after the mode
  read_command_line(
      who.c_str(), argc - first + 1, argv + first - 1, [&](const std::string& arg, const auto& value) {
        // > 0, or >= 1 for a ratio
        const auto positive = [&](const std::string& what, const std::string& text, bool ratio = false) {
          const double x = parse_number((who + ": " + what).c_str(), text);  // the whole text, finite
          if (ratio ? !(x >= 1.0) : !(x > 0.0))
            fail(who, ": ", what, " '", text, "': must be ", ratio ? ">= 1" : "> 0");
          return x;
        };
        const auto number = [&](bool ratio = false) { return positive(arg, value(), ratio); };
        if (arg.size() < 2 || arg[0] != '-' || arg[1] != '-') {  // a positional number: the mode's next slot
          if (positional == slots.size()) {
            std::string all;
            for (const std::string& n : slots) all += (all.empty() ? "" : " and ") + n;
            fail(who, ": unexpected '", arg, "' (at most ", all, ")");
          }
          const std::string& name = slots[positional++];
          const double x = positive(name, arg);
          switch (o.mode) {
            case channel_mode::poiseuille:
              if (name == "L") {
                o.poiseuille.L = x;
                // the viscous limit 0.1 L²/ν scales with L²
                o.poiseuille.dt = 2.5e-4 * (x / 0.5e-3) * (x / 0.5e-3);
              } else {
                o.poiseuille.t_end = x;
              }
              break;
            case channel_mode::pipe:
              o.pipe.t_end = x;
              break;
            case channel_mode::duct:
            case channel_mode::duct_multires:
              (name == "L" ? o.duct.L : o.duct.t_end) = x;
              break;
            case channel_mode::a2:
              o.a2_t_end = x;
              break;
            case channel_mode::multi:
              (name == "L" ? o.multi.L : o.multi.t_end) = x;
              break;
          }
          return true;
        }
        switch (o.mode) {
          case channel_mode::poiseuille:
            if (arg == "--full")
              o.poiseuille.length = 0.1, o.full = true;
            else if (arg == "--periodic-only")
              o.periodic_only = true;
            else
              return false;
            return true;
          case channel_mode::a2:
            if (arg == "--pressure")
              o.a2_pressure = true;
            else if (arg == "--no-single")
              o.a2_single = false;
            else if (arg == "--ratio")
              o.a2_ratio = number(true);
            else
              return false;
            return true;
          case channel_mode::multi:
            if (arg == "--neumann-points")  // the wall copies as Neumann points (opt-in wall rows)
              o.multi.params.copy_row = scheme::copy_row_kind::neumann_points;
            else if (arg == "--thin-walls")  // the visibility test on (the library's default)
              o.multi.params.thin_walls = true;
            else if (arg == "--progress")
              o.multi.progress_interval = number();
            else if (arg == "--dt-ratio")  // the Δt ladder's ratio r (time_step_params::ratio)
              o.multi.params.time.ratio = number();
            else if (arg == "--checkpoint")  // long runs in pieces
              o.multi.pieces.checkpoint = value();
            else if (arg == "--resume")
              o.multi.pieces.resume = value();
            else if (arg == "--every")
              o.multi.pieces.checkpoint_interval = number();
            else if (arg == "--stop-after")
              o.multi.pieces.stop_after = number();
            else if (arg == "--ilut-across")  // keep the ILUT factors across changes of the unknowns
              o.multi.params.solver.ilut_reuse_across_changes = true;
            else if (arg == "--graded")  // start at the target diameter (with --refine)
              o.multi.graded_start = true;
            else if (arg == "--refine")
              o.refine = number(true);
            else
              return false;
            return true;
          case channel_mode::pipe:
          case channel_mode::duct:
          case channel_mode::duct_multires:
            break;  // positional numbers only
        }
        return false;
      });
  // The transient's comparisons fall inside the run (the cases step on to each probe time, so a probe past
  // t_end would run the case beyond the end asked for); --a2 and --multi set their own.
  const auto inside = [](std::vector<double>& probes, double t_end) {
    std::erase_if(probes, [&](double t) { return !(t < t_end); });
  };
  inside(o.poiseuille.probe_times, o.poiseuille.t_end);
  inside(o.pipe.probe_times, o.pipe.t_end);
  return o;
}

}  // namespace mpskit::cases
