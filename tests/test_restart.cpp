// io/simulation_checkpoint.hpp: checkpoint and restart of the semi-implicit scheme on the Koshizuka &
// Oka dam break (label restart).
#include <doctest/doctest.h>

#include "support/support.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <cstddef>
#include <vector>
#include <filesystem>
#include <string>
#if __has_include(<unistd.h>)
#include <unistd.h>
#endif

#include "cases/dam_break.hpp"
#include "cases/run_pieces.hpp"
#include "mpskit/io/simulation_checkpoint.hpp"
#include "mpskit/ppe/fallback.hpp"
#include "mpskit/ppe/sparse_lu.hpp"

using namespace mpskit;
namespace fs = std::filesystem;

namespace {
/// A scratch directory removed at the end of the test (tests/support).
struct scratch : mpskit::test::scratch {
  explicit scratch(const std::string& name) : mpskit::test::scratch("mpskit_test_restart", name) {}
};

using sim_t = simulation<defaults<2>>;
/// The classic defaults with Eigen's SparseLU behind incomplete-Cholesky CG (ppe/fallback.hpp), and SparseLU
/// alone.
struct fallback_defaults : defaults<2> {
  using solver = ppe::with_fallback<ppe::cg_ichol, ppe::sparse_lu>;
};
struct lu_defaults : defaults<2> {
  using solver = ppe::sparse_lu;
};

/// The dam break of examples/cases/dam_break.hpp at l0 = a/15 (coarse: the test is about restart).
struct dam {
  cases::dam_break_config cfg;
  dam() {
    cfg.l0 = cfg.a / 15;
    cfg.params.l0 = cfg.l0;
  }
  scheme::semi_implicit_state<2> initial() const {
    return cases::tank_state<2>(vec<2>(cfg.a, 2 * cfg.a), vec<2>(4 * cfg.a, 2.5 * cfg.a), cfg.l0);
  }
};

void steps(sim_t& s, int n) {
  for (int k = 0; k < n; ++k) s.step();
}

using mpskit::test::same_bits;

void check_same_counters(const scheme::semi_implicit_counters& a, const scheme::semi_implicit_counters& b) {
  for (long scheme::semi_implicit_counters::*f : scheme::semi_implicit_counter_fields) CHECK(a.*f == b.*f);
}
}  // namespace

TEST_SUITE("restart") {
  TEST_CASE("restart: dam break, 113 steps + save + 100 steps equals load + 100 steps bitwise") {
    scratch tmp("dam");
    const dam d;
    sim_t a(d.cfg.params, d.initial());
    steps(a, 113);  // not a multiple of reorder_every (25): the scheme builds its list every step
    REQUIRE(113 % d.cfg.params.reorder_every != 0);
    io::save_simulation(tmp / "c.mpscp", a);
    steps(a, 100);

    sim_t b(d.cfg.params, d.initial());
    io::load_simulation(tmp / "c.mpscp", b);
    CHECK(b.counters().steps == 113);
    steps(b, 100);

    MESSAGE("A: t = " << a.time() << " s, " << a.counters().steps << " steps, " << a.counters().ppe_iterations
                      << " PPE iterations, dt state {" << a.time_step().state().halvings << ", "
                      << a.time_step().state().held << ", " << a.time_step().state().changes << "}");
    // Reference: the uninterrupted run A. The restart holds every input of the next steps bitwise (state,
    // time, counters, Δt controller); both runs build the list at every step start from the state, so
    // every later operation is the same sequence of floating-point operations: equality, not a tolerance.
    const auto& sa = a.state();
    const auto& sb = b.state();
    REQUIRE(sa.n_real() == sb.n_real());
    CHECK(sa.ids() == sb.ids());
    CHECK(sa.kinds() == sb.kinds());
    CHECK(sa.flags() == sb.flags());
    CHECK(same_bits(sa.x(), sb.x()));
    CHECK(same_bits(sa.u(), sb.u()));
    CHECK(same_bits(sa.get<field::pressure>(), sb.get<field::pressure>()));
    CHECK(same_bits(sa.get<field::number_density>(), sb.get<field::number_density>()));
    CHECK(std::bit_cast<std::uint64_t>(a.time()) == std::bit_cast<std::uint64_t>(b.time()));
    check_same_counters(a.counters(), b.counters());
    CHECK(a.time_step().state().halvings == b.time_step().state().halvings);
    CHECK(a.time_step().state().held == b.time_step().state().held);
    CHECK(a.time_step().state().changes == b.time_step().state().changes);
  }

  TEST_CASE("restart: refused loads name the file and the problem") {
    scratch tmp("bad");
    const dam d;
    sim_t a(d.cfg.params, d.initial());
    steps(a, 3);
    io::save_simulation(tmp / "c.mpscp", a);
    // Into a simulation that has stepped (its list would describe other particles).
    CHECK_THROWS_WITH_AS(io::load_simulation(tmp / "c.mpscp", a), doctest::Contains("already stepped"),
                         mpskit::error);
    // Into a simulation of another spacing.
    auto p = d.cfg.params;
    p.l0 = d.cfg.l0 * 1.5;
    sim_t c(p, cases::tank_state<2>(vec<2>(d.cfg.a, 2 * d.cfg.a), vec<2>(4 * d.cfg.a, 2.5 * d.cfg.a), p.l0));
    CHECK_THROWS_WITH_AS(io::load_simulation(tmp / "c.mpscp", c), doctest::Contains("written with l0"),
                         mpskit::error);
    CHECK(c.counters().steps == 0);  // untouched
    // A plain particle checkpoint without the scheme's sections.
    io::save_checkpoint(tmp / "plain.mpscp", a.state());
    sim_t e(d.cfg.params, d.initial());
    CHECK_THROWS_WITH_AS(io::load_simulation(tmp / "plain.mpscp", e),
                         doctest::Contains("no section 'semi_implicit.time'"), mpskit::error);
    CHECK(e.time() == 0.0);
  }

  TEST_CASE(
      "restart: the classic scheme counts the fallback's solves (ppe_fallbacks), kept in the checkpoint") {
    // ppe::with_fallback<cg_ichol, sparse_lu> in the classic stepper. With CG capped at one iteration it
    // never converges, so every step's PPE is solved by the LU: 10 steps, 10 fallbacks, and the same
    // pressures as SparseLU alone (both are the LU solution of the same system; tolerance 1e-9 of the largest
    // pressure, far above round-off and far below CG's one-iteration error). Uncapped, CG converges and the
    // count stays 0.
    scratch tmp("fallback");
    const dam d;
    auto capped = d.cfg.params;
    capped.solver.max_iterations = 1;
    simulation<fallback_defaults> a(capped, d.initial());
    simulation<lu_defaults> lu(d.cfg.params, d.initial());
    simulation<fallback_defaults> plain(d.cfg.params, d.initial());
    for (int k = 0; k < 10; ++k) {
      a.step();
      lu.step();
      plain.step();
      CHECK(a.last_solve().fallback);
      CHECK(!plain.last_solve().fallback);
    }
    CHECK(a.counters().ppe_fallbacks == 10);
    CHECK(plain.counters().ppe_fallbacks == 0);
    CHECK(lu.counters().ppe_fallbacks == 0);
    const auto& pa = a.state().get<field::pressure>();
    const auto& pl = lu.state().get<field::pressure>();
    REQUIRE(pa.size() == pl.size());
    const double scale = pl.cwiseAbs().maxCoeff(), diff = (pa - pl).cwiseAbs().maxCoeff();
    MESSAGE("after 10 steps: largest pressure " << scale << " Pa, fallback against SparseLU alone " << diff
                                                << " Pa");
    REQUIRE(scale > 0.0);
    CHECK(diff <= 1e-9 * scale);

    // The checkpoint keeps the count; files written before it (8 counters), before ppe_breakdown_restarts (9)
    // or before ppe_cold_restarts (10) load with the missing counters 0.
    io::save_simulation(tmp / "c.mpscp", a);
    simulation<fallback_defaults> b(capped, d.initial());
    io::load_simulation(tmp / "c.mpscp", b);
    check_same_counters(a.counters(), b.counters());
    scheme::semi_implicit_state<2> st;
    io::checkpoint_sections all;
    io::load_checkpoint(tmp / "c.mpscp", st, all);
    std::vector<std::int64_t> v = all.get_int64s("semi_implicit.counters");
    REQUIRE(v.size() == 11);
    CHECK(v[8] == 10);
    CHECK(v[9] == 0);  // no breakdown here
    // Every capped solve started from the previous pressure (a warm start) except the first (from 0): the
    // cold restart (one iteration from 0, solver_params::cold_restart) ran and failed at the other 9 before
    // the LU.
    CHECK(v[10] == 9);
    v[9] = 3;          // a count to read back
    v[10] = 4;
    const auto write = [&](const std::string& name, std::size_t n) {  // the file with the first n counters
      io::checkpoint_sections old;
      old.add_doubles("semi_implicit.time", all.get_doubles("semi_implicit.time"));
      old.add_doubles("semi_implicit.l0", all.get_doubles("semi_implicit.l0"));
      old.add_int64s("semi_implicit.counters",
                     std::vector<std::int64_t>(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n)));
      old.add_int64s("semi_implicit.time_step", all.get_int64s("semi_implicit.time_step"));
      io::save_checkpoint(tmp / name, st, old);
      return tmp / name;
    };
    simulation<fallback_defaults> c11(capped, d.initial());
    io::load_simulation(write("11.mpscp", 11), c11);
    CHECK(c11.counters().ppe_breakdown_restarts == 3);
    CHECK(c11.counters().ppe_cold_restarts == 4);
    simulation<fallback_defaults> c10(capped, d.initial());
    io::load_simulation(write("10.mpscp", 10), c10);
    CHECK(c10.counters().ppe_fallbacks == 10);
    CHECK(c10.counters().ppe_breakdown_restarts == 3);
    CHECK(c10.counters().ppe_cold_restarts == 0);
    simulation<fallback_defaults> c9(capped, d.initial());
    io::load_simulation(write("9.mpscp", 9), c9);
    CHECK(c9.counters().ppe_fallbacks == 10);
    CHECK(c9.counters().ppe_breakdown_restarts == 0);
    simulation<fallback_defaults> c(capped, d.initial());
    io::load_simulation(write("8.mpscp", 8), c);
    CHECK(c.counters().steps == 10);
    CHECK(c.counters().ppe_iterations == a.counters().ppe_iterations);
    CHECK(c.counters().ppe_fallbacks == 0);
    simulation<fallback_defaults> e(capped, d.initial());
    CHECK_THROWS_WITH_AS(io::load_simulation(write("7.mpscp", 7), e),
                         doctest::Contains("holds 7 values, expected 11"), mpskit::error);
    // A file with more counters than this library knows (written by a later one) is refused too, not
    // truncated.
    v.push_back(5);
    simulation<fallback_defaults> f(capped, d.initial());
    CHECK_THROWS_WITH_AS(io::load_simulation(write("12.mpscp", 12), f),
                         doctest::Contains("holds 12 values, expected 11"), mpskit::error);
    CHECK(f.counters().steps == 0);  // untouched
  }

  TEST_CASE(
      "restart: the runners' measure lists and sample columns round-trip bitwise; bad lists are refused") {
    // cases/run_pieces.hpp: what tanaka_dam_break_run.hpp, multi_diameter_channel.hpp and the
    // tanaka_dam_break example save beside the simulation. The values are chosen not to survive a float or a
    // rounding.
    double d = 0.1, wall = 1.0 / 3.0;
    std::int64_t i = -(std::int64_t{1} << 53);  // the most negative integer the list accepts
    std::size_t n = std::size_t{1} << 53;
    int k = 7;
    bool b = true;
    cases::measure_list m;
    m(d)(i)(n)(k)(b).add([&] { return wall; }, [&](double w) { wall = w; });
    CHECK(m.size() == 6);
    io::checkpoint_sections s;
    m.save(s, "x.measures");
    const std::vector<double> T{0.0, 0.25, 0.5}, Z{1.0, 1.1, 1.3}, Zb{1.0, 1.05, std::nan("")};
    cases::add_columns(s, "x.front", {&T, &Z, &Zb});
    const double d0 = d, w0 = wall;
    d = wall = 0.0;
    i = 0;
    n = 0;
    k = 0;
    b = false;
    m.load(s, "x.measures", "test", "memory");
    CHECK(same_bits(d, d0));
    CHECK(same_bits(wall, w0));
    CHECK(i == -(std::int64_t{1} << 53));
    CHECK(n == std::size_t{1} << 53);
    CHECK(k == 7);
    CHECK(b);
    std::vector<double> t2{9.0}, z2, zb2{1.0, 2.0, 3.0, 4.0};  // old contents are replaced, not appended to
    cases::get_columns(s, "x.front", {&t2, &z2, &zb2}, "test", "memory");
    CHECK(t2 == T);
    CHECK(z2 == Z);
    REQUIRE(zb2.size() == 3);
    CHECK(zb2[1] == 1.05);
    CHECK(std::isnan(zb2[2]));
    // Offsets (the multi-diameter channel's three configuration values come first).
    std::vector<double> v{5.0, 6.0};
    const std::vector<double> mv = m.values();
    v.insert(v.end(), mv.begin(), mv.end());
    d = 0.0;
    m.assign(v, 2);
    CHECK(d == 0.1);
    CHECK_THROWS_WITH_AS(m.assign(v, 1), doctest::Contains("8 values for 1 + 6 places"), mpskit::error);
    // Refused: a section of another length, an integer a double would round, no columns, unequal columns, and
    // a section that the reader's columns do not divide.
    io::checkpoint_sections t;
    t.add_doubles("x.measures", {1.0, 2.0});
    CHECK_THROWS_WITH_AS(m.load(t, "x.measures", "test", "f.cp"),
                         doctest::Contains("test: 'f.cp': section 'x.measures' holds 2 values, expected 6"),
                         mpskit::error);
    i = -(std::int64_t{1} << 53) - 1;
    CHECK_THROWS_WITH_AS(m.save(t, "y"), doctest::Contains("beyond 2^53"), mpskit::error);
    i = (std::int64_t{1} << 53) + 1;
    CHECK_THROWS_WITH_AS(m.save(t, "y"), doctest::Contains("beyond 2^53"), mpskit::error);
    i = std::int64_t{1} << 53;
    CHECK_NOTHROW(m.save(t, "y"));
    i = 0;
    n = (std::size_t{1} << 53) + 1;
    CHECK_THROWS_WITH_AS(m.values(), doctest::Contains("beyond 2^53"), mpskit::error);
    // Read back: a value that is not a whole number in the integer's range, or a flag other than 0 or 1.
    std::vector<double> bad = mv;
    bad[1] = 0.5;
    CHECK_THROWS_WITH_AS(m.assign(bad), doctest::Contains("0.5 read for an integer of 63 bits"),
                         mpskit::error);
    bad[1] = mv[1];
    bad[2] = -1.0;
    CHECK_THROWS_WITH_AS(m.assign(bad), doctest::Contains("read for an integer of 64 bits"), mpskit::error);
    bad[2] = std::ldexp(1.0, 64);
    CHECK_THROWS_WITH_AS(m.assign(bad), doctest::Contains("read for an integer of 64 bits"), mpskit::error);
    bad[2] = mv[2];
    bad[3] = std::nan("");
    CHECK_THROWS_WITH_AS(m.assign(bad), doctest::Contains("read for an integer of 31 bits"), mpskit::error);
    bad[3] = mv[3];
    bad[4] = 2.0;
    CHECK_THROWS_WITH_AS(m.assign(bad), doctest::Contains("read for a flag"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::add_columns(t, "z", {}), doctest::Contains("no columns"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::add_columns(t, "z", {&T, &v}), doctest::Contains("columns of 3 and 8 values"),
                         mpskit::error);
    CHECK_FALSE(t.contains("z"));
    CHECK_THROWS_WITH_AS(cases::get_columns(s, "x.front", {}, "test", "f.cp"),
                         doctest::Contains("no columns to read"), mpskit::error);
    CHECK_THROWS_WITH_AS(cases::get_columns(s, "x.front", {&t2, &z2}, "test", "f.cp"),
                         doctest::Contains("section 'x.front' holds 9 values, not a multiple of 2"),
                         mpskit::error);
  }
}
