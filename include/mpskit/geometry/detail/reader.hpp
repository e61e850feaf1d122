#pragma once
/// \file geometry/detail/reader.hpp
/// \brief Shared reader plumbing: file slurping, line tokenising, strict number parsing, and the
/// final defect pass (refuse or drop degenerate/duplicate elements, fill the quality report).
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "mpskit/core/error.hpp"
#include "mpskit/geometry/polygon_mesh.hpp"

namespace mpskit::geometry {

/// Options of every reader.
struct read_options {
  bool drop_degenerate = false;  ///< remove degenerate elements (counted) instead of refusing the file
  bool drop_duplicates = false;  ///< remove repeated elements (counted); by default they are only reported
};

/// A mesh as read, with its quality report.
template <int D>
struct read_result {
  polygon_mesh<D> mesh;    ///< vertices and elements, orientation as in the file
  quality_report quality;  ///< defects found (see docs/geometry.md)
};

namespace detail {

inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, ": cannot open for reading");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Whitespace tokens of one line, with '#' comments removed when `hash_comments`.
inline std::vector<std::string> tokens(const std::string& line, bool hash_comments = true) {
  std::string s = line;
  if (hash_comments) {
    const std::size_t h = s.find('#');
    if (h != std::string::npos) s.resize(h);
  }
  std::istringstream is(s);
  std::vector<std::string> t;
  for (std::string w; is >> w;) t.push_back(w);
  return t;
}

/// Strict finite double: the whole token must parse and be finite.
inline double to_double(const std::string& tok, const std::string& file, index_t line, const char* what) {
  const char* b = tok.c_str();
  char* e = nullptr;
  errno = 0;
  const double v = std::strtod(b, &e);
  if (e == b || *e != '\0') fail(file, ":", line, ": ", what, ": '", tok, "' is not a number");
  if (!std::isfinite(v) || errno == ERANGE)
    fail(file, ":", line, ": ", what, ": '", tok, "' is not a finite number");
  return v;
}

/// Strict integer.
inline long long to_integer(const std::string& tok, const std::string& file, index_t line, const char* what) {
  const char* b = tok.c_str();
  char* e = nullptr;
  errno = 0;
  const long long v = std::strtoll(b, &e, 10);
  if (e == b || *e != '\0' || errno == ERANGE)
    fail(file, ":", line, ": ", what, ": '", tok, "' is not an integer");
  return v;
}

/// Final pass: analyses the mesh, refuses (or drops) degenerate elements and optionally drops
/// duplicates. `where[e]` names element e's origin ("line 12" or "triangle 7").
template <int D>
inline read_result<D> finish(polygon_mesh<D> mesh, const std::vector<std::string>& where,
                             const read_options& opt, const std::string& file, index_t merged = 0) {
  validate(mesh, file);
  if (mesh.size() == 0) fail(file, ": no elements");
  quality_report q = analyse(mesh);
  std::vector<char> drop(static_cast<std::size_t>(mesh.size()), 0);
  index_t dropped_deg = 0, dropped_dup = 0;
  if (!q.degenerate.empty()) {
    if (!opt.drop_degenerate) {
      const index_t e = q.degenerate.front();
      fail(file, ": ", where[e], ": element ", e, " is degenerate (zero length/area or repeated vertex); ",
           q.degenerate.size(), " degenerate element(s) in total (read option drop_degenerate removes them)");
    }
    for (index_t e : q.degenerate) drop[e] = 1;
    dropped_deg = static_cast<index_t>(q.degenerate.size());
  }
  if (opt.drop_duplicates)
    for (const auto& d : q.duplicate)
      if (!drop[d.first]) {
        drop[d.first] = 1;
        ++dropped_dup;
      }
  if (dropped_deg + dropped_dup > 0) {
    element_indices<D> kept(D, mesh.size() - dropped_deg - dropped_dup);
    index_t k = 0;
    for (index_t e = 0; e < mesh.size(); ++e)
      if (!drop[e]) kept.col(k++) = mesh.elements.col(e);
    mesh.elements = std::move(kept);
    if (mesh.size() == 0) fail(file, ": no elements left after dropping degenerate/duplicate ones");
    q = analyse(mesh);
  }
  q.merged_vertices = merged;
  q.dropped_degenerate = dropped_deg;
  q.dropped_duplicate = dropped_dup;
  return {std::move(mesh), std::move(q)};
}

template <int D>
inline void write_file(const std::string& path, const std::string& data) {
  std::ofstream out(path, std::ios::binary);
  if (!out) fail(path, ": cannot open for writing");
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  if (!out) fail(path, ": write failed");
}

}  // namespace detail
}  // namespace mpskit::geometry
