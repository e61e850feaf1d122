#pragma once
/// \file op/concepts.hpp
/// \brief Concepts of the operator area. Operators expose *stencils*: rows of coefficients generated on
/// demand per particle, shared by explicit application and implicit (PPE) assembly, so no per-pair
/// weights are stored (ARCHITECTURE.md §4).
///
/// Row convention (every operator, every row): ⟨Lφ⟩_i = Σ_j a_ij (φ_j − φ_i) (+ hook terms), so the
/// diagonal is −Σ_j a_ij and a constant field gives exactly zero.
#include <concepts>

#include "mpskit/core/dimension.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::op {

/// Accepts every neighbour (default filter of operator sweeps).
struct all_neighbours {
  constexpr bool operator()(index_t) const noexcept { return true; }
};

/// A scalar Laplacian stencil over D-dimensional positions: `op.for_each_laplacian_weight(x, list, i,
/// filter, f)` calls f(j, a_ij) with ⟨∇²φ⟩_i = Σ_j a_ij (φ_j − φ_i).
template <class Op, int D>
concept LaplacianStencil = requires(const Op& op, const points<D>& x, const search::neighbour_list<D>& nl,
                                    index_t i) {
  op.for_each_laplacian_weight(x, nl, i, all_neighbours{}, [](index_t, double) {});
};

/// A gradient stencil: `op.for_each_gradient_weight(x, list, i, filter, f)` calls f(j, c_ij) with
/// ⟨∇φ⟩_i = Σ_j c_ij (φ_j − φ_i), c_ij a vec<D>.
template <class Op, int D>
concept GradientStencil = requires(const Op& op, const points<D>& x, const search::neighbour_list<D>& nl,
                                   index_t i) {
  op.for_each_gradient_weight(x, nl, i, all_neighbours{}, [](index_t, const vec<D>&) {});
};

}  // namespace mpskit::op
