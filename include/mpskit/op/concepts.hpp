#pragma once
/// \file op/concepts.hpp
/// \brief Concepts of the operator area. Operators expose *stencils*: rows of coefficients generated on
/// demand per particle, shared by explicit application and implicit (PPE) assembly, so no per-pair
/// weights are stored (ARCHITECTURE.md §4).
///
/// Row convention (every operator, every row): ⟨Lφ⟩_i = Σ_j a_ij (φ_j − φ_i) (+ hook terms), so the
/// diagonal is −Σ_j a_ij and a constant field gives exactly zero.
#include <Eigen/Core>
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

/// One particle diameter (or spacing) for every particle: L_i = L (single resolution).
struct uniform_size {
  static constexpr bool uniform = true;
  double L = 0.0;  ///< the diameter (m)
  double operator()(index_t) const noexcept { return L; }
};

/// Per-particle diameters L_i (multi-resolution); the array must outlive every use of the operator.
struct per_particle_size {
  static constexpr bool uniform = false;
  const Eigen::VectorXd* L = nullptr;  ///< L_i (m)
  double operator()(index_t i) const noexcept { return (*L)[i]; }
};

/// A size model: uniform_size or per_particle_size.
template <class S>
concept SizeModel = requires(const S& s, index_t i) {
  { s(i) } -> std::convertible_to<double>;
  { S::uniform } -> std::convertible_to<bool>;
};

/// \brief Collects one operator row in absolute form (docs/operators.md "Rows and the hook"):
///   ⟨Lφ⟩_i = Σ_j a_j φ_j + a_diag φ_i + c.
/// `add(j, a)` adds a·φ_j (j ≠ i; a column may be added more than once, the builder sums),
/// `add_diagonal(a)` adds a·φ_i, `add_constant(c)` adds a known term c (a right-hand side in assembly).
/// An operator's own weights a_ij arrive as add(j, a_ij) and add_diagonal(−a_ij), so a row built from the
/// relative convention Σ a_ij (φ_j − φ_i) still gives zero on constants.
template <class B>
concept RowBuilder = requires(B& b, index_t j, double a) {
  b.add(j, a);
  b.add_diagonal(a);
  b.add_constant(a);
};

/// \brief The row-contribution hook: `hook(i, row, builder)` is called once per row after the operator
/// has emitted its own weights. `row` is the operator's row view (lsmps: `weight(v)` for a virtual
/// neighbour with weighted basis vector v, `neumann_vector()`; mps: `weight(d)` for a virtual neighbour at
/// displacement d); the hook may add weights to existing columns, a constant, and diagonal terms through
/// `builder` (Neumann constraint, ERP mirror sums, dummy-particle pressures).
template <class H, class Row, class B>
concept RowContribution = RowBuilder<B> && requires(const H& h, index_t i, const Row& row, B& b) {
  h(i, row, b);
};

/// The hook that adds nothing.
struct no_contribution {
  template <class Row, class B>
  constexpr void operator()(index_t, const Row&, B&) const noexcept {}
};

}  // namespace mpskit::op
