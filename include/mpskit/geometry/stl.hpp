#pragma once
/// \file geometry/stl.hpp
/// \brief STL reader (ASCII and binary, detected from the content) and writer. Facet normals in the
/// file are parsed but ignored: orientation comes from the vertex winding (docs/geometry.md).
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/geometry/detail/reader.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"

namespace mpskit::geometry {

static_assert(std::endian::native == std::endian::little,
              "mpskit: binary STL I/O assumes a little-endian host");

/// STL flavour for the writer.
enum class stl_format { ascii, binary };

namespace detail {
/// Merges exactly coincident vertices (STL stores each triangle's corners separately).
class vertex_welder {
 public:
  index_t add(const vec<3>& p) {
    ++added_;
    auto [it, inserted] = ids_.try_emplace({p.x(), p.y(), p.z()}, static_cast<index_t>(points_.size()));
    if (inserted) points_.push_back(p);
    return it->second;
  }
  polygon_mesh<3> mesh(const std::vector<std::array<index_t, 3>>& tris) const {
    polygon_mesh<3> m;
    m.vertices.resize(3, static_cast<index_t>(points_.size()));
    for (std::size_t i = 0; i < points_.size(); ++i) m.vertices.col(static_cast<index_t>(i)) = points_[i];
    m.elements.resize(3, static_cast<index_t>(tris.size()));
    for (std::size_t e = 0; e < tris.size(); ++e)
      for (int k = 0; k < 3; ++k) m.elements(k, static_cast<index_t>(e)) = tris[e][k];
    return m;
  }
  index_t merged() const { return added_ - static_cast<index_t>(points_.size()); }

 private:
  std::map<std::array<double, 3>, index_t> ids_;
  std::vector<vec<3>> points_;
  index_t added_ = 0;
};

inline read_result<3> parse_stl_binary(const std::string& data, const std::string& file,
                                       const read_options& opt) {
  std::uint32_t n = 0;
  std::memcpy(&n, data.data() + 80, 4);
  const std::uint64_t need = 84 + 50ull * n;
  if (data.size() != need)
    fail(file, ": binary STL declares ", n, " triangles (", need, " bytes) but the file has ", data.size(),
         " bytes (truncated or wrong count)");
  vertex_welder w;
  std::vector<std::array<index_t, 3>> tris(n);
  std::vector<std::string> where(n);
  for (std::uint32_t t = 0; t < n; ++t) {
    const char* rec = data.data() + 84 + 50ull * t;
    float f[12];
    std::memcpy(f, rec, sizeof f);
    for (int k = 0; k < 3; ++k) {
      vec<3> p(f[3 + 3 * k], f[4 + 3 * k], f[5 + 3 * k]);
      if (!p.allFinite())
        fail(file, ": triangle ", t, " (byte offset ", 84 + 50ull * t, "): non-finite vertex coordinate");
      tris[t][k] = w.add(p);
    }
    where[t] = mpskit::detail::concat("triangle ", t);
  }
  return finish<3>(w.mesh(tris), where, opt, file, w.merged());
}

inline read_result<3> parse_stl_ascii(const std::string& data, const std::string& file,
                                      const read_options& opt) {
  // token stream with line numbers
  std::vector<std::pair<std::string, index_t>> tok;
  {
    std::istringstream in(data);
    std::string line;
    index_t ln = 0;
    while (std::getline(in, line)) {
      ++ln;
      for (std::string& t : tokens(line, false)) tok.push_back({std::move(t), ln});
    }
  }
  std::size_t i = 0;
  const index_t last_line = tok.empty() ? 1 : tok.back().second;
  auto at_end = [&]() { return i >= tok.size(); };
  auto expect = [&](const char* word) {
    if (at_end()) fail(file, ":", last_line, ": file ends where '", word, "' was expected (truncated)");
    if (tok[i].first != word)
      fail(file, ":", tok[i].second, ": expected '", word, "', found '", tok[i].first, "'");
    ++i;
  };
  auto number = [&](const char* what) {
    if (at_end()) fail(file, ":", last_line, ": file ends inside a ", what, " (truncated)");
    const double v = to_double(tok[i].first, file, tok[i].second, what);
    ++i;
    return v;
  };
  vertex_welder w;
  std::vector<std::array<index_t, 3>> tris;
  std::vector<std::string> where;
  expect("solid");
  // optional name: everything on the 'solid' line
  const index_t solid_line = tok[i - 1].second;
  while (!at_end() && tok[i].second == solid_line) ++i;
  for (;;) {
    if (at_end()) fail(file, ":", last_line, ": file ends before 'endsolid' (truncated)");
    if (tok[i].first == "endsolid") {
      const index_t l = tok[i].second;
      ++i;
      while (!at_end() && tok[i].second == l) ++i;  // optional name
      if (at_end()) break;
      expect("solid");  // several solids in one file
      const index_t l2 = tok[i - 1].second;
      while (!at_end() && tok[i].second == l2) ++i;
      continue;
    }
    const index_t facet_line = at_end() ? last_line : tok[i].second;
    expect("facet");
    expect("normal");
    for (int k = 0; k < 3; ++k) number("facet normal component");
    expect("outer");
    expect("loop");
    std::array<index_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      expect("vertex");
      vec<3> p;
      for (int c = 0; c < 3; ++c) p[c] = number("vertex coordinate");
      t[k] = w.add(p);
    }
    if (!at_end() && tok[i].first == "vertex")
      fail(file, ":", tok[i].second, ": facet has more than 3 vertices (only triangles are STL)");
    expect("endloop");
    expect("endfacet");
    tris.push_back(t);
    where.push_back(mpskit::detail::concat("line ", facet_line));
  }
  return finish<3>(w.mesh(tris), where, opt, file, w.merged());
}
}  // namespace detail

/// Parses STL bytes: binary if the size is exactly 84 + 50·count, ASCII if it starts with "solid".
inline read_result<3> parse_stl(const std::string& data, const std::string& file = "<stl>",
                                const read_options& opt = {}) {
  if (data.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, data.data() + 80, 4);
    if (data.size() == 84 + 50ull * n) return detail::parse_stl_binary(data, file, opt);
  }
  const std::size_t s = data.find_first_not_of(" \t\r\n");
  if (s != std::string::npos && data.compare(s, 5, "solid") == 0 && data.find("facet") != std::string::npos)
    return detail::parse_stl_ascii(data, file, opt);
  if (s != std::string::npos && data.compare(s, 5, "solid") == 0 && data.size() < 84)
    return detail::parse_stl_ascii(data, file, opt);
  if (data.size() < 84)
    fail(file, ": ", data.size(), " bytes: too short for binary STL (84-byte header) and not ASCII STL");
  return detail::parse_stl_binary(data, file, opt);  // reports the size mismatch
}

/// Reads an STL file (ASCII or binary).
inline read_result<3> read_stl(const std::string& path, const read_options& opt = {}) {
  return parse_stl(detail::slurp(path), path, opt);
}

/// STL bytes of a mesh; ASCII uses 17 significant digits (exact), binary stores float32.
inline std::string format_stl(const polygon_mesh<3>& m, stl_format format = stl_format::binary,
                              const std::string& name = "mpskit") {
  if (format == stl_format::ascii) {
    std::ostringstream os;
    os.precision(17);
    os << "solid " << name << "\n";
    for (index_t e = 0; e < m.size(); ++e) {
      const mat<3> v = m.element(e);
      const vec<3> n = detail::winding_normal<3>(v).normalized();
      os << "  facet normal " << n.x() << " " << n.y() << " " << n.z() << "\n    outer loop\n";
      for (int k = 0; k < 3; ++k)
        os << "      vertex " << v(0, k) << " " << v(1, k) << " " << v(2, k) << "\n";
      os << "    endloop\n  endfacet\n";
    }
    os << "endsolid " << name << "\n";
    return os.str();
  }
  std::string out(84 + 50 * static_cast<std::size_t>(m.size()), '\0');
  const std::string header = "binary STL written by mpskit (float32)";
  std::memcpy(out.data(), header.data(), header.size());
  const std::uint32_t n = static_cast<std::uint32_t>(m.size());
  std::memcpy(out.data() + 80, &n, 4);
  for (index_t e = 0; e < m.size(); ++e) {
    const mat<3> v = m.element(e);
    const vec<3> nn = detail::winding_normal<3>(v).normalized();
    float f[12];
    for (int c = 0; c < 3; ++c) f[c] = static_cast<float>(nn[c]);
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) f[3 + 3 * k + c] = static_cast<float>(v(c, k));
    std::memcpy(out.data() + 84 + 50 * e, f, sizeof f);
  }
  return out;
}

/// Writes an STL file.
inline void write_stl(const std::string& path, const polygon_mesh<3>& m,
                      stl_format format = stl_format::binary) {
  detail::write_file<3>(path, format_stl(m, format));
}

}  // namespace mpskit::geometry
