#pragma once
/// \file geometry/obj.hpp
/// \brief Wavefront OBJ reader and writer (geometry only): `v x y z [w]` and `f a b c ...` with
/// `a`, `a/t`, `a//n`, `a/t/n` references, 1-based or negative (relative); polygons with more than
/// three vertices are fan-triangulated. Other statements (vt, vn, o, g, s, usemtl, mtllib, l, ...)
/// are ignored.
#include <array>
#include <sstream>
#include <string>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/geometry/detail/reader.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"

namespace mpskit::geometry {

/// Parses OBJ text; `file` names the source in messages.
inline read_result<3> parse_obj(const std::string& text, const std::string& file = "<obj>",
                                const read_options& opt = {}) {
  std::istringstream in(text);
  std::string line;
  index_t ln = 0;
  std::vector<vec<3>> v;
  std::vector<std::array<index_t, 3>> tris;
  std::vector<std::string> where;
  while (std::getline(in, line)) {
    ++ln;
    const std::vector<std::string> t = detail::tokens(line);
    if (t.empty()) continue;
    if (t[0] == "v") {
      if (t.size() != 4 && t.size() != 5)
        fail(file, ":", ln, ": vertex: expected 'v x y z [w]', found ", t.size() - 1, " number(s)");
      vec<3> p;
      for (int k = 0; k < 3; ++k) p[k] = detail::to_double(t[1 + k], file, ln, "vertex coordinate");
      v.push_back(p);
    } else if (t[0] == "f") {
      if (t.size() < 4) fail(file, ":", ln, ": face needs at least 3 vertices, found ", t.size() - 1);
      std::vector<index_t> ids;
      const long long nv = static_cast<long long>(v.size());
      for (std::size_t k = 1; k < t.size(); ++k) {
        const std::string ref = t[k].substr(0, t[k].find('/'));
        const long long r = detail::to_integer(ref, file, ln, "face vertex index");
        const long long idx = r > 0 ? r - 1 : nv + r;  // negative: relative to the vertices so far
        if (r == 0 || idx < 0 || idx >= nv)
          fail(file, ":", ln, ": face refers to vertex ", r, ", but ", nv,
               " vertices are defined so far (accepted 1..", nv, " or -", nv, "..-1)");
        ids.push_back(idx);
      }
      for (std::size_t k = 1; k + 1 < ids.size(); ++k) {
        tris.push_back({ids[0], ids[k], ids[k + 1]});
        where.push_back(mpskit::detail::concat("line ", ln));
      }
    }
  }
  polygon_mesh<3> m;
  m.vertices.resize(3, static_cast<index_t>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) m.vertices.col(static_cast<index_t>(i)) = v[i];
  m.elements.resize(3, static_cast<index_t>(tris.size()));
  for (std::size_t e = 0; e < tris.size(); ++e)
    for (int k = 0; k < 3; ++k) m.elements(k, static_cast<index_t>(e)) = tris[e][k];
  return detail::finish<3>(std::move(m), where, opt, file);
}

/// Reads an OBJ file.
inline read_result<3> read_obj(const std::string& path, const read_options& opt = {}) {
  return parse_obj(detail::slurp(path), path, opt);
}

/// OBJ text of a mesh (17 significant digits: exact round trip).
inline std::string format_obj(const polygon_mesh<3>& m) {
  std::ostringstream os;
  os.precision(17);
  os << "# written by mpskit\n";
  for (index_t i = 0; i < m.vertices.cols(); ++i)
    os << "v " << m.vertices(0, i) << " " << m.vertices(1, i) << " " << m.vertices(2, i) << "\n";
  for (index_t e = 0; e < m.size(); ++e)
    os << "f " << m.elements(0, e) + 1 << " " << m.elements(1, e) + 1 << " " << m.elements(2, e) + 1 << "\n";
  return os.str();
}

/// Writes an OBJ file.
inline void write_obj(const std::string& path, const polygon_mesh<3>& m) {
  detail::write_file<3>(path, format_obj(m));
}

}  // namespace mpskit::geometry
