#pragma once
/// \file geometry/polyline_io.hpp
/// \brief The mpskit 2D polyline format (docs/geometry.md §Formats): reader and writer.
///
/// ```
/// mpskit_polyline 1          # magic and version; '#' starts a comment anywhere
/// vertices 4                 # count, then one "x y" line per vertex (m)
/// 0 0
/// 1 0
/// 1 1
/// 0 1
/// segments 3                 # count, then one "i j" line per segment (0-based vertex indices)
/// 3 0                        # the fluid is on the LEFT of i→j
/// 0 1
/// 1 2
/// ```
#include <sstream>
#include <string>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/geometry/detail/reader.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"

namespace mpskit::geometry {

/// Parses polyline text; `file` names the source in messages.
inline read_result<2> parse_polyline(const std::string& text, const std::string& file = "<polyline>",
                                     const read_options& opt = {}) {
  std::istringstream in(text);
  std::string line;
  index_t lineno = 0;
  // next non-empty line's tokens; empty vector at end of file
  auto next = [&]() {
    while (std::getline(in, line)) {
      ++lineno;
      std::vector<std::string> t = detail::tokens(line);
      if (!t.empty()) return t;
    }
    ++lineno;
    return std::vector<std::string>{};
  };
  std::vector<std::string> t = next();
  if (t.size() != 2 || t[0] != "mpskit_polyline")
    fail(file, ":", lineno, ": expected header 'mpskit_polyline 1'");
  if (t[1] != "1") fail(file, ":", lineno, ": unsupported polyline format version '", t[1], "', accepted: 1");
  auto count = [&](const char* keyword) {
    std::vector<std::string> c = next();
    if (c.empty()) fail(file, ":", lineno, ": file ends before '", keyword, " <count>' (truncated)");
    if (c.size() != 2 || c[0] != keyword) fail(file, ":", lineno, ": expected '", keyword, " <count>'");
    const long long n = detail::to_integer(c[1], file, lineno, keyword);
    if (n < 0) fail(file, ":", lineno, ": ", keyword, " count ", n, " is negative");
    return static_cast<index_t>(n);
  };
  polygon_mesh<2> m;
  const index_t nv = count("vertices");
  m.vertices.resize(2, nv);
  for (index_t i = 0; i < nv; ++i) {
    const std::vector<std::string> c = next();
    if (c.empty())
      fail(file, ":", lineno, ": file ends after ", i, " of ", nv, " vertices (truncated or wrong count)");
    if (c[0] == "segments")
      fail(file, ":", lineno, ": found 'segments' after ", i, " of ", nv, " vertices (wrong vertex count)");
    if (c.size() != 2)
      fail(file, ":", lineno, ": vertex ", i, ": expected 2 coordinates, found ", c.size(), " field(s)");
    for (int k = 0; k < 2; ++k) m.vertices(k, i) = detail::to_double(c[k], file, lineno, "vertex coordinate");
  }
  const index_t ns = count("segments");
  m.elements.resize(2, ns);
  std::vector<std::string> where;
  for (index_t e = 0; e < ns; ++e) {
    const std::vector<std::string> c = next();
    if (c.empty())
      fail(file, ":", lineno, ": file ends after ", e, " of ", ns, " segments (truncated or wrong count)");
    if (c.size() != 2)
      fail(file, ":", lineno, ": segment ", e, ": expected 2 vertex indices, found ", c.size(), " field(s)");
    for (int k = 0; k < 2; ++k) {
      const long long v = detail::to_integer(c[k], file, lineno, "segment vertex index");
      if (v < 0 || v >= nv)
        fail(file, ":", lineno, ": segment ", e, " refers to vertex ", v, ", accepted range [0, ", nv - 1,
             "]");
      m.elements(k, e) = v;
    }
    where.push_back(mpskit::detail::concat("line ", lineno));
  }
  if (!next().empty())
    fail(file, ":", lineno, ": unexpected content after the last segment (more segments than declared?)");
  return detail::finish<2>(std::move(m), where, opt, file);
}

/// Reads a polyline file.
inline read_result<2> read_polyline(const std::string& path, const read_options& opt = {}) {
  return parse_polyline(detail::slurp(path), path, opt);
}

/// Polyline text of a mesh (17 significant digits: exact round trip).
inline std::string format_polyline(const polygon_mesh<2>& m) {
  std::ostringstream os;
  os.precision(17);
  os << "mpskit_polyline 1\nvertices " << m.vertices.cols() << "\n";
  for (index_t i = 0; i < m.vertices.cols(); ++i) os << m.vertices(0, i) << " " << m.vertices(1, i) << "\n";
  os << "segments " << m.size() << "\n";
  for (index_t e = 0; e < m.size(); ++e) os << m.elements(0, e) << " " << m.elements(1, e) << "\n";
  return os.str();
}

/// Writes a polyline file.
inline void write_polyline(const std::string& path, const polygon_mesh<2>& m) {
  detail::write_file<2>(path, format_polyline(m));
}

}  // namespace mpskit::geometry
