#pragma once
/// \file io/vtk_reader.hpp
/// \brief Reader of the .vtu and .pvd files io/vtk.hpp writes (both encodings, UInt32 or UInt64 block
/// headers, uncompressed): named arrays with their units, for tests and for restarting from output.
/// Malformed or truncated files are refused with an mpskit::error naming the file and the problem.
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/io/concepts.hpp"
#include "mpskit/io/detail/bytes.hpp"
#include "mpskit/io/detail/type_names.hpp"
#include "mpskit/io/detail/xml.hpp"
#include "mpskit/io/vtk.hpp"

namespace mpskit::io {

/// One array of a .vtu file: raw little-endian values of `type`, `tuples` × `components`.
struct vtu_array {
  std::string name;    ///< field name (a " [units]" suffix written with units_in_names is removed)
  std::string type;    ///< VTK type name: "Float64", "Int64", "UInt8", ...
  std::string units;   ///< the `units` attribute ("" when absent)
  int components = 1;  ///< values per tuple
  index_t tuples = 0;  ///< number of tuples (points for point data)
  std::string bytes;   ///< the values, as stored

  /// The values as T; T's VTK type must be `type` (exact, bitwise).
  template <class T>
  std::vector<T> values() const {
    if (detail::vtk_type_name<T>() != type)
      fail("vtu array '", name, "' holds ", type, ", not ", detail::vtk_type_name<T>());
    std::vector<T> v(bytes.size() / sizeof(T));
    if (!v.empty()) std::memcpy(v.data(), bytes.data(), v.size() * sizeof(T));
    return v;
  }
  /// The values converted to double (any numeric type).
  std::vector<double> as_doubles() const {
    const std::size_t n = static_cast<std::size_t>(tuples) * static_cast<std::size_t>(components);
    std::vector<double> v(n);
    auto conv = [&](auto tag) {
      using T = decltype(tag);
      for (std::size_t k = 0; k < n; ++k) {
        T x;
        std::memcpy(&x, bytes.data() + k * sizeof(T), sizeof(T));
        v[k] = static_cast<double>(x);
      }
    };
    if (type == "Float64") conv(double{});
    else if (type == "Float32") conv(float{});
    else if (type == "Int64") conv(std::int64_t{});
    else if (type == "UInt64") conv(std::uint64_t{});
    else if (type == "Int32") conv(std::int32_t{});
    else if (type == "UInt32") conv(std::uint32_t{});
    else if (type == "Int16") conv(std::int16_t{});
    else if (type == "UInt16") conv(std::uint16_t{});
    else if (type == "Int8") conv(std::int8_t{});
    else conv(std::uint8_t{});
    return v;
  }
};

/// A .vtu file as read.
struct vtu_file {
  std::filesystem::path path;            ///< where it was read from
  index_t n_points = 0;                  ///< points (particles)
  vtu_array points;                      ///< 3 × n_points Float64
  std::vector<vtu_array> point_data;     ///< per-particle arrays in file order
  std::vector<vtu_array> cells;          ///< connectivity, offsets, types
  std::vector<vtu_array> field_data;     ///< whole-dataset arrays
  std::optional<double> time;            ///< field data "TimeValue" [s]
  std::optional<index_t> step;           ///< field data "CycleIndex"

  /// True when a point-data array has this name.
  bool has(std::string_view name) const { return find(name) != nullptr; }
  /// The point-data array of this name; throws naming the file when absent.
  const vtu_array& point_array(std::string_view name) const {
    if (const vtu_array* a = find(name)) return *a;
    fail("read_vtu: '", path.string(), "' has no point-data array '", name, "'");
  }

 private:
  const vtu_array* find(std::string_view name) const {
    for (const auto& a : point_data)
      if (a.name == name) return &a;
    return nullptr;
  }
};

namespace detail {

class vtu_reader {
 public:
  vtu_reader(const std::filesystem::path& path) : path_(path), src_(read_file(path, "read_vtu")) {}

  vtu_file read() {
    xml_parser xp(src_, "read_vtu", path_.string());
    const xml_node root = xp.parse();
    appended_ = xp.appended_begin();
    if (root.name != "VTKFile") bad("root element is <" + root.name + ">, not <VTKFile>");
    if (const std::string* t = root.attr("type"); !t || *t != "UnstructuredGrid")
      bad("VTKFile type is not \"UnstructuredGrid\"");
    if (const std::string* bo = root.attr("byte_order"); !bo || *bo != "LittleEndian" || !little_endian)
      bad("byte_order must be LittleEndian on a little-endian machine");
    if (root.attr("compressor"))
      bad("compressed data (compressor=\"" + *root.attr("compressor") + "\") is not supported");
    header_size_ = 4;
    if (const std::string* h = root.attr("header_type")) {
      if (*h == "UInt64") header_size_ = 8;
      else if (*h != "UInt32") bad("header_type \"" + *h + "\" is not UInt32 or UInt64");
    }
    const xml_node* appended_node = nullptr;
    const xml_node* grid = nullptr;
    for (const auto& c : root.children) {
      if (c.name == "UnstructuredGrid") grid = &c;
      if (c.name == "AppendedData") appended_node = &c;
    }
    if (appended_node && appended_ == xml_parser::npos_)
      bad("AppendedData encoding must be \"raw\" (base64 appended data is not supported)");
    if (appended_ != xml_parser::npos_) {
      // The file must end with the closing tags: a truncated raw block is detected here or by the offsets.
      std::string_view tail(src_);
      while (!tail.empty() && std::string_view(" \n\r\t").find(tail.back()) != std::string_view::npos)
        tail.remove_suffix(1);
      if (!tail.ends_with("</VTKFile>")) bad("does not end with </VTKFile> (file truncated?)");
    }
    if (!grid) bad("no <UnstructuredGrid> element");
    const xml_node* piece = nullptr;
    vtu_file f;
    f.path = path_;
    for (const auto& c : grid->children) {
      if (c.name == "Piece") {
        if (piece) bad("more than one <Piece> (not written by mpskit)");
        piece = &c;
      } else if (c.name == "FieldData") {
        for (const auto& a : c.children) f.field_data.push_back(array(a, -1, 0));
      }
    }
    if (!piece) bad("no <Piece> element");
    f.n_points = count_attr(*piece, "NumberOfPoints");
    const index_t n_cells = count_attr(*piece, "NumberOfCells");
    bool have_points = false;
    for (const auto& c : piece->children) {
      if (c.name == "PointData") {
        for (const auto& a : c.children) f.point_data.push_back(array(a, f.n_points, 0));
      } else if (c.name == "Points") {
        if (c.children.size() != 1) bad("<Points> must hold one DataArray");
        f.points = array(c.children.front(), f.n_points, 3);
        have_points = true;
      } else if (c.name == "Cells") {
        for (const auto& a : c.children) {
          const std::string* nm = a.attr("Name");
          f.cells.push_back(array(a, nm && *nm == "connectivity" ? -1 : n_cells, 1));
        }
      }
    }
    if (!have_points) bad("no <Points> element");
    if (f.points.type != "Float64") bad("points are " + f.points.type + ", not Float64");
    for (const auto& a : f.field_data) {
      if (a.name == "TimeValue" && a.tuples >= 1) f.time = a.as_doubles().front();
      if (a.name == "CycleIndex" && a.tuples >= 1) f.step = static_cast<index_t>(a.as_doubles().front());
    }
    return f;
  }

 private:
  [[noreturn]] void bad(const std::string& msg) const { fail("read_vtu: '", path_.string(), "': ", msg); }

  index_t count_attr(const xml_node& n, const char* key) const {
    const std::string* v = n.attr(key);
    if (!v) bad("<" + n.name + "> has no " + key);
    index_t x = -1;
    const auto r = std::from_chars(v->data(), v->data() + v->size(), x);
    if (r.ec != std::errc{} || r.ptr != v->data() + v->size() || x < 0)
      bad(std::string(key) + " = \"" + *v + "\" is not a count >= 0");
    return x;
  }

  /// Reads one DataArray; tuples = expected number of tuples (-1: any), comps = required components (0: any).
  vtu_array array(const xml_node& n, index_t tuples, int comps) const {
    if (n.name != "DataArray") bad("line " + std::to_string(n.line) + ": unexpected <" + n.name + ">");
    vtu_array a;
    const std::string* name = n.attr("Name");
    a.name = name ? *name : "";
    const std::string where = "line " + std::to_string(n.line) + ": array '" + a.name + "'";
    const std::string* type = n.attr("type");
    if (!type || vtk_type_size(*type) == 0) bad(where + ": missing or unknown type");
    a.type = *type;
    if (const std::string* u = n.attr("units")) a.units = *u;
    if (!a.units.empty() && a.name.ends_with(" [" + a.units + "]"))
      a.name.resize(a.name.size() - a.units.size() - 3);
    a.components = 1;
    if (const std::string* c = n.attr("NumberOfComponents")) {
      int k = 0;
      const auto r = std::from_chars(c->data(), c->data() + c->size(), k);
      if (r.ec != std::errc{} || r.ptr != c->data() + c->size() || k < 1)
        bad(where + ": bad NumberOfComponents");
      a.components = k;
    }
    if (comps > 0 && a.components != comps)
      bad(where + ": has " + std::to_string(a.components) + " components, expected " + std::to_string(comps));
    const std::size_t size = static_cast<std::size_t>(vtk_type_size(a.type));
    const std::string* format = n.attr("format");
    if (!format) bad(where + ": no format");
    if (*format == "binary") {
      std::string block;
      if (!base64_decode(n.text, block)) bad(where + ": invalid base64 data");
      a.bytes = payload(block, 0, where);
    } else if (*format == "appended") {
      if (appended_ == xml_parser::npos_) bad(where + ": format=\"appended\" but no raw <AppendedData>");
      const std::string* off = n.attr("offset");
      std::size_t o = 0;
      if (!off || std::from_chars(off->data(), off->data() + off->size(), o).ec != std::errc{})
        bad(where + ": missing or bad offset");
      if (o > src_.size() - appended_)
        bad(where + ": offset " + *off + " is past the end of the file (truncated?)");
      a.bytes = payload(std::string_view(src_).substr(appended_), o, where);
    } else if (*format == "ascii") {
      a.bytes = ascii(n.text, a.type, where);
    } else {
      bad(where + ": unknown format \"" + *format + "\"");
    }
    if (a.bytes.size() % (size * static_cast<std::size_t>(a.components)) != 0)
      bad(where + ": " + std::to_string(a.bytes.size()) + " bytes is not a whole number of tuples");
    a.tuples = static_cast<index_t>(a.bytes.size() / (size * static_cast<std::size_t>(a.components)));
    if (tuples >= 0 && a.tuples != tuples)
      bad(where + ": has " + std::to_string(a.tuples) + " tuples, expected " + std::to_string(tuples));
    return a;
  }

  /// A block: header (byte count) then data, starting at `at` in `blk`.
  std::string payload(std::string_view blk, std::size_t at, const std::string& where) const {
    if (blk.size() - at < header_size_) bad(where + ": data block shorter than its header (truncated?)");
    std::uint64_t nbytes = 0;
    if (header_size_ == 8) std::memcpy(&nbytes, blk.data() + at, 8);
    else {
      std::uint32_t n32 = 0;
      std::memcpy(&n32, blk.data() + at, 4);
      nbytes = n32;
    }
    const std::size_t avail = blk.size() - at - header_size_;
    if (nbytes > avail)
      bad(where + ": header says " + std::to_string(nbytes) + " bytes, only " + std::to_string(avail) +
          " present (truncated?)");
    return std::string(blk.substr(at + header_size_, static_cast<std::size_t>(nbytes)));
  }

  std::string ascii(std::string_view text, const std::string& type, const std::string& where) const {
    std::string out;
    const char* p = text.data();
    const char* e = p + text.size();
    for (;;) {
      while (p < e && std::string_view(" \n\r\t").find(*p) != std::string_view::npos) ++p;
      if (p == e) break;
      bool ok = false;
      auto take = [&](auto v) {
        const auto r = std::from_chars(p, e, v);
        ok = r.ec == std::errc{};
        p = r.ptr;
        append_value(out, v);
      };
      if (type == "Float64") take(double{});
      else if (type == "Float32") take(float{});
      else if (type == "Int64") take(std::int64_t{});
      else if (type == "UInt64") take(std::uint64_t{});
      else if (type == "Int32") take(std::int32_t{});
      else if (type == "UInt32") take(std::uint32_t{});
      else bad(where + ": ascii " + type + " is not supported");
      if (!ok) bad(where + ": bad ascii value");
    }
    return out;
  }

  std::filesystem::path path_;
  std::string src_;
  std::size_t appended_ = xml_parser::npos_;
  std::size_t header_size_ = 8;
};

}  // namespace detail

/// Reads a .vtu file written by write_vtu (or any uncompressed, single-piece UnstructuredGrid).
inline vtu_file read_vtu(const std::filesystem::path& path) { return detail::vtu_reader(path).read(); }

/// Reads a .pvd collection; entries with time > up_to are dropped (restart: continue the series).
/// File paths are returned as written (relative to the .pvd's directory).
inline std::vector<pvd_entry> read_pvd(const std::filesystem::path& path,
                                       std::optional<double> up_to = std::nullopt) {
  const std::string src = detail::read_file(path, "read_pvd");
  detail::xml_parser xp(src, "read_pvd", path.string());
  const detail::xml_node root = xp.parse();
  auto bad = [&](const std::string& m) { fail("read_pvd: '", path.string(), "': ", m); };
  if (root.name != "VTKFile" || !root.attr("type") || *root.attr("type") != "Collection")
    bad("not a VTKFile of type \"Collection\"");
  std::vector<pvd_entry> out;
  for (const auto& c : root.children) {
    if (c.name != "Collection") continue;
    for (const auto& d : c.children) {
      if (d.name != "DataSet") continue;
      const std::string* t = d.attr("timestep");
      const std::string* f = d.attr("file");
      if (!t || !f) bad("line " + std::to_string(d.line) + ": DataSet without timestep or file");
      double tv = 0.0;
      const auto r = std::from_chars(t->data(), t->data() + t->size(), tv);
      if (r.ec != std::errc{} || r.ptr != t->data() + t->size())
        bad("line " + std::to_string(d.line) + ": timestep \"" + *t + "\" is not a number");
      if (up_to && tv > *up_to) continue;
      out.push_back({tv, std::filesystem::path(*f)});
    }
  }
  return out;
}

/// \brief Fills a state from a .vtu written by write_vtu: every field by name (positions from the points),
/// ghosts (ghost_role != none, written with include_ghosts) after the real particles, next id = largest
/// real id + 1. Doubles are restored bitwise. The file must hold every field of the state with its type;
/// a 2D state refuses a nonzero z. Time-step controller and counters are not in a .vtu: for a bitwise
/// restart use a checkpoint (io/checkpoint.hpp).
template <ParticleState State>
void read_state(const vtu_file& f, State& state) {
  constexpr int D = State::dim;
  const std::size_t n = static_cast<std::size_t>(f.n_points);
  auto bad = [&](const std::string& m) { fail("read_state: '", f.path.string(), "': ", m); };
  index_t n_real = f.n_points;
  if (f.has("ghost_role")) {
    const std::vector<double> roles = f.point_array("ghost_role").as_doubles();
    n_real = 0;
    while (static_cast<std::size_t>(n_real) < n && roles[static_cast<std::size_t>(n_real)] == 0.0) ++n_real;
    for (std::size_t i = static_cast<std::size_t>(n_real); i < n; ++i)
      if (roles[i] == 0.0) bad("real particle " + std::to_string(i) + " after a ghost");
  }
  state.restore_layout(n_real, f.n_points - n_real, 0);
  State::for_each_field([&](auto tag) {
    using T = decltype(tag);
    auto& s = state.template get<T>();
    const vtu_array& a = std::same_as<T, field::position> ? f.points : f.point_array(T::name);
    if constexpr (T::shape == field_shape::vector) {
      const std::vector<double> v = a.values<double>();
      if (a.components != 3)
        bad("array '" + a.name + "' has " + std::to_string(a.components) + " components, not 3");
      for (std::size_t i = 0; i < n; ++i) {
        for (int c = 0; c < D; ++c) s(c, static_cast<index_t>(i)) = v[3 * i + static_cast<std::size_t>(c)];
        if (D == 2 && v[3 * i + 2] != 0.0)
          bad("array '" + a.name + "' of particle " + std::to_string(i) + " has z != 0 in a 2D state");
      }
    } else if constexpr (T::shape == field_shape::scalar) {
      const std::vector<double> v = a.values<double>();
      if (a.components != 1) bad("array '" + a.name + "' is not a scalar");
      for (std::size_t i = 0; i < n; ++i) s[static_cast<index_t>(i)] = v[i];
    } else {
      using V = typename T::value_type;
      using U = detail::underlying_t<V>;
      const std::vector<U> v = a.values<U>();
      if (a.components != 1) bad("array '" + a.name + "' is not a scalar");
      for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<V>(v[i]);
    }
  });
  particle_id next = 0;
  for (index_t i = 0; i < n_real; ++i) next = std::max(next, state.ids()[static_cast<std::size_t>(i)] + 1);
  state.restore_layout(n_real, f.n_points - n_real, next);
  state.validate();
}

}  // namespace mpskit::io
