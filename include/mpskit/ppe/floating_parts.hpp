#pragma once
/// \file ppe/floating_parts.hpp
/// \brief The connected parts of a PPE system that have no Dirichlet row (periodic boxes, closed tanks, dry
/// wall islands): each is singular (p is defined up to a constant) and must be pinned before the solve
/// (ARCHITECTURE.md §4). Shared by the schemes; how a part is pinned is the scheme's choice.
#include <cstdint>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/union_find.hpp"
#include "mpskit/ppe/concepts.hpp"

namespace mpskit::ppe {

/// One part with no Dirichlet row: its rows and the row to pin.
struct floating_part {
  index_t pin = npos;            ///< the row with the smallest key (deterministic: the lowest particle id)
  std::vector<index_t> members;  ///< every row of the part, pin included
};

/// Whether every part of the graph of A + Aᵀ holds a row with dirichlet[r] ≠ 0 (nothing to pin): one
/// union–find pass over A's entries (core/union_find.hpp: path halving, the smaller row index as the root),
/// no transpose. The free-surface flows' common case, checked first by find_floating_parts: on Tanaka's
/// obstacle dam break the transpose the search below needs took 9 % of the run (docs/performance.md "Floating
/// parts").
inline bool every_part_anchored(const matrix& A, const std::vector<std::uint8_t>& dirichlet) {
  const index_t m = A.rows();
  union_find sets(m);
  for (index_t r = 0; r < m; ++r) {
    index_t a = sets.find(r);  // r's root, kept current through the row's unions
    for (matrix::InnerIterator it(A, r); it; ++it)
      if (it.index() != r) a = sets.link(a, sets.find(it.index()));
  }
  std::vector<std::uint8_t> anchored(static_cast<std::size_t>(m), 0);
  for (index_t r = 0; r < m; ++r)
    if (dirichlet[static_cast<std::size_t>(r)]) anchored[static_cast<std::size_t>(sets.find(r))] = 1;
  for (index_t r = 0; r < m; ++r)
    if (!anchored[static_cast<std::size_t>(sets.find(r))]) return false;
  return true;
}

/// The parts of the graph of A (of A + Aᵀ when `symmetric` is false) none of whose rows has
/// dirichlet[r] ≠ 0, by a depth-first search (members in its order). key(r) orders the rows for the pin (e.g.
/// the particle id of row r). Use find_floating_parts, which skips this when every part is anchored.
template <class Key>
std::vector<floating_part> search_floating_parts(const matrix& A, const std::vector<std::uint8_t>& dirichlet,
                                                 bool symmetric, const Key& key) {
  const index_t m = A.rows();
  matrix At;
  if (!symmetric) At = A.transpose();
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(m), 0);
  std::vector<index_t> stack;
  std::vector<floating_part> parts;
  floating_part part;
  for (index_t r0 = 0; r0 < m; ++r0) {
    if (seen[static_cast<std::size_t>(r0)]) continue;
    bool has_dirichlet = false;
    part.pin = r0;
    part.members.clear();
    stack.assign(1, r0);
    seen[static_cast<std::size_t>(r0)] = 1;
    while (!stack.empty()) {
      const index_t r = stack.back();
      stack.pop_back();
      part.members.push_back(r);
      has_dirichlet |= dirichlet[static_cast<std::size_t>(r)] != 0;
      if (key(r) < key(part.pin)) part.pin = r;
      const auto visit = [&](const matrix& M) {
        for (matrix::InnerIterator it(M, r); it; ++it)
          if (!seen[static_cast<std::size_t>(it.index())]) {
            seen[static_cast<std::size_t>(it.index())] = 1;
            stack.push_back(it.index());
          }
      };
      visit(A);
      if (!symmetric) visit(At);
    }
    if (!has_dirichlet) parts.push_back(part);
  }
  return parts;
}

/// The parts of the graph of A (of A + Aᵀ when `symmetric` is false) none of whose rows has
/// dirichlet[r] ≠ 0. key(r) orders the rows for the pin (e.g. the particle id of row r). When every part has
/// a Dirichlet row (every_part_anchored) the answer is empty and no search is made; otherwise the parts are
/// those of search_floating_parts, members in its order (so the pinned solve is the same to the bit as before
/// the check was added).
template <class Key>
std::vector<floating_part> find_floating_parts(const matrix& A, const std::vector<std::uint8_t>& dirichlet,
                                               bool symmetric, const Key& key) {
  if (every_part_anchored(A, dirichlet)) return {};
  return search_floating_parts(A, dirichlet, symmetric, key);
}

}  // namespace mpskit::ppe
