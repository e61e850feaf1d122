#pragma once
// The command line of examples/gears.cpp: its options, their reading and their refusals. In a header so that
// they are tested (label bad_input) although the examples are not built in CI.
#include <cstdio>
#include <string>

#include "cases/cli.hpp"
#include "cases/gears.hpp"

namespace mpskit::cases {

/// gears' options (the usage line and the knobs of its header comment): the case (gears_config), the output
/// directory and interval, what to run, and the solver.
struct gears_options {
  gears_config c{};
  std::string out = "out/gears";
  double vtk_every = 2e-3;  ///< ParaView output interval (s)
  bool geometry_only = false, jacobi = false, ilut = false;
  bool window_given = false;  ///< --window given (refused when not shorter than --t-end)

  /// Refuses, before any output (mpskit::error naming the option or the parameter): a --window not shorter
  /// than --t-end (the averaging window must end inside the run); scheme and face parameters the knobs put
  /// out of range (e.g. --cprime 1, which makes eq. 62's c′_min 0), checked as run_gears will use them
  /// (gears_config::scheme_params), also with --geometry-only (bad input either way).
  void validate() const {
    if (window_given && !(c.t_end > c.window)) {
      char text[96];  // %g: the numbers as given, not to 17 digits
      std::snprintf(text, sizeof text, "--window %g must be shorter than --t-end %g", c.window, c.t_end);
      fail("gears: ", text);
    }
    c.scheme_params().validate();
    c.boundary.validate();
  }
  /// The default window follows a --t-end not longer than it: 0.2 t_end. Returns whether it did (the example
  /// says so). Call after validate().
  bool fit_default_window() {
    if (c.t_end > c.window) return false;
    c.window = 0.2 * c.t_end;
    return true;
  }
};

/// Reads gears' command line (argv[1 ..]). --full is applied first, wherever it stands, so that the options
/// given with it override its values; --out's value is skipped in that pass (a directory may be called
/// "--full"), and a number option whose value reads "--full" is refused as not a number. A value that is not
/// wholly a finite number, or is <= 0 (< 0 for --filter and --two-point, where 0 switches off), an unknown
/// option and a missing value are refused (mpskit::error naming the option).
inline gears_options read_gears_options(int argc, const char* const* argv) {
  gears_options o;
  gears_config& c = o.c;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--out")
      ++a;
    else if (arg == "--full") {
      c.L_min = 0.1e-3;
      c.r_fine = 4e-3;
      c.t_end = 0.4;
      c.window = 0.1;
      o.vtk_every = 0.02;
    }
  }
  read_command_line("gears", argc, argv, [&](const std::string& arg, const auto& value) {
    const std::string what = "gears: " + arg;
    // > 0, or >= 0 where 0 switches the option off
    const auto number = [&](bool zero_ok = false) {
      const std::string text = value();
      const double x = parse_number(what.c_str(), text);  // the whole text, finite
      if (x < 0.0 || (x == 0.0 && !zero_ok)) fail(what, " '", text, "': must be ", zero_ok ? ">= 0" : "> 0");
      return x;
    };
    if (arg == "--full")
      ;  // applied above
    else if (arg == "--out")
      o.out = value();
    else if (arg == "--t-end")
      c.t_end = number();
    else if (arg == "--lmin")
      c.L_min = number();
    else if (arg == "--lmax")
      c.L_max = number();
    else if (arg == "--rfine")
      c.r_fine = number();
    else if (arg == "--wall-limit")
      c.wall_limit = number();
    else if (arg == "--tip-round")
      c.geometry.tip_round = number();
    else if (arg == "--root-round")
      c.geometry.root_round = number();
    else if (arg == "--filter")
      c.params.boundary_filter.strength = number(true);
    else if (arg == "--shift-as-printed")
      c.params.shift.projection = regularize::penalty_projection::with_displacement;
    else if (arg == "--two-point")
      c.params.copy_two_point = number(true);
    else if (arg == "--wall-contact")
      c.params.resolution.wall_contact = number();
    else if (arg == "--courant")
      c.params.time.courant = number();
    else if (arg == "--alpha-w")
      c.params.walls.alpha_w = number();
    else if (arg == "--alpha-o")
      c.boundary.alpha_o = number();
    else if (arg == "--window")
      c.window = number(), o.window_given = true;
    else if (arg == "--vtk-every")
      o.vtk_every = number();
    else if (arg == "--geometry-only")
      o.geometry_only = true;
    else if (arg == "--no-merge")
      c.params.resolution.merge = false;
    else if (arg == "--jacobi")
      o.jacobi = true;
    else if (arg == "--ilut")
      o.ilut = true;
    else if (arg == "--ilut-drop")
      c.params.solver.ilut_drop_tolerance = number();
    else if (arg == "--cprime") {  // the largest volume correction per step (eq. 62's c′ bounds)
      const double d = number();
      c.params.volume.c_prime_min = 1.0 - d;
      c.params.volume.c_prime_max = 1.0 + d;
    } else
      return false;
    return true;
  });
  return o;
}

}  // namespace mpskit::cases
