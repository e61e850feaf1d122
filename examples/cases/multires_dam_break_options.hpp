#pragma once
// The command line of examples/multires_dam_break.cpp (the README's main example): its options, their
// reading and their refusals. In a header so that the refusals are tested (label bad_input) although the
// examples are not built in CI.
#include <cmath>
#include <string>

#include "cases/tanaka_dam_break_options.hpp"
#include "cases/tanaka_obstacle_multires.hpp"

namespace mpskit::cases {

/// multires_dam_break's options (its usage line): the coarse spacing L_mm, the size ratio, the refined disc
/// r0_mm and the ramp's end r1_mm around the block, the scheme's switches; --full is the paper's 5 mm at 5:1.
struct multires_dam_break_options {
  double L_mm = 5.0, ratio = 2.0, T_end = 3.8, r0_mm = 30.0, r1_mm = 60.0;
  bool single = true, contact_fallback = false;
  bool release = scheme::lsmps_impact_params<2>().active_set_release;
  bool warm = scheme::lsmps_impact_params<2>().active_set_warm_start;
  impact_scheme_options lsmps;  ///< --walls, --collision and the isolated particles' switches
  std::string out = "out/multires_dam_break";

  /// The single runs' parameters (the multi-resolution run adds refine_around_block's target diameter and the
  /// wall-contact fallback): the wall variant, the switches and the active set's options; validated.
  scheme::lsmps_params<2> params() const {
    scheme::lsmps_params<2> p = lsmps.params("multires_dam_break");
    p.active_set_release = release;
    p.active_set_warm_start = warm;
    p.validate();  // --release with wall options that have no active set, --warm without --release: refused
    return p;
  }

  /// The obstacle case at the coarse (L_mm) and the fine (L_mm / ratio) spacing; validated (an --L above the
  /// column's width is refused).
  tanaka_dam_break_config coarse_config() const { return obstacle_config(1e-3 * L_mm); }
  tanaka_dam_break_config fine_config() const { return obstacle_config(1e-3 * L_mm / ratio); }

  /// The refusals before any output: --L, --T > 0; --ratio >= 1; 0 <= --r0 < --r1;
  /// impact_scheme_options::validate's; params()'s; the two configurations'. mpskit::error naming the option.
  void validate() const {
    const char* who = "multires_dam_break";
    if (!(L_mm > 0.0 && std::isfinite(L_mm))) fail(who, ": --L ", L_mm, " mm: must be > 0");
    if (!(ratio >= 1.0 && std::isfinite(ratio))) fail(who, ": --ratio ", ratio, ": must be >= 1");
    if (!(T_end > 0.0 && std::isfinite(T_end))) fail(who, ": --T ", T_end, ": must be > 0");
    if (!(r0_mm >= 0.0 && r1_mm > r0_mm && std::isfinite(r1_mm)))
      fail(who, ": --r0 ", r0_mm, " mm, --r1 ", r1_mm, " mm: need 0 <= r0 < r1");
    lsmps.validate(who);
    params();
    coarse_config();
    fine_config();
  }

 private:
  static tanaka_dam_break_config obstacle_config(double L) {
    const tanaka_dam_break_config c = tanaka_obstacle_config(L);
    c.validate();
    return c;
  }
};

/// Reads multires_dam_break's command line. Numbers are the whole text, finite (cases/cli.hpp: `--r0 abc` is
/// refused, not read as 0); an unknown option or one missing its value is refused too: mpskit::error naming
/// it. The ranges are validate()'s.
inline multires_dam_break_options read_multires_dam_break_options(int argc, const char* const* argv) {
  multires_dam_break_options o;
  read_command_line("multires_dam_break", argc, argv, [&](const std::string& arg, const auto& value) {
    const std::string what = "multires_dam_break: " + arg;
    const auto number = [&] { return parse_number(what.c_str(), value()); };
    if (o.lsmps.read(arg, value, "multires_dam_break")) return true;
    if (arg == "--full")
      o.L_mm = 5.0, o.ratio = 5.0;
    else if (arg == "--no-single")
      o.single = false;
    else if (arg == "--release")
      o.release = true;
    else if (arg == "--warm")
      o.warm = true;
    else if (arg == "--contact-fallback")
      o.contact_fallback = true;
    else if (arg == "--L")
      o.L_mm = number();
    else if (arg == "--ratio")
      o.ratio = number();
    else if (arg == "--T")
      o.T_end = number();
    else if (arg == "--r0")
      o.r0_mm = number();
    else if (arg == "--r1")
      o.r1_mm = number();
    else if (arg == "--out")
      o.out = value();
    else
      return false;
    return true;
  });
  return o;
}

}  // namespace mpskit::cases
