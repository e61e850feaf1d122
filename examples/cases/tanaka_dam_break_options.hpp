#pragma once
// The command lines of examples/tanaka_dam_break.cpp and (with cases/multires_dam_break_options.hpp)
// examples/multires_dam_break.cpp: their options, their reading and their refusals. In a header so that the
// refusals are tested (label bad_input) although the examples are not built in CI.
#include <cmath>
#include <string>

#include "cases/cli.hpp"
#include "cases/tanaka_dam_break_run.hpp"
#include "mpskit/regularize/collision.hpp"
#include "mpskit/scheme/lsmps_semi_implicit.hpp"

namespace mpskit::cases {

/// The LSMPS options both dam-break examples take: the wall variant (--walls), the collision stage
/// (--collision ALPHA1), isolated particles colliding (--[no-]collide-isolated) and in the shifting penalty
/// (--[no-]shift-isolated). The defaults are scheme::lsmps_impact_params<2>()'s.
struct impact_scheme_options {
  std::string walls_name = tanaka_impact_walls;
  double collision = scheme::lsmps_impact_params<2>().collision.alpha1;
  bool collide_isolated = scheme::lsmps_impact_params<2>().collision.isolated;
  bool collide_isolated_asked = false;  ///< --collide-isolated given last (refused with --collision 0)
  bool shift_isolated = scheme::lsmps_impact_params<2>().shift_isolated_penalty;

  /// Reads arg when it is one of these options (value(): its value); false otherwise. `who`: the program.
  template <class Value>
  bool read(const std::string& arg, const Value& value, const char* who) {
    if (arg == "--collide-isolated")
      collide_isolated = collide_isolated_asked = true;
    else if (arg == "--no-collide-isolated")
      collide_isolated = collide_isolated_asked = false;
    else if (arg == "--shift-isolated")
      shift_isolated = true;
    else if (arg == "--no-shift-isolated")
      shift_isolated = false;
    else if (arg == "--walls")
      walls_name = value();
    else if (arg == "--collision")
      collision = parse_number((std::string(who) + ": --collision").c_str(), value());
    else
      return false;
    return true;
  }

  /// Isolated particles collide: asked (the default) and the collision stage on (without it nothing
  /// collides: the default's "on" lapses with --collision 0).
  bool colliding_isolated() const { return collide_isolated && collision != 0.0; }

  /// The wall variant named by --walls; mpskit::error listing the accepted names otherwise.
  const tanaka_wall_variant& walls(const char* who) const {
    return tanaka_wall_variant_named(walls_name, (std::string(who) + " --walls").c_str());
  }

  /// Refuses an unknown wall variant, --collision outside the stage's range and --collide-isolated with
  /// --collision 0 (mpskit::error naming `who` and the option).
  void validate(const char* who) const {
    walls(who);
    regularize::sized_collision_params{.alpha1 = collision}.validate();
    if (collide_isolated_asked && collision == 0.0)
      fail(who, ": --collide-isolated needs the collision stage on (--collision ALPHA1 > 0)");
  }

  /// The 2D scheme's parameters: lsmps_params<2>{} with the wall variant applied, then these options.
  scheme::lsmps_params<2> params(const char* who) const {
    scheme::lsmps_params<2> p;
    walls(who).apply(p);
    return switches(p);
  }

  /// The 3D slab's parameters (tanaka_dam_break --slab): Tanaka's Table 2 (lsmps_params<3>{}) with --walls
  /// parent_gradient, otherwise scheme::lsmps_impact_params<3>() (the wall variants are 2D; the slab takes
  /// these two only, tanaka_dam_break_options::validate), then the collision and isolated-particle options
  /// as in 2D.
  scheme::lsmps_params<3> slab_params() const {
    return switches(slab_table2() ? scheme::lsmps_params<3>{} : scheme::lsmps_impact_params<3>());
  }
  /// What slab_params() starts from, for the run's header line.
  const char* slab_scheme_name() const {
    return slab_table2() ? "Tanaka's Table 2 (lsmps_params<3>{})" : "scheme::lsmps_impact_params<3>()";
  }

 private:
  bool slab_table2() const { return walls_name == "parent_gradient"; }
  template <int D>
  scheme::lsmps_params<D> switches(scheme::lsmps_params<D> p) const {
    p.collision.alpha1 = collision;
    p.collision.isolated = colliding_isolated();
    p.shift_isolated_penalty = shift_isolated;
    return p;
  }
};

/// tanaka_dam_break's options (its usage line).
struct tanaka_dam_break_options {
  double L_mm = 5.0, T_end = 3.2, trace_speed = 0.0, lid_mm = 0.0, slab = 0.0;
  bool slab_asked = false, slab_walls = false, trace = false, obstacle = false, fallback = false,
       ilu0 = false;
  impact_scheme_options lsmps;  ///< --walls, --collision and the isolated particles' switches
  tanaka_pieces pieces;
  std::string data, out = "out/tanaka_dam_break";

  /// The refusals before any output: --L, --T > 0; --trace >= 0; --fallback with --ilu0; --every and
  /// --stop-after without --checkpoint; impact_scheme_options::validate's; --slab not a whole number in
  /// [1, 1000], or with a 2D-only option or another wall variant than the impact configuration's or
  /// parent_gradient; --slab-walls without --slab. mpskit::error naming the option. The case's own checks
  /// (a lid at or below the water) are config()'s.
  void validate() const {
    if (!(L_mm > 0.0 && std::isfinite(L_mm))) fail("tanaka_dam_break: --L ", L_mm, " mm: must be > 0");
    if (!(T_end > 0.0 && std::isfinite(T_end))) fail("tanaka_dam_break: --T ", T_end, ": must be > 0");
    if (trace && !(trace_speed >= 0.0 && std::isfinite(trace_speed)))
      fail("tanaka_dam_break: --trace ", trace_speed, " m/s: must be >= 0");
    if (fallback && ilu0)
      fail("tanaka_dam_break: --fallback and --ilu0 name two solvers (the fallback's primary is Jacobi)");
    pieces.validate("tanaka_dam_break");  // --every and --stop-after need --checkpoint; both finite, >= 0
    lsmps.validate("tanaka_dam_break");
    if (slab_asked) {  // the 3D slab: its own path (the probe, the trace and the pictures are 2D)
      if (!(slab >= 1.0 && slab <= 1000.0 && slab == std::floor(slab)))
        fail("tanaka_dam_break: --slab ", slab, ": the number of layers must be a whole number in [1, 1000]");
      if (obstacle || trace || fallback || ilu0 || !pieces.checkpoint.empty() || !pieces.resume.empty())
        fail(
            "tanaka_dam_break: --slab takes neither --obstacle, --trace, --fallback, --ilu0, --checkpoint "
            "nor --resume (2D only)");
      if (lsmps.walls_name != "parent_gradient" && lsmps.walls_name != tanaka_impact_walls)
        fail("tanaka_dam_break: --slab takes --walls ", tanaka_impact_walls,
             " (the default: the impact configuration) or parent_gradient (Tanaka's Table 2), not ",
             lsmps.walls_name);
    } else if (slab_walls) {
      fail("tanaka_dam_break: --slab-walls needs --slab N");
    }
  }

  /// The case: Tanaka's dam break (or the obstacle case) at L_mm, with the lid; validated.
  tanaka_dam_break_config config() const {
    tanaka_dam_break_config cfg = obstacle ? tanaka_obstacle_config(1e-3 * L_mm) : tanaka_dam_break_config{};
    cfg.L = 1e-3 * L_mm;
    // cfg.validate() checks the lid against the column (a lid at or below the water is refused)
    if (lid_mm != 0.0) {
      cfg.vessel_height = 1e-3 * lid_mm;
      cfg.closed_top = true;
    }
    cfg.validate();
    return cfg;
  }
};

/// Reads tanaka_dam_break's command line (data: the default of --data). Numbers are the whole text, finite
/// (cases/cli.hpp: `--collision abc` is refused, not read as 0, which would switch the stage off); an unknown
/// option or one missing its value is refused too: mpskit::error naming it. The ranges are validate()'s.
inline tanaka_dam_break_options read_tanaka_dam_break_options(int argc, const char* const* argv,
                                                              const std::string& data) {
  tanaka_dam_break_options o;
  o.data = data;
  read_command_line("tanaka_dam_break", argc, argv, [&](const std::string& arg, const auto& value) {
    const std::string what = "tanaka_dam_break: " + arg;
    const auto number = [&] { return parse_number(what.c_str(), value()); };
    if (o.lsmps.read(arg, value, "tanaka_dam_break")) return true;
    if (arg == "--full")
      o.L_mm = 1.0;
    else if (arg == "--obstacle")
      o.obstacle = true;
    else if (arg == "--fallback")
      o.fallback = true;
    else if (arg == "--ilu0")
      o.ilu0 = true;
    else if (arg == "--slab-walls")
      o.slab_walls = true;
    else if (arg == "--L")
      o.L_mm = number();
    else if (arg == "--T")
      o.T_end = number();
    else if (arg == "--lid")
      o.lid_mm = number();
    else if (arg == "--slab")
      o.slab = number(), o.slab_asked = true;
    else if (arg == "--trace")
      o.trace_speed = number(), o.trace = true;
    else if (arg == "--checkpoint")
      o.pieces.checkpoint = value();
    else if (arg == "--resume")
      o.pieces.resume = value();
    else if (arg == "--every")
      o.pieces.checkpoint_interval = number();
    else if (arg == "--stop-after")
      o.pieces.stop_after = number();
    else if (arg == "--out")
      o.out = value();
    else if (arg == "--data")
      o.data = value();
    else
      return false;
    return true;
  });
  return o;
}

}  // namespace mpskit::cases
