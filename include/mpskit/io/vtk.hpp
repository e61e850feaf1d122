#pragma once
/// \file io/vtk.hpp
/// \brief VTK XML output: `write_vtu` (UnstructuredGrid, one VTK_VERTEX cell per particle, every field of
/// the state with its units), `pvd_series` (a ParaView collection with the simulated time of each file)
/// and `vtk_series` (both together). Format and conventions: docs/io.md.
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/io/concepts.hpp"
#include "mpskit/io/detail/bytes.hpp"
#include "mpskit/io/detail/type_names.hpp"

namespace mpskit::io {

/// How array data is stored in a .vtu file.
enum class vtk_encoding : std::uint8_t {
  base64,       ///< inline `format="binary"` (base64): ParaView, VTK, meshio 5 (default)
  raw_appended  ///< one `<AppendedData encoding="raw">` block: fastest, VTK/ParaView only (meshio refuses it)
};

/// Options of write_vtu.
struct vtu_options {
  vtk_encoding encoding = vtk_encoding::base64;  ///< array encoding
  bool include_ghosts = false;  ///< write the ghost range too (default: real particles only)
  bool units_in_names = false;  ///< name arrays "pressure [Pa]" (shown by ParaView) instead of "pressure"
  std::optional<double> time = std::nullopt;  ///< simulated time [s], written as field data "TimeValue"
  std::optional<index_t> step = std::nullopt; ///< step number, written as field data "CycleIndex"
};

namespace detail {

inline void xml_escape(std::string& out, std::string_view s) {
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
}

inline std::string format_double(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip representation
  return std::string(buf, r.ptr);
}

/// One array ready to be written: its attributes and its bytes.
struct vtu_blob {
  std::string name, type, units;
  int components = 1;
  std::string bytes;
};

/// Writes one DataArray element (inline base64, or a reference into the appended block).
inline void write_data_array(std::string& xml, std::string& appended, const vtu_blob& b, vtk_encoding enc,
                             std::string_view indent) {
  xml += indent;
  xml += "<DataArray type=\"";
  xml += b.type;
  xml += "\" Name=\"";
  xml_escape(xml, b.name);
  xml += "\" NumberOfComponents=\"" + std::to_string(b.components) + "\"";
  if (!b.units.empty()) {
    xml += " units=\"";
    xml_escape(xml, b.units);
    xml += "\"";
  }
  const std::uint64_t nbytes = b.bytes.size();
  if (enc == vtk_encoding::base64) {
    // VTK's uncompressed binary block: a UInt64 byte count (header_type="UInt64") then the data, encoded
    // as one base64 stream.
    std::string block;
    block.reserve(sizeof nbytes + b.bytes.size());
    append_value(block, nbytes);
    block += b.bytes;
    xml += " format=\"binary\">\n";
    xml += indent;
    xml += "  ";
    base64_encode(block, xml);
    xml += "\n";
    xml += indent;
    xml += "</DataArray>\n";
  } else {
    xml += " format=\"appended\" offset=\"" + std::to_string(appended.size()) + "\"/>\n";
    append_value(appended, nbytes);
    appended += b.bytes;
  }
}

template <class V>
std::string bytes_of(const V* p, std::size_t n) {
  std::string s;
  append_raw(s, p, n);
  return s;
}

}  // namespace detail

/// \brief Writes the state as a VTK XML UnstructuredGrid (.vtu): points = positions (3D, z = 0 in 2D),
/// one VTK_VERTEX cell per particle, one point-data array per field (scalar → Float64 × 1, vector →
/// Float64 × 3 padded with 0, integer/index → its VTK integer type), each with a `units` attribute.
/// The file is written atomically (temporary file + rename). Throws mpskit::error naming the path.
template <ParticleState State>
void write_vtu(const std::filesystem::path& path, const State& state, const vtu_options& opt = {}) {
  constexpr int D = State::dim;
  if (!detail::little_endian) fail("write_vtu: '", path.string(), "': big-endian machines are not supported");
  const index_t n = opt.include_ghosts ? state.size() : state.n_real();
  const std::size_t un = static_cast<std::size_t>(n);

  std::vector<detail::vtu_blob> point_data;
  detail::vtu_blob points_blob;
  State::for_each_field([&](auto tag) {
    using T = decltype(tag);
    const auto& s = state.template get<T>();
    detail::vtu_blob b;
    b.name = std::string(T::name);
    b.units = detail::resolve_units(T::units, D);
    if (opt.units_in_names) b.name += " [" + b.units + "]";
    if constexpr (T::shape == field_shape::vector) {
      std::vector<double> v(3 * un, 0.0);
      for (std::size_t i = 0; i < un; ++i)
        for (int a = 0; a < D; ++a) v[3 * i + static_cast<std::size_t>(a)] = s(a, static_cast<index_t>(i));
      b.type = "Float64";
      b.components = 3;
      b.bytes = detail::bytes_of(v.data(), v.size());
    } else if constexpr (T::shape == field_shape::scalar) {
      b.type = "Float64";
      b.bytes = detail::bytes_of(s.data(), un);
    } else {
      using V = typename T::value_type;
      b.type = std::string(detail::vtk_type_name<V>());
      b.bytes = detail::bytes_of(s.data(), un);
    }
    if constexpr (std::same_as<T, field::position>) points_blob = std::move(b);
    else point_data.push_back(std::move(b));
  });

  std::vector<std::int64_t> conn(un), offsets(un);
  for (std::size_t i = 0; i < un; ++i) {
    conn[i] = static_cast<std::int64_t>(i);
    offsets[i] = static_cast<std::int64_t>(i + 1);
  }
  const std::vector<std::uint8_t> types(un, std::uint8_t{1});  // VTK_VERTEX = 1

  const vtk_encoding enc = opt.encoding;
  std::string xml, appended;
  std::size_t payload = points_blob.bytes.size() + 17 * un + 64;
  for (const auto& b : point_data) payload += b.bytes.size() + 8;
  if (enc == vtk_encoding::base64) xml.reserve(4096 + payload / 3 * 4 + 4 * 64);
  else appended.reserve(payload);
  xml += "<?xml version=\"1.0\"?>\n<!-- mpskit particles: ";
  xml += opt.include_ghosts ? "real and ghost" : "real only";
  xml += "; units of each array in its 'units' attribute (docs/io.md) -->\n";
  xml +=
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n";
  xml += "  <UnstructuredGrid>\n";
  if (opt.time || opt.step) {
    xml += "    <FieldData>\n";
    if (opt.time)
      xml +=
          "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" units=\"s\" "
          "format=\"ascii\">" +
          detail::format_double(*opt.time) + "</DataArray>\n";
    if (opt.step)
      xml += "      <DataArray type=\"Int64\" Name=\"CycleIndex\" NumberOfTuples=\"1\" format=\"ascii\">" +
             std::to_string(*opt.step) + "</DataArray>\n";
    xml += "    </FieldData>\n";
  }
  xml += "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"" + std::to_string(n) +
         "\">\n";
  xml += "      <PointData>\n";
  for (const auto& b : point_data) detail::write_data_array(xml, appended, b, enc, "        ");
  xml += "      </PointData>\n      <Points>\n";
  detail::write_data_array(xml, appended, points_blob, enc, "        ");
  xml += "      </Points>\n      <Cells>\n";
  detail::write_data_array(xml, appended, {"connectivity", "Int64", "", 1, detail::bytes_of(conn.data(), un)},
                           enc, "        ");
  detail::write_data_array(xml, appended, {"offsets", "Int64", "", 1, detail::bytes_of(offsets.data(), un)},
                           enc, "        ");
  detail::write_data_array(xml, appended, {"types", "UInt8", "", 1, detail::bytes_of(types.data(), un)}, enc,
                           "        ");
  xml += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n";
  if (enc == vtk_encoding::raw_appended) {
    xml += "  <AppendedData encoding=\"raw\">\n   _";
    detail::write_file_atomic(path, {xml, appended, "\n  </AppendedData>\n</VTKFile>\n"}, "write_vtu");
  } else {
    xml += "</VTKFile>\n";
    detail::write_file_atomic(path, {xml}, "write_vtu");
  }
}

/// One dataset of a .pvd collection.
struct pvd_entry {
  double time = 0.0;           ///< simulated time [s]
  std::filesystem::path file;  ///< path as written in the .pvd (relative to the .pvd's directory)
};

/// \brief A ParaView collection (.pvd) listing .vtu files with their simulated times; rewritten
/// atomically on every add, so a crash leaves the last complete list.
class pvd_series {
 public:
  /// A series written to `pvd_path`, starting from `existing` entries (e.g. read_pvd on restart).
  explicit pvd_series(std::filesystem::path pvd_path, std::vector<pvd_entry> existing = {})
      : path_(std::move(pvd_path)), entries_(std::move(existing)) {
    if (path_.empty()) fail("pvd_series: empty path");
  }

  /// Adds a dataset at simulated time t (finite, not before the last one) and rewrites the .pvd.
  void add(double t, const std::filesystem::path& vtu) {
    if (!std::isfinite(t)) fail("pvd_series '", path_.string(), "': time ", t, " is not finite");
    if (!entries_.empty() && t < entries_.back().time)
      fail("pvd_series '", path_.string(), "': time ", t, " is before the last entry's time ",
           entries_.back().time, " (times must not decrease)");
    const std::filesystem::path base =
        path_.has_parent_path() ? path_.parent_path() : std::filesystem::path(".");
    std::filesystem::path rel =
        vtu.is_absolute() || base.is_absolute()
            ? std::filesystem::absolute(vtu).lexically_relative(std::filesystem::absolute(base))
            : vtu.lexically_relative(base);
    if (rel.empty()) rel = vtu;
    entries_.push_back({t, rel});
    write();
  }

  /// Rewrites the .pvd from the current entries (atomic).
  void write() const {
    std::string xml =
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        "  <Collection>\n";
    for (const auto& e : entries_) {
      xml += "    <DataSet timestep=\"" + detail::format_double(e.time) + "\" group=\"\" part=\"0\" file=\"";
      detail::xml_escape(xml, e.file.generic_string());
      xml += "\"/>\n";
    }
    xml += "  </Collection>\n</VTKFile>\n";
    detail::write_file_atomic(path_, {xml}, "pvd_series");
  }

  const std::vector<pvd_entry>& entries() const { return entries_; }  ///< datasets in order
  const std::filesystem::path& path() const { return path_; }         ///< the .pvd path

 private:
  std::filesystem::path path_;
  std::vector<pvd_entry> entries_;
};

/// \brief Output series: `write(state, t)` writes "<prefix>_<k>.vtu" (k = 000000, 000001, ...) and adds it
/// to "<prefix>.pvd". The prefix's directory is created when missing.
class vtk_series {
 public:
  /// Series at `prefix` (e.g. "out/dam_break"); options apply to every file (time and step are set per
  /// write).
  explicit vtk_series(std::filesystem::path prefix, vtu_options opt = {},
                      std::vector<pvd_entry> existing = {})
      : prefix_(std::move(prefix)), opt_(opt), pvd_(pvd_path_of(prefix_), std::move(existing)) {
    count_ = static_cast<index_t>(pvd_.entries().size());
    if (prefix_.has_parent_path()) {
      std::error_code ec;
      std::filesystem::create_directories(prefix_.parent_path(), ec);
      if (ec)
        fail("vtk_series: cannot create directory '", prefix_.parent_path().string(), "': ", ec.message());
    }
  }

  /// Writes the state at simulated time t (and optional step); returns the .vtu path.
  template <ParticleState State>
  std::filesystem::path write(const State& state, double t, std::optional<index_t> step = std::nullopt) {
    std::string num = std::to_string(count_);
    if (num.size() < 6) num.insert(0, 6 - num.size(), '0');
    std::filesystem::path file = prefix_;
    file += "_" + num + ".vtu";
    vtu_options o = opt_;
    o.time = t;
    o.step = step;
    write_vtu(file, state, o);
    pvd_.add(t, file);
    ++count_;
    return file;
  }

  const pvd_series& pvd() const { return pvd_; }  ///< the collection
  index_t files_written() const { return count_; }  ///< number of files in the series

 private:
  static std::filesystem::path pvd_path_of(const std::filesystem::path& prefix) {
    std::filesystem::path p = prefix;
    p += ".pvd";
    return p;
  }
  std::filesystem::path prefix_;
  vtu_options opt_;
  pvd_series pvd_;
  index_t count_ = 0;
};

}  // namespace mpskit::io
