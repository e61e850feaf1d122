// io/: base64 and checksum vectors, .vtu/.pvd round trips through the project's reader (both encodings,
// 2D and 3D, every field shape) and through meshio and VTK's Python reader when present, malformed files
// refused, CSV series, progress and summary formatting, the largest connected body (suite "io"); checkpoint
// round trip, bitwise restart and refusal of truncated, corrupted, wrong-version and mismatched checkpoints
// (suite "checkpoint").
#include <doctest/doctest.h>

#include "support/support.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "mpskit/core/state.hpp"
#include "mpskit/io/checkpoint.hpp"
#include "mpskit/io/concepts.hpp"
#include "mpskit/io/csv.hpp"
#include "mpskit/io/probes.hpp"
#include "mpskit/io/progress.hpp"
#include "mpskit/io/vtk.hpp"
#include "mpskit/io/vtk_reader.hpp"

#if __has_include(<unistd.h>)
#include <unistd.h>
#endif

using namespace mpskit;
namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t default_seed = 20261122;

/// The seed of this run: MPSKIT_TEST_SEED when set, printed either way.
std::uint64_t test_seed() {
  static const std::uint64_t s = [] {
    const char* e = std::getenv("MPSKIT_TEST_SEED");
    const std::uint64_t v = e ? std::strtoull(e, nullptr, 10) : default_seed;
    MESSAGE("io tests: seed ", v, " (set MPSKIT_TEST_SEED to change)");
    return v;
  }();
  return s;
}

// Test-only fields of integer types the core does not use, to cover every VTK integer width.
struct level : field::integer_base<std::int32_t> {
  static constexpr std::string_view name = "level", units = "1";
};
struct tag16 : field::integer_base<std::uint16_t> {
  static constexpr std::string_view name = "tag16", units = "1";
};
using extra_fields = field_list<field::pressure, field::volume, field::normal, field::partner, level, tag16>;
template <int D>
using state_t = particle_state<D, extra_fields>;

/// A scratch directory removed at the end of the test (tests/support).
struct scratch : mpskit::test::scratch {
  explicit scratch(const std::string& name) : mpskit::test::scratch("mpskit_test_io", name) {}
};

/// Doubles that stress a binary round trip: negative zero, a subnormal, the largest finite, π.
double special_or_random(std::mt19937_64& rng) {
  static const double specials[] = {-0.0, 5e-324, std::numeric_limits<double>::max(), std::numbers::pi};
  std::uniform_int_distribution<int> pick(0, 15);
  const int k = pick(rng);
  if (k < 4) return specials[k];
  return std::uniform_real_distribution<double>(-1e3, 1e3)(rng);
}

/// A state with n real particles (some removed so ids are not contiguous), g ghosts and every field
/// filled with random values.
template <int D>
state_t<D> make_state(index_t n, index_t g, std::mt19937_64& rng) {
  state_t<D> s(n + n / 4);
  std::vector<char> mask(static_cast<std::size_t>(s.n_real()), 0);
  for (std::size_t i = 0; i < mask.size(); i += 5) mask[i] = 1;
  s.remove(mask);
  s.add_ghosts(g, ghost_role::imaginary);
  const index_t m = s.size();
  std::uniform_int_distribution<int> any_kind(0, 4);
  std::uniform_int_distribution<std::uint32_t> bits(0, 63);
  std::uniform_int_distribution<index_t> any_index(-1, m - 1),
      any_real(0, std::max<index_t>(s.n_real() - 1, 0));
  std::uniform_int_distribution<std::int32_t> any_level(-100000, 100000);
  std::uniform_int_distribution<std::uint32_t> any_tag(0, 65535);
  for (index_t i = 0; i < m; ++i) {
    const std::size_t k = static_cast<std::size_t>(i);
    for (int a = 0; a < D; ++a) {
      s.x()(a, i) = special_or_random(rng);
      s.u()(a, i) = special_or_random(rng);
      s.template get<field::normal>()(a, i) = special_or_random(rng);
    }
    s.template get<field::pressure>()[i] = special_or_random(rng);
    s.template get<field::volume>()[i] = special_or_random(rng);
    s.kinds()[k] = static_cast<kind>(any_kind(rng));
    s.flags()[k] = bits(rng);
    s.template get<field::partner>()[k] = any_index(rng);
    s.template get<level>()[k] = any_level(rng);
    s.template get<tag16>()[k] = static_cast<std::uint16_t>(any_tag(rng));
    if (i >= s.n_real()) s.template get<field::parent>()[k] = any_real(rng);
  }
  return s;
}

/// Byte-wise equality of one field's storage (doubles compared bitwise: -0.0 ≠ 0.0, NaN == same NaN).
template <class S>
bool same_bytes(const S& a, const S& b) {
  if (a.size() != b.size()) return false;
  using V = std::remove_cvref_t<decltype(*a.data())>;
  return a.size() == 0 ||
         std::memcmp(a.data(), b.data(), static_cast<std::size_t>(a.size()) * sizeof(V)) == 0;
}

/// Every field, the counts and the next id equal bitwise; names the first field that differs.
template <class State>
std::string state_difference(const State& a, const State& b) {
  if (a.n_real() != b.n_real() || a.n_ghost() != b.n_ghost() || a.next_id() != b.next_id()) return "layout";
  std::string diff;
  State::for_each_field([&](auto tag) {
    using T = decltype(tag);
    if (diff.empty() && !same_bytes(a.template get<T>(), b.template get<T>())) diff = std::string(T::name);
  });
  return diff;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void dump(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
}

/// Runs f, expects an mpskit::error whose message contains every piece.
template <class F>
void check_refused(F&& f, std::initializer_list<std::string> pieces) {
  std::string msg;
  try {
    f();
  } catch (const error& e) {
    msg = e.what();
  }
  CAPTURE(msg);
  REQUIRE(!msg.empty());
  for (const auto& p : pieces) CHECK(msg.find(p) != std::string::npos);
}

/// Checks a read .vtu against the state it was written from: every array bitwise.
template <int D>
void check_vtu_matches(const io::vtu_file& f, const state_t<D>& s, index_t n) {
  REQUIRE(f.n_points == n);
  const std::size_t un = static_cast<std::size_t>(n);
  const std::vector<double> pts = f.points.values<double>();
  REQUIRE(pts.size() == 3 * un);
  index_t mismatches = 0;
  for (std::size_t i = 0; i < un; ++i)
    for (int a = 0; a < 3; ++a) {
      const double want = a < D ? s.x()(a, static_cast<index_t>(i)) : 0.0;
      mismatches += std::memcmp(&pts[3 * i + static_cast<std::size_t>(a)], &want, sizeof want) != 0;
    }
  CHECK(mismatches == 0);
  CHECK(f.points.units == "m");
  state_t<D>::for_each_field([&](auto tag) {
    using T = decltype(tag);
    if constexpr (!std::same_as<T, field::position>) {
      CAPTURE(T::name);
      REQUIRE(f.has(T::name));
      const io::vtu_array& a = f.point_array(T::name);
      CHECK(a.units == io::detail::resolve_units(T::units, D));
      const auto& st = s.template get<T>();
      if constexpr (T::shape == field_shape::vector) {
        REQUIRE(a.components == 3);
        const std::vector<double> v = a.values<double>();
        index_t bad = 0;
        for (std::size_t i = 0; i < un; ++i)
          for (int c = 0; c < 3; ++c) {
            const double want = c < D ? st(c, static_cast<index_t>(i)) : 0.0;
            bad += std::memcmp(&v[3 * i + static_cast<std::size_t>(c)], &want, sizeof want) != 0;
          }
        CHECK(bad == 0);
      } else if constexpr (T::shape == field_shape::scalar) {
        REQUIRE(a.type == "Float64");
        const std::vector<double> v = a.values<double>();
        CHECK(std::memcmp(v.data(), st.data(), un * sizeof(double)) == 0);
      } else {
        using U = io::detail::underlying_t<typename T::value_type>;
        const std::vector<U> v = a.values<U>();
        CHECK(std::memcmp(v.data(), st.data(), un * sizeof(U)) == 0);
      }
    }
  });
}

/// A python3 that can import `module`, or "" (MPSKIT_PYTHON, then /usr/bin/python3, then python3 on
/// PATH: Debian's python3-meshio and python3-vtk9 install for the system interpreter only).
std::string python_with(const std::string& module) {
  std::vector<std::string> candidates;
  if (const char* e = std::getenv("MPSKIT_PYTHON")) candidates.emplace_back(e);
  candidates.emplace_back("/usr/bin/python3");
  candidates.emplace_back("python3");
  for (const auto& py : candidates)
    if (std::system((py + " -c \"import " + module + "\" >/dev/null 2>&1").c_str()) == 0) return py;
  return "";
}

// Python scripts that read a .vtu with an external reader and print every array as "name kind count"
// then one value per line: floats with repr (shortest round trip, so the comparison is bitwise),
// integers as integers; then "CELLS <type> <count>" and "TIME <repr>".
constexpr const char* dump_put =
    "import sys\n"
    "out = open(sys.argv[2], 'w')\n"
    "def put(name, a):\n"
    "    a = a.ravel()\n"
    "    kind = 'f' if a.dtype.kind == 'f' else 'i'\n"
    "    out.write('%s %s %d\\n' % (name, kind, a.size))\n"
    "    for v in a: out.write((repr(float(v)) if kind == 'f' else str(int(v))) + '\\n')\n";
constexpr const char* meshio_dump =
    "import meshio\n"
    "m = meshio.read(sys.argv[1])\n"
    "put('POINTS', m.points)\n"
    "for name, a in m.point_data.items(): put(name, a)\n"
    "out.write('CELLS %s %d\\n' % (m.cells[0].type, len(m.cells[0].data)))\n"
    "out.write('TIME %s\\n' % repr(float(m.field_data['TimeValue'][0])))\n";
constexpr const char* vtk_dump =
    "from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader\n"
    "from vtkmodules.util.numpy_support import vtk_to_numpy\n"
    "errors = []\n"
    "r = vtkXMLUnstructuredGridReader()\n"
    "r.AddObserver('ErrorEvent', lambda o, e: errors.append(e))\n"
    "r.SetFileName(sys.argv[1])\n"
    "r.Update()\n"
    "if errors: sys.exit('vtk reader reported an error')\n"
    "g = r.GetOutput()\n"
    "put('POINTS', vtk_to_numpy(g.GetPoints().GetData()))\n"
    "pd = g.GetPointData()\n"
    "for k in range(pd.GetNumberOfArrays()): put(pd.GetArray(k).GetName(), vtk_to_numpy(pd.GetArray(k)))\n"
    "n = g.GetNumberOfCells()\n"
    "out.write('CELLS %s %d\\n' % ('vertex' if all(g.GetCellType(i) == 1 for i in range(n)) else 'other', "
    "n))\n"
    "out.write('TIME %s\\n' % repr(g.GetFieldData().GetArray('TimeValue').GetValue(0)))\n";

/// Runs an external reader on `vtu` and checks every array it reports against our reader, bitwise.
void check_external_reader(const std::string& py, const char* body, const fs::path& vtu, const scratch& tmp,
                           index_t n_points, double time, index_t n_arrays) {
  const fs::path txt = tmp / "dump.txt", script = tmp / "dump.py";
  dump(script, std::string(dump_put) + body);
  const std::string cmd = py + " " + script.string() + " " + vtu.string() + " " + txt.string();
  REQUIRE(std::system(cmd.c_str()) == 0);
  const io::vtu_file ours = io::read_vtu(vtu);
  std::ifstream in(txt);
  std::string name, kind_s;
  index_t arrays = 0;
  bool cells = false, have_time = false;
  while (in >> name >> kind_s) {
    CAPTURE(name);
    if (name == "TIME") {
      double t = 0.0;
      std::from_chars(kind_s.data(), kind_s.data() + kind_s.size(), t);
      CHECK(t == time);
      have_time = true;
      continue;
    }
    std::size_t count = 0;
    in >> count;
    if (name == "CELLS") {
      CHECK(kind_s == "vertex");
      CHECK(count == static_cast<std::size_t>(n_points));
      cells = true;
      continue;
    }
    const io::vtu_array& a = name == "POINTS" ? ours.points : ours.point_array(name);
    REQUIRE(count == static_cast<std::size_t>(a.tuples * a.components));
    index_t bad = 0;
    if (kind_s == "f") {
      const std::vector<double> want = a.values<double>();
      for (std::size_t k = 0; k < count; ++k) {
        std::string v;
        in >> v;
        double got = 0.0;
        std::from_chars(v.data(), v.data() + v.size(), got);
        bad += std::memcmp(&got, &want[k], sizeof got) != 0;
      }
    } else {
      const std::vector<double> want = a.as_doubles();  // ids < 2^53 and small ints are exact as doubles
      for (std::size_t k = 0; k < count; ++k) {
        long double v = 0;
        in >> v;
        bad += static_cast<double>(v) != want[k];
      }
    }
    CHECK(bad == 0);
    ++arrays;
  }
  CHECK(arrays == n_arrays);
  CHECK(cells);
  CHECK(have_time);
}

// A deterministic toy "scheme" for the restart test: explicit update of x, u, p with a controller whose
// Δt halves when the speed is high and doubles after 4 calm steps (like scheme/time_step's hysteresis).
struct toy_controller {
  double dt = 1e-3;
  std::int64_t calm = 0;
  void save(io::checkpoint_sections& s) const {
    s.add("toy.dt", dt);
    s.add("toy.calm", calm);
  }
  void load(const io::checkpoint_sections& s) {
    dt = s.get_double("toy.dt");
    calm = s.get_int64("toy.calm");
  }
};
static_assert(io::Checkpointable<toy_controller> && !io::Checkpointable<int>);
static_assert(io::ParticleState<state_t<2>> && io::ParticleState<state_t<3>> && !io::ParticleState<int>);

template <class State>
void toy_step(State& s, toy_controller& c, double& t, std::int64_t& step) {
  double umax = 0.0;
  auto& p = s.template get<field::pressure>();
  for (index_t i = 0; i < s.n_real(); ++i) {
    // A nonlinear oscillator with a pressure-like memory: every stored value feeds the next step.
    for (int a = 0; a < State::dim; ++a) {
      s.u()(a, i) += c.dt * (-std::sin(s.x()(a, i)) - 0.1 * p[i]);
      s.x()(a, i) += c.dt * s.u()(a, i);
    }
    p[i] = 0.5 * p[i] + std::cos(s.x().col(i).norm());
    umax = std::max(umax, s.u().col(i).norm());
  }
  if (umax * c.dt > 0.02) {
    c.dt *= 0.5;
    c.calm = 0;
  } else if (++c.calm >= 4) {
    c.dt *= 2.0;
    c.calm = 0;
  }
  t += c.dt;
  ++step;
}

}  // namespace

TEST_SUITE("io") {
  TEST_CASE("io: base64 and FNV-1a match their published test vectors") {
    // RFC 4648 §10 test vectors.
    const std::pair<std::string, std::string> b64[] = {{"", ""},
                                                       {"f", "Zg=="},
                                                       {"fo", "Zm8="},
                                                       {"foo", "Zm9v"},
                                                       {"foob", "Zm9vYg=="},
                                                       {"fooba", "Zm9vYmE="},
                                                       {"foobar", "Zm9vYmFy"}};
    for (const auto& [plain, enc] : b64) {
      std::string e, d;
      io::detail::base64_encode(plain, e);
      CHECK(e == enc);
      CHECK(io::detail::base64_decode(enc, d));
      CHECK(d == plain);
    }
    // Two streams back to back (a VTK header encoded apart from its data) decode as their concatenation.
    std::string d;
    CHECK(io::detail::base64_decode("Zg==Zm9vYmFy", d));
    CHECK(d == "ffoobar");
    CHECK(!io::detail::base64_decode("Zm9v*", d));
    CHECK(!io::detail::base64_decode("Zm9vY", d));
    // FNV-1a 64 reference values (Fowler–Noll–Vo test suite: "", "a", "foobar").
    CHECK(io::detail::fnv1a64("") == 0xcbf29ce484222325ull);
    CHECK(io::detail::fnv1a64("a") == 0xaf63dc4c8601ec8cull);
    CHECK(io::detail::fnv1a64("foobar") == 0x85944171f73967e8ull);
  }

  TEST_CASE_TEMPLATE("io: .vtu round trip is bitwise for every field, both encodings", Dim, dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    std::mt19937_64 rng(test_seed() + D);
    const state_t<D> s = make_state<D>(57, 11, rng);
    scratch tmp("vtu" + std::to_string(D));
    for (const io::vtk_encoding enc : {io::vtk_encoding::base64, io::vtk_encoding::raw_appended}) {
      for (const bool ghosts : {false, true}) {
        for (const bool in_names : {false, true}) {
          CAPTURE(int(enc));
          CAPTURE(ghosts);
          CAPTURE(in_names);
          const fs::path p = tmp / "s.vtu";
          io::vtu_options opt;
          opt.encoding = enc;
          opt.include_ghosts = ghosts;
          opt.units_in_names = in_names;
          opt.time = 0.1 + 0.2;  // not representable in few digits: the round trip must keep all 17
          opt.step = 42;
          io::write_vtu(p, s, opt);
          const io::vtu_file f = io::read_vtu(p);
          check_vtu_matches<D>(f, s, ghosts ? s.size() : s.n_real());
          REQUIRE(f.time.has_value());
          CHECK(*f.time == 0.1 + 0.2);
          CHECK(f.step == 42);
          CHECK(f.point_array("volume").units == (D == 2 ? "m^2" : "m^3"));
          // One VTK_VERTEX cell per particle.
          REQUIRE(f.cells.size() == 3);
          const std::vector<std::int64_t> conn = f.cells[0].values<std::int64_t>();
          const std::vector<std::int64_t> off = f.cells[1].values<std::int64_t>();
          const std::vector<std::uint8_t> types = f.cells[2].values<std::uint8_t>();
          REQUIRE(conn.size() == static_cast<std::size_t>(f.n_points));
          bool ok = off.size() == conn.size() && types.size() == conn.size();
          for (std::size_t i = 0; ok && i < conn.size(); ++i)
            ok = conn[i] == static_cast<std::int64_t>(i) && off[i] == static_cast<std::int64_t>(i + 1) &&
                 types[i] == 1;
          CHECK(ok);
          // Restoring a state from the output gives back the same particles bitwise.
          if (!in_names) {
            state_t<D> r;
            io::read_state(f, r);
            state_t<D> want = s;
            if (!ghosts) want.clear_ghosts();
            // next_id is rebuilt as max id + 1 (removed particles after the last one are unknown to a .vtu).
            CHECK(state_difference(r, want) == (r.next_id() == want.next_id() ? "" : "layout"));
            CHECK(r.n_real() == s.n_real());
          }
        }
      }
    }
  }

  TEST_CASE("io: an empty state writes and reads back") {
    scratch tmp("empty");
    particle_state<2> s;
    for (const io::vtk_encoding enc : {io::vtk_encoding::base64, io::vtk_encoding::raw_appended}) {
      io::write_vtu(tmp / "e.vtu", s, {.encoding = enc});
      const io::vtu_file f = io::read_vtu(tmp / "e.vtu");
      CHECK(f.n_points == 0);
      CHECK(f.points.bytes.empty());
      CHECK(!f.time.has_value());
    }
  }

  TEST_CASE("io: malformed, truncated and foreign .vtu files are refused naming the file") {
    std::mt19937_64 rng(test_seed());
    const state_t<3> s = make_state<3>(20, 0, rng);
    scratch tmp("bad_vtu");
    const fs::path good64 = tmp / "b64.vtu", goodraw = tmp / "raw.vtu", bad = tmp / "bad.vtu";
    io::write_vtu(good64, s);
    io::write_vtu(goodraw, s, {.encoding = io::vtk_encoding::raw_appended});
    const std::string b64 = slurp(good64), raw = slurp(goodraw);

    check_refused([&] { io::read_vtu(tmp / "missing.vtu"); }, {"missing.vtu", "cannot open"});
    dump(bad, b64.substr(0, b64.size() / 2));
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "not closed"});
    dump(bad, raw.substr(0, raw.size() - 40));
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "truncated"});
    // A raw block cut inside the data, with the closing tags kept: the offsets run past the end.
    const std::size_t us = raw.find('_', raw.find("<AppendedData"));
    dump(bad, raw.substr(0, us + 100) + "\n</AppendedData>\n</VTKFile>\n");
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "truncated"});
    std::string t = b64;
    t.replace(t.find("format=\"binary\">") + 30, 1, "*");
    dump(bad, t);
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "invalid base64"});
    t = b64;
    t.replace(t.find("header_type=\"UInt64\""), 20, "header_type=\"Int128\"");
    dump(bad, t);
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "header_type"});
    t = b64;
    t.replace(t.find("NumberOfPoints=\"20\""), 19, "NumberOfPoints=\"21\"");
    dump(bad, t);
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "tuples, expected 21"});
    t = b64;
    t.replace(t.find("UnstructuredGrid\""), 17, "PolyData\"");
    dump(bad, t);
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "UnstructuredGrid"});
    t = b64;
    t.replace(t.find("</PointData>"), 12, "</PointDatum>");
    dump(bad, t);
    check_refused([&] { io::read_vtu(bad); }, {"bad.vtu", "does not match"});
    check_refused([&] { io::read_vtu(good64).point_array("no_such"); }, {"b64.vtu", "no_such"});
    // Output into a directory that does not exist.
    check_refused([&] { io::write_vtu(tmp / "nowhere" / "x.vtu", s); }, {"nowhere", "does not exist"});
  }

  TEST_CASE("io: .pvd lists files with their times in order; restart keeps the earlier part") {
    std::mt19937_64 rng(test_seed());
    const state_t<2> s = make_state<2>(10, 3, rng);
    scratch tmp("pvd");
    io::vtk_series series(tmp / "out" / "case");
    const double times[] = {0.0, 0.1, 0.25, 0.25, 1.0 / 3.0};
    for (std::size_t k = 0; k < std::size(times); ++k) series.write(s, times[k], static_cast<index_t>(k));
    const fs::path pvd = tmp / "out" / "case.pvd";
    const std::vector<io::pvd_entry> e = io::read_pvd(pvd);
    REQUIRE(e.size() == std::size(times));
    for (std::size_t k = 0; k < e.size(); ++k) {
      CAPTURE(k);
      CHECK(e[k].time == times[k]);  // shortest round-trip text: exact
      CHECK(e[k].file.generic_string() == "case_00000" + std::to_string(k) + ".vtu");
      const io::vtu_file f = io::read_vtu(pvd.parent_path() / e[k].file);
      CHECK(f.time == times[k]);
      CHECK(f.step == static_cast<index_t>(k));
    }
    check_refused([&] { io::pvd_series(tmp / "x.pvd", e).add(0.2, tmp / "y.vtu"); },
                  {"x.pvd", "must not decrease"});
    check_refused([&] { io::pvd_series(tmp / "x.pvd").add(std::nan(""), tmp / "y.vtu"); },
                  {"x.pvd", "not finite"});
    // Restart at t = 0.25: later entries dropped, numbering continues.
    io::vtk_series resumed(tmp / "out" / "case", {}, io::read_pvd(pvd, 0.25));
    CHECK(resumed.files_written() == 4);
    CHECK(resumed.write(s, 0.3).filename() == "case_000004.vtu");
    const std::vector<io::pvd_entry> e2 = io::read_pvd(pvd);
    REQUIRE(e2.size() == 5);
    CHECK(e2.back().time == 0.3);
    check_refused([&] { io::read_pvd(tmp / "out" / "case_000000.vtu"); }, {"case_000000.vtu", "Collection"});
  }

  TEST_CASE_TEMPLATE("io: meshio and VTK's own reader read the .vtu with the same values", Dim, dim<2>,
                     dim<3>) {
    constexpr int D = Dim::value;
    std::mt19937_64 rng(test_seed() + 10 + D);
    const state_t<D> s = make_state<D>(23, 4, rng);
    scratch tmp("external" + std::to_string(D));
    // Points plus every field but the position (which is the points).
    const index_t n_arrays = static_cast<index_t>(state_t<D>::fields::size);
    const double t = 0.1 + 0.2;
    if (const std::string py = python_with("meshio"); py.empty()) {
      MESSAGE("meshio not found (apt-get install python3-meshio): meshio round trip skipped");
    } else {
      io::write_vtu(tmp / "m.vtu", s, {.time = t});
      check_external_reader(py, meshio_dump, tmp / "m.vtu", tmp, s.n_real(), t, n_arrays);
    }
    if (const std::string py = python_with("vtkmodules.vtkIOXML"); py.empty()) {
      MESSAGE("VTK's Python modules not found (apt-get install python3-vtk9): VTK reader round trip skipped");
    } else {
      for (const io::vtk_encoding enc : {io::vtk_encoding::base64, io::vtk_encoding::raw_appended}) {
        CAPTURE(int(enc));
        io::write_vtu(tmp / "v.vtu", s, {.encoding = enc, .include_ghosts = true, .time = t});
        check_external_reader(py, vtk_dump, tmp / "v.vtu", tmp, s.size(), t, n_arrays);
      }
    }
  }

  TEST_CASE("io: CSV series writes units in the header, exact values, and refuses bad rows") {
    scratch tmp("csv");
    const fs::path p = tmp / "probes.csv";
    {
      io::csv_writer w(p, {{"time", "s"}, {"p_probe0", "Pa"}, {"u_probe0", "m/s"}});
      w.row({0.0, 101325.0, -0.0});
      w.row({0.1 + 0.2, 1.0 / 3.0, 5e-324});
      check_refused([&] { w.row({1.0, 2.0}); }, {"probes.csv", "row 2 has 2 values", "3 columns"});
      CHECK(w.rows() == 2);
    }
    {
      io::csv_writer w(p, {{"time", "s"}, {"p_probe0", "Pa"}, {"u_probe0", "m/s"}}, io::csv_mode::append);
      w.row({0.5, 2.0, std::numeric_limits<double>::infinity()});
    }
    std::ifstream in(p);
    std::string line;
    std::getline(in, line);
    CHECK(line == "time [s],p_probe0 [Pa],u_probe0 [m/s]");
    const double want[3][3] = {{0.0, 101325.0, -0.0},
                               {0.1 + 0.2, 1.0 / 3.0, 5e-324},
                               {0.5, 2.0, std::numeric_limits<double>::infinity()}};
    for (const auto& row : want) {
      REQUIRE(std::getline(in, line));
      std::istringstream ls(line);
      std::string cell;
      for (const double w : row) {
        REQUIRE(std::getline(ls, cell, ','));
        double v = 0.0;
        std::from_chars(cell.data(), cell.data() + cell.size(), v);
        CHECK(std::memcmp(&v, &w, sizeof v) == 0);
      }
    }
    CHECK(!std::getline(in, line));
    check_refused(
        [&] {
          io::csv_writer(p, {{"time", "s"}}, io::csv_mode::append);
        },
        {"probes.csv", "header"});
    check_refused([&] { io::csv_writer(tmp / "x.csv", {{"a,b", "s"}}); }, {"x.csv", "column 0"});
    check_refused([&] { io::csv_writer(tmp / "x.csv", {}); }, {"x.csv", "no columns"});
    check_refused([&] { io::csv_writer(tmp / "no" / "x.csv", {{"t", "s"}}); }, {"x.csv", "cannot open"});
  }

  TEST_CASE_TEMPLATE("io: LSMPS type B probes are exact for linear fields, kernel probes for constants", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    std::mt19937_64 rng(test_seed() + 400 + D);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    // A jittered lattice of spacing l0 (jitter ±0.3 l0) filling [0, m l0)^D.
    const double l0 = 0.01;
    const int m = D == 2 ? 20 : 8;
    const index_t n = D == 2 ? m * m : m * m * m;
    particle_state<D, field_list<field::pressure>> s(n);
    for (index_t i = 0; i < n; ++i) {
      index_t r = i;
      for (int a = 0; a < D; ++a, r /= m)
        s.x()(a, i) = (static_cast<double>(r % m) + 0.5 + 0.3 * U(rng)) * l0;
    }
    // Linear fields p = p0 + b·x, u = u0 + A x with random coefficients.
    const double p0 = 1000.0 * U(rng);
    vec<D> b, u0;
    mat<D> A;
    for (int a = 0; a < D; ++a) {
      b[a] = 1e4 * U(rng);
      u0[a] = U(rng);
      for (int c = 0; c < D; ++c) A(a, c) = 100.0 * U(rng);
    }
    for (index_t i = 0; i < n; ++i) {
      s.template get<field::pressure>()[i] = p0 + b.dot(s.x().col(i));
      s.u().col(i) = u0 + A * s.x().col(i);
    }
    std::vector<io::probe_point<D>> probes;
    for (int k = 0; k < 6; ++k) {
      vec<D> q;
      for (int a = 0; a < D; ++a) q[a] = (0.5 * m + 0.35 * m * U(rng)) * l0;  // inside, at random offsets
      probes.push_back({"P" + std::to_string(k), q});
    }
    probes.push_back({"air", vec<D>::Constant(-10.0 * l0)});  // no particle within re: NaN
    scratch tmp("probes" + std::to_string(D));
    const double re = 3.1 * l0;
    io::probe_set<decltype(s)> lin(tmp / "lin.csv", probes, re, 3);
    io::probe_set<decltype(s), io::kernel_interpolation<D>> ker(tmp / "ker.csv", probes, re);
    int rows = 0;
    for (index_t step = 0; step < 10; ++step) rows += lin.sample(s, 0.01 * static_cast<double>(step), step);
    CHECK(rows == 4);  // steps 0, 3, 6, 9
    CHECK(lin.csv().rows() == 4);
    const std::vector<double>& row = lin.last_row();
    REQUIRE(row.size() == 2 + probes.size() * (1 + D));
    CHECK(row[0] == 0.09);
    CHECK(row[1] == 9.0);
    for (std::size_t k = 0; k + 1 < probes.size(); ++k) {
      CAPTURE(k);
      const vec<D>& q = probes[k].x;
      // Exact up to rounding: values are O(1e3) Pa and O(1) m/s; the moment matrices have rcond ~ 0.1
      // (re = 3.1 l0, ~30 neighbours in 2D), so the error is a few ulps of the largest term.
      CHECK(std::abs(row[2 + k * (1 + D)] - (p0 + b.dot(q))) < 1e-9);
      const vec<D> uq = u0 + A * q;
      for (int a = 0; a < D; ++a)
        CHECK(std::abs(row[3 + k * (1 + D) + static_cast<std::size_t>(a)] - uq[a]) < 1e-12);
    }
    for (std::size_t c = 2 + (probes.size() - 1) * (1 + D); c < row.size(); ++c) CHECK(std::isnan(row[c]));
    // Kernel interpolation: exact for a constant field (weights sum to 1), not for the linear one.
    s.template get<field::pressure>().setConstant(p0);
    ker.sample(s, 0.0, 0);
    for (std::size_t k = 0; k + 1 < probes.size(); ++k)
      CHECK(ker.last_row()[2 + k * (1 + D)] == doctest::Approx(p0).epsilon(1e-14));
    std::ifstream in(tmp / "lin.csv");
    std::string comment, header;
    std::getline(in, comment);
    std::getline(in, header);
    CHECK(comment.find("LSMPS type B, first order") != std::string::npos);
    CHECK(header.starts_with("time [s],step [1],P0.p [Pa],P0.u_x [m/s],P0.u_y [m/s]"));
    check_refused([&] { io::probe_set<decltype(s)>(tmp / "x.csv", probes, 0.0); }, {"x.csv", "re = 0"});
    check_refused([&] { io::probe_set<decltype(s)>(tmp / "x.csv", probes, re, 0); }, {"x.csv", "every = 0"});
  }

  TEST_CASE("io: integrals and surge front on a lattice match closed forms") {
    // m × m fluid particles at (i + 1/2) l0, (j + 1/2) l0 moving with u = (1, 2): closed forms below.
    const int m = 10;
    const double l0 = 0.02, rho = 1000.0, g = 9.81;
    particle_state<2> s(m * m + 3);
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) {
        const index_t k = j * m + i;
        s.x().col(k) << (i + 0.5) * l0, (j + 0.5) * l0;
        s.u().col(k) << 1.0, 2.0;
      }
    for (index_t k = m * m; k < s.size(); ++k) {
      s.kinds()[static_cast<std::size_t>(k)] = kind::wall;  // walls are not counted by default
      s.x().col(k) << 100.0, 100.0;
    }
    const io::flow_integrals r = io::integrals(s, rho, vec<2>(0.0, -g), l0 * l0);
    const double V = m * m * l0 * l0, M = rho * V;
    CHECK(r.particles == m * m);
    CHECK(r.volume == doctest::Approx(V).epsilon(1e-13));
    CHECK(r.mass == doctest::Approx(M).epsilon(1e-13));
    CHECK(r.kinetic_energy == doctest::Approx(0.5 * M * 5.0).epsilon(1e-13));
    // Σ y = m Σ_j (j + 1/2) l0 = m · m²/2 · l0 → E_p = ρ l0² g · m³ l0 / 2 = M g (m l0)/2 (centre of mass
    // height).
    CHECK(r.potential_energy == doctest::Approx(M * g * 0.5 * m * l0).epsilon(1e-13));
    CHECK(io::front_position(s, 0) == doctest::Approx((m - 0.5) * l0).epsilon(1e-15));
    CHECK(io::front_position(s, 0, 0.5 * l0) == doctest::Approx(m * l0).epsilon(1e-15));
    CHECK(io::front_position(s, 0, 0.0, io::mask_of(kind::wall)) == 100.0);
    CHECK(std::isnan(io::front_position(s, 0, 0.0, io::mask_of(kind::body))));
    check_refused([&] { io::front_position(s, 2); }, {"axis = 2"});
    check_refused([&] { io::integrals(s, -1.0, vec<2>(0.0, -g), l0 * l0); }, {"rho = -1"});
    check_refused([&] { io::integrals(s, rho, vec<2>(0.0, -g)); }, {"particle_volume = 0"});
    scratch tmp("integrals");
    io::csv_writer w(tmp / "i.csv", io::flow_integrals::columns(2));
    w.row(r.values(0.5));
    std::ifstream in(tmp / "i.csv");
    std::string header;
    std::getline(in, header);
    CHECK(header ==
          "time [s],particles [1],volume [m^2],mass [kg/m],kinetic_energy [J/m],potential_energy [J/m]");
  }

  TEST_CASE(
      "io: largest_body keeps the bulk and its chains, leaves detached clusters out, and matches brute "
      "force") {
    // A 6 × 6 block of unit diameters at integer points, a chain running right from it at spacing 1.4 (< link
    // 1.5: linked), and a 2 × 2 cluster beyond the chain's tip at 1.6 (> 1.5: detached, as spray is).
    std::vector<vec<2>> p;
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i) p.emplace_back(i, j);
    const int chain = 5;
    for (int k = 1; k <= chain; ++k) p.emplace_back(5.0 + 1.4 * k, 0.0);
    const double tip = 5.0 + 1.4 * chain;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) p.emplace_back(tip + 1.6 + i, j);
    const index_t n = static_cast<index_t>(p.size());
    points<2> x(2, n);
    for (index_t i = 0; i < n; ++i) x.col(i) = p[static_cast<std::size_t>(i)];
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n);
    const auto all = [](index_t) { return true; };
    auto front = [&](const std::vector<char>& m) {
      double f = -1e300;
      for (index_t i = 0; i < n; ++i)
        if (m[static_cast<std::size_t>(i)]) f = std::max(f, x(0, i));
      return f;
    };
    std::vector<char> m = io::largest_body(x, d, n, all);
    CHECK(std::count(m.begin(), m.end(), 1) == 36 + chain);
    CHECK(front(m) == tip);  // the chain's tip, not the cluster 1.6 beyond it
    // With link 1.7 the cluster joins; with 1.3 the chain does not (its first link is 1.4).
    CHECK(front(io::largest_body(x, d, n, all, 1.7)) == doctest::Approx(tip + 2.6).epsilon(1e-15));
    m = io::largest_body(x, d, n, all, 1.3);
    CHECK(std::count(m.begin(), m.end(), 1) == 36);
    // The link scales with (d_i + d_j)/2: halving every diameter is link 0.75 in these units.
    // No pair is linked then, every particle is a body of its own, and the tie goes to particle 0.
    m = io::largest_body(x, Eigen::VectorXd(0.5 * d), n, all);
    CHECK(std::count(m.begin(), m.end(), 1) == 1);
    CHECK(m[0] == 1);
    // A particle that is not counted neither belongs nor bridges: drop the chain's first particle.
    m = io::largest_body(x, d, n, [&](index_t i) { return i != 36; });
    CHECK(std::count(m.begin(), m.end(), 1) == 36);
    CHECK(m[36] == 0);
    // The body with the largest Σ d^D wins, not the most particles: the 4-particle cluster at diameter 4
    // (Σ d² = 64, its members 1 apart and linked) against the block's 36 + the chain's 5 (41).
    Eigen::VectorXd big = d;
    big.tail(4).setConstant(4.0);
    const index_t far_cluster = 36 + chain;
    // Diameter 4 also links the cluster to the chain's tip (1.6 < 1.5 · 2.5): move it away first.
    points<2> y = x;
    for (index_t i = far_cluster; i < n; ++i) y(0, i) += 100.0;
    m = io::largest_body(y, big, n, all);
    CHECK(std::count(m.begin(), m.end(), 1) == 4);
    CHECK(m[static_cast<std::size_t>(far_cluster)] == 1);
    // Ties go to the body holding the lowest index: two equal blocks.
    points<2> two(2, 8);
    for (int k = 0; k < 4; ++k) {
      two.col(k) << k % 2, k / 2;
      two.col(4 + k) << 10.0 + k % 2, k / 2;
    }
    m = io::largest_body(two, Eigen::VectorXd::Ones(8), 8, all);
    CHECK(std::vector<char>(m.begin(), m.begin() + 4) == std::vector<char>(4, 1));
    CHECK(std::vector<char>(m.begin() + 4, m.end()) == std::vector<char>(4, 0));
    // Nothing counted: no member. Bad input refused.
    m = io::largest_body(x, d, n, [](index_t) { return false; });
    CHECK(std::count(m.begin(), m.end(), 1) == 0);
    check_refused([&] { io::largest_body(x, d, n + 1, all); }, {"n = ", "exceeds"});
    check_refused([&] { io::largest_body(x, d, n, all, 0.0); }, {"link = 0"});
    Eigen::VectorXd bad = d;
    bad[3] = 0.0;
    check_refused([&] { io::largest_body(x, bad, n, all); }, {"particle 3"});
    points<2> far = x;
    // the block's top-left corner 1e19 cells up: int64_t would overflow
    far(1, 30) = 1e19 * 1.5 * d.maxCoeff();
    check_refused([&] { io::largest_body(far, d, n, all); }, {"particle 30", "along axis 1", "4e18 cells"});
    // far, but representable: a body of its own, the block stays the body
    far(1, 30) = 1e17 * 1.5 * d.maxCoeff();
    m = io::largest_body(far, d, n, all);
    CHECK(m[30] == 0);
    CHECK(std::count(m.begin(), m.end(), 1) == 35 + chain);

    // Random clouds in 2D and 3D with diameters in [0.5, 1.5]: the grid's components equal those of an
    // all-pairs search (a graph search over every pair), so no link across cells is missed.
    std::mt19937_64 rng(test_seed());
    // With periodic axes (search::domain) the links use the minimum image, and the all-pairs search does too.
    // The cloud fills the box [−box/2, box/2) (per axis).
    auto compare = [&]<int D>(std::integral_constant<int, D>, int count, const vec<D>& box,
                              const search::domain<D>& dom) {
      std::uniform_real_distribution<double> u(0.0, 1.0), ud(0.5, 1.5);
      points<D> z(D, count);
      Eigen::VectorXd dz(count);
      for (int i = 0; i < count; ++i) {
        for (int a = 0; a < D; ++a) z(a, i) = (u(rng) - 0.5) * box[a];  // negative coordinates too
        dz[i] = ud(rng);
      }
      const auto counted = [](index_t i) { return i % 7 != 3; };
      const std::vector<char> got = dom.any_periodic() ? io::largest_body(z, dz, count, counted, dom)
                                                       : io::largest_body(z, dz, count, counted);
      std::vector<int> comp(static_cast<std::size_t>(count), -1);
      std::vector<double> vol;
      for (int s0 = 0; s0 < count; ++s0) {
        if (!counted(s0) || comp[static_cast<std::size_t>(s0)] >= 0) continue;
        const int c = static_cast<int>(vol.size());
        vol.push_back(0.0);
        std::vector<int> todo{s0};
        comp[static_cast<std::size_t>(s0)] = c;
        while (!todo.empty()) {
          const int i = todo.back();
          todo.pop_back();
          vol[static_cast<std::size_t>(c)] += std::pow(dz[i], D);
          for (int j = 0; j < count; ++j)
            if (vec<D> r = z.col(i) - z.col(j);
                counted(j) && comp[static_cast<std::size_t>(j)] < 0 &&
                (dom.minimum_image(r), r.norm() < 1.5 * 0.5 * (dz[i] + dz[j]))) {
              comp[static_cast<std::size_t>(j)] = c;
              todo.push_back(j);
            }
        }
      }
      const int best = static_cast<int>(std::max_element(vol.begin(), vol.end()) - vol.begin());
      int members = 0, mismatches = 0;
      for (int i = 0; i < count; ++i) {
        const bool want = comp[static_cast<std::size_t>(i)] == best;
        members += want;
        mismatches += want != (got[static_cast<std::size_t>(i)] != 0);
      }
      CHECK(mismatches == 0);
      CHECK(members > 1);        // the clouds' density gives bodies of several particles ...
      CHECK(vol.size() > 2);     // ... and several bodies, so the choice is tested
      MESSAGE("largest_body ", D, "D", std::string(dom.any_periodic() ? " (periodic)" : ""), ": ", vol.size(),
              " bodies, the largest has ", members, " of ", count);
    };
    using in2 = std::integral_constant<int, 2>;
    using in3 = std::integral_constant<int, 3>;
    const vec<2> box2 = vec<2>::Constant(30.0), strip(30.0, 4.0);
    const vec<3> box3 = vec<3>::Constant(10.0);
    compare(in2{}, 400, box2, search::domain<2>{});
    compare(in3{}, 400, box3, search::domain<3>{});
    // The box as the period box: periodic in x (2D), in x and z (3D), and in y of a 30 × 4 strip, whose
    // period holds a single cell of 1.5 · 1.5 (so the neighbour cells across it repeat).
    const auto periodic_box = []<std::size_t D>(const std::array<bool, D>& axes,
                                                const vec<static_cast<int>(D)>& box) {
      search::domain<static_cast<int>(D)> dom;
      dom.periodic = axes;
      dom.lo = -0.5 * box;
      dom.hi = 0.5 * box;
      return dom;
    };
    compare(in2{}, 400, box2, periodic_box(std::array{true, false}, box2));
    compare(in3{}, 400, box3, periodic_box(std::array{true, false, true}, box3));
    compare(in2{}, 60, strip, periodic_box(std::array{false, true}, strip));
  }

  TEST_CASE("io: largest_body links across a periodic side: a row cut by the box's side is one body") {
    // Unit diameters at x = 0, 1, ..., 9 (y = 0) in the period box [−0.5, 9.5) along x: a closed ring once 9
    // links to 0 through its image (distance 1 < 1.5). Particles 4 and 5 not counted: without the periodic
    // axis 0–3 and 6–9 are two bodies of 4 and a row of 7 at y = 50 (x = 20 ... 26, outside the box: wrapped
    // for the cells, not moved) is the largest; with it 0–3 and 6–9 are one body of 8.
    points<2> x(2, 17);
    for (int i = 0; i < 10; ++i) x.col(i) << i, 0.0;
    for (int i = 0; i < 7; ++i) x.col(10 + i) << 20.0 + i, 50.0;
    const Eigen::VectorXd d = Eigen::VectorXd::Ones(17);
    const auto cut = [](index_t i) { return i != 4 && i != 5; };
    search::domain<2> dom;
    dom.periodic = {true, false};
    dom.lo = vec<2>(-0.5, 0.0);
    dom.hi = vec<2>(9.5, 0.0);
    std::vector<char> m = io::largest_body(x, d, 17, cut);
    CHECK(std::count(m.begin(), m.end(), 1) == 7);
    CHECK(m[10] == 1);
    m = io::largest_body(x, d, 17, cut, dom);
    CHECK(std::count(m.begin(), m.end(), 1) == 8);
    CHECK(m[0] == 1);
    CHECK(m[9] == 1);
    CHECK(m[10] == 0);
    // Pairs linked only through the side, one pair counted at a time (linked: a body of 2; not: 1). Period
    // 3.01 h (h = link · d = 1.5): three cells of 1.505, so a grid of four cells of h (cells 0 and 2 not
    // neighbours) would miss the first pair. The others: a particle exactly at hi (wrapped to lo), one a
    // rounding below lo, and a pair several periods apart.
    search::domain<2> thin;
    thin.periodic = {true, false};
    thin.lo = vec<2>(0.0, 0.0);
    thin.hi = vec<2>(3.01 * 1.5, 0.0);
    const double P = thin.period(0);
    points<2> pairs(2, 8);
    pairs.col(0) << 0.1, 0.0;          // and 1 at hi − 1.3: 1.4 apart through the side
    pairs.col(1) << P - 1.3, 0.0;
    pairs.col(2) << P, 5.0;            // exactly hi, and 3 1.2 beyond lo
    pairs.col(3) << 1.2, 5.0;
    pairs.col(4) << -1e-17, 10.0;      // wraps to the box's top, which is its bottom; and 5 at hi − 1.0
    pairs.col(5) << P - 1.0, 10.0;
    pairs.col(6) << 3.0 * P + 0.5, 15.0;  // 3 periods up and 2 down: 1.2 apart
    pairs.col(7) << -2.0 * P + 1.7, 15.0;
    const Eigen::VectorXd ones = Eigen::VectorXd::Ones(8);
    for (index_t k = 0; k < 8; k += 2) {
      const auto pair = [k](index_t i) { return i == k || i == k + 1; };
      CAPTURE(k);
      m = io::largest_body(pairs, ones, 8, pair, thin);
      CHECK(std::count(m.begin(), m.end(), 1) == 2);
      m = io::largest_body(pairs, ones, 8, pair);  // open: too far apart
      CHECK(std::count(m.begin(), m.end(), 1) == 1);
    }
    // A periodic axis without a period is refused (search::domain::validate).
    search::domain<2> bad = dom;
    bad.hi[0] = bad.lo[0];
    check_refused([&] { io::largest_body(x, d, 17, cut, bad); }, {"domain", "periodic axis 0"});
  }

  TEST_CASE("io: progress prints a plain row per interval, or one line in place on a terminal") {
    io::progress_info p;
    p.end_time = 1.0;
    p.dt = 1e-3;
    p.ppe_iterations = 42;
    p.particles = 1000;
    std::ostringstream os;
    io::progress_sink sink(os, 1.0, io::progress_mode::plain);
    CHECK(!sink.terminal());
    const double walls[] = {0.0, 0.5, 1.0, 1.5, 10.0};
    int printed = 0;
    for (int k = 0; k < 5; ++k) {
      p.step = 10 * k;
      p.time = 0.05 * k;
      p.wall_seconds = walls[k];
      printed += sink.update(p);
    }
    CHECK(printed == 3);  // at wall 0 (first), 1.0 and 10.0
    std::istringstream lines(os.str());
    std::string first, second, third;
    std::getline(lines, first);
    std::getline(lines, second);
    std::getline(lines, third);
    CHECK(first == "t = 0 s / 1 s, step 0, dt = 1.000e-03 s, PPE iterations 42, particles 1000, ETA --");
    // ETA from the first report: 1 s of wall for 0.1 s simulated, 0.9 s to go → 9 s.
    CHECK(second ==
          "t = 0.1 s / 1 s, step 20, dt = 1.000e-03 s, PPE iterations 42, particles 1000, ETA 9.0s");
    // 10 s for 0.2 s, 0.8 s to go → 40 s.
    CHECK(third ==
          "t = 0.2 s / 1 s, step 40, dt = 1.000e-03 s, PPE iterations 42, particles 1000, ETA 40.0s");
    CHECK(io::format_duration(3723.0) == "1h02m03s");
    CHECK(io::format_duration(125.0) == "2m05s");

    std::ostringstream term;
    io::progress_sink tsink(term, 0.0, io::progress_mode::terminal);
    p.wall_seconds = 0.0;
    tsink.update(p);
    p.wall_seconds = 1.0;
    tsink.update(p);
    CHECK(term.str().find('\n') == std::string::npos);
    CHECK(term.str().find('\r') == 0);
    tsink.finish();
    CHECK(term.str().back() == '\n');
    check_refused([&] { io::progress_sink(term, -1.0); }, {"interval", ">= 0"});

    // The progress line's iterations are the step's, every solve summed (the LSMPS scheme repeats solves
    // within a step, and its last_solve() is the last one only): step_iterations differences the running
    // total; a resumed run starts from its restored total; a total that falls is refused.
    io::step_iterations its;
    CHECK(its(30) == 30);
    CHECK(its(30) == 0);
    CHECK(its(75) == 45);
    io::step_iterations resumed{1000};
    CHECK(resumed(1012) == 12);
    check_refused([&] { resumed(5); }, {"step_iterations", "fell below"});
  }

  TEST_CASE("io: end summary accumulates and prints every counter") {
    io::run_counters c;
    c.record_step(100, 10, 1, 0, 2);
    c.record_step(102, 30, 0, 3, 0);
    c.record_step(104, 20, 1, 1, 1);
    io::run_counters copy;
    copy.from_values(c.values());
    const io::run_summary s = c.summary(2.0);
    CHECK(copy.values() == c.values());
    CHECK(s.particles == 104);
    CHECK(s.steps == 3);
    CHECK(s.particle_steps == 306.0);
    CHECK(s.particle_steps_per_second() == 153.0);
    CHECK(s.ppe_iterations_mean == 20.0);
    CHECK(s.ppe_iterations_max == 30);
    CHECK(s.pinned_components == 2);
    CHECK(s.guarded_particles == 4);
    CHECK(s.excluded_particles == 3);
    std::ostringstream os;
    io::print_summary(os, s);
    CHECK(os.str() ==
          "mpskit run summary\n"
          "  particles:                 104\n"
          "  steps:                     3\n"
          "  wall time:                 2.0s (2 s)\n"
          "  particle-steps per second: 1.5300e+02\n"
          "  PPE iterations:            mean 20.00, max 30\n"
          "  pinned components:         2\n"
          "  guarded particles:         4\n"
          "  excluded particles:        3\n");
  }
}

TEST_SUITE("checkpoint") {
  TEST_CASE_TEMPLATE("checkpoint: round trip restores every field, the layout and the sections bitwise", Dim,
                     dim<2>, dim<3>) {
    constexpr int D = Dim::value;
    std::mt19937_64 rng(test_seed() + 100 + D);
    const state_t<D> s = make_state<D>(73, 9, rng);
    scratch tmp("ckpt" + std::to_string(D));
    io::checkpoint_sections out;
    out.add("time", 0.1 + 0.2);
    out.add("step", std::int64_t{1234});
    out.add_doubles("controller", {1e-3, -0.0, 5e-324});
    out.add_int64s("counters", {1, -2, std::numeric_limits<std::int64_t>::min()});
    out.add_bytes("opaque", std::string("\0\1\2binary", 9));
    const fs::path p = tmp / "run.ckpt";
    io::save_checkpoint(p, s, out);

    state_t<D> r = make_state<D>(5, 2, rng);  // loading replaces whatever the state held
    io::checkpoint_sections in;
    io::load_checkpoint(p, r, in);
    CHECK(state_difference(r, s) == "");
    CHECK(r.n_ghost() == 9);
    CHECK(r.next_id() == s.next_id());
    CHECK(in.names() == out.names());
    const double t = in.get_double("time");
    CHECK(t == 0.1 + 0.2);
    CHECK(in.get_int64("step") == 1234);
    const std::vector<double> ctl = in.get_doubles("controller"), want = {1e-3, -0.0, 5e-324};
    CHECK(std::memcmp(ctl.data(), want.data(), sizeof(double) * 3) == 0);
    CHECK(in.get_int64s("counters") ==
          std::vector<std::int64_t>{1, -2, std::numeric_limits<std::int64_t>::min()});
    CHECK(in.get_bytes("opaque") == std::string("\0\1\2binary", 9));
    // Saving the restored state gives the same file, byte for byte.
    io::save_checkpoint(tmp / "again.ckpt", r, in);
    CHECK(slurp(tmp / "again.ckpt") == slurp(p));
    // Sections: missing, wrong type, duplicate.
    check_refused([&] { (void)in.get_double("nope"); }, {"run.ckpt", "no section 'nope'", "time, step"});
    check_refused([&] { (void)in.get_double("step"); }, {"run.ckpt", "'step' holds int64"});
    check_refused([&] { (void)in.get_double("controller"); }, {"holds 3 values, expected 1"});
    check_refused([&] { out.add("time", 1.0); }, {"'time' added twice"});
  }

  TEST_CASE("checkpoint: a restarted run continues bitwise identically") {
    std::mt19937_64 rng(test_seed() + 200);
    scratch tmp("restart");
    const state_t<2> init = make_state<2>(40, 0, rng);
    auto fresh = [&] {
      state_t<2> s = init;
      // Finite, moderate values for the dynamics.
      s.x() = s.x().unaryExpr([](double v) { return std::fmod(v, 3.0); });
      s.u().setZero();
      s.get<field::pressure>().setZero();
      return s;
    };
    constexpr int n1 = 37, n2 = 41;
    // Straight run.
    state_t<2> a = fresh();
    toy_controller ca;
    double ta = 0.0;
    std::int64_t sa = 0;
    for (int k = 0; k < n1 + n2; ++k) toy_step(a, ca, ta, sa);
    // Interrupted run: n1 steps, checkpoint, a fresh process (new objects), load, n2 steps.
    {
      state_t<2> b = fresh();
      toy_controller cb;
      double tb = 0.0;
      std::int64_t sb = 0;
      for (int k = 0; k < n1; ++k) toy_step(b, cb, tb, sb);
      io::checkpoint_sections sec;
      cb.save(sec);
      sec.add("time", tb);
      sec.add("step", sb);
      io::save_checkpoint(tmp / "mid.ckpt", b, sec);
    }
    state_t<2> b;
    toy_controller cb;
    io::checkpoint_sections sec;
    io::load_checkpoint(tmp / "mid.ckpt", b, sec);
    cb.load(sec);
    double tb = sec.get_double("time");
    std::int64_t sb = sec.get_int64("step");
    for (int k = 0; k < n2; ++k) toy_step(b, cb, tb, sb);
    CHECK(state_difference(a, b) == "");
    CHECK(std::memcmp(&ta, &tb, sizeof ta) == 0);
    CHECK(ca.dt == cb.dt);
    CHECK(sa == sb);
  }

  TEST_CASE("checkpoint: truncated, corrupted, foreign and mismatched files are refused") {
    std::mt19937_64 rng(test_seed() + 300);
    scratch tmp("bad_ckpt");
    const state_t<2> s = make_state<2>(30, 5, rng);
    io::checkpoint_sections sec;
    sec.add("time", 1.5);
    const fs::path good = tmp / "good.ckpt", bad = tmp / "bad.ckpt";
    io::save_checkpoint(good, s, sec);
    const std::string bytes = slurp(good);
    state_t<2> r;
    io::checkpoint_sections in;
    auto load_bad = [&] { io::load_checkpoint(bad, r, in); };

    check_refused([&] { io::load_checkpoint(tmp / "missing.ckpt", r, in); }, {"missing.ckpt", "cannot open"});
    dump(bad, bytes.substr(0, bytes.size() - 1));
    check_refused(load_bad, {"bad.ckpt", "truncated"});
    dump(bad, bytes.substr(0, 20));
    check_refused(load_bad, {"bad.ckpt", "truncated"});
    dump(bad, bytes + "x");
    check_refused(load_bad, {"bad.ckpt", "trailing bytes"});
    // Flip one bit in each of 16 random payload bytes, one at a time: each is caught by the checksum.
    std::uniform_int_distribution<std::size_t> where(32, bytes.size() - 1);
    for (int k = 0; k < 16; ++k) {
      std::string t = bytes;
      const std::size_t at = where(rng);
      CAPTURE(at);
      t[at] = static_cast<char>(t[at] ^ (1 << (k % 8)));
      dump(bad, t);
      check_refused(load_bad, {"bad.ckpt", "checksum mismatch"});
    }
    std::string t = bytes;
    t[0] = 'X';
    dump(bad, t);
    check_refused(load_bad, {"bad.ckpt", "wrong magic"});
    t = bytes;
    t[8] = 2;  // version 2
    dump(bad, t);
    check_refused(load_bad, {"bad.ckpt", "format version 2 is not supported"});
    dump(bad, "hello");
    check_refused(load_bad, {"bad.ckpt", "not an mpskit checkpoint"});
    // Another dimension, another field list.
    state_t<3> r3;
    check_refused([&] { io::load_checkpoint(good, r3, in); }, {"good.ckpt", "2D scene", "3D state"});
    particle_state<2, field_list<field::pressure>> fewer;
    check_refused([&] { io::load_checkpoint(good, fewer, in); }, {"good.ckpt", "fields"});
    particle_state<2, field_list<field::pressure, field::volume, field::normal, field::partner, tag16, level>>
        swapped;
    check_refused([&] { io::load_checkpoint(good, swapped, in); }, {"good.ckpt", "'level'", "'tag16'"});
    // A refused load leaves the target untouched.
    CHECK(r.size() == 0);
    check_refused([&] { io::save_checkpoint(tmp / "no" / "x.ckpt", s); }, {"x.ckpt", "does not exist"});
  }
}
