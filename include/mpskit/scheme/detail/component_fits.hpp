#pragma once
/// \file scheme/detail/component_fits.hpp
/// \brief ∇ and ∇² of a vector field's D components at one particle: one neighbour sweep where the operator
/// offers it (op::lsmps_a::gradients / laplacians), else D scalar calls. Both give the same numbers to the
/// bit (the fused sweep adds the same terms in the same order), so the choice is speed only: on the obstacle
/// dam break the D sweeps of ∇u′, ∇²u and the shifting's ∇u were 11 % of the run (docs/performance.md "Fused
/// fits").
#include <array>
#include <cstddef>

#include <Eigen/Core>

#include "mpskit/core/dimension.hpp"
#include "mpskit/search/neighbour_list.hpp"

namespace mpskit::scheme::detail {

/// Rows a: ⟨∇u_a⟩_i for the components u[a].
template <int D, class Op, class Filter>
mat<D> component_gradients(const Op& op, const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                           const std::array<Eigen::VectorXd, static_cast<std::size_t>(D)>& u,
                           const Filter& filter) {
  if constexpr (requires { op.gradients(x, nl, i, u, filter); }) {
    return op.gradients(x, nl, i, u, filter);
  } else {
    mat<D> G;
    for (int a = 0; a < D; ++a)
      G.row(a) = op.gradient(x, nl, i, u[static_cast<std::size_t>(a)], filter).transpose();
    return G;
  }
}

/// Entries a: ⟨∇²u_a⟩_i for the components u[a].
template <int D, class Op, class Filter>
vec<D> component_laplacians(const Op& op, const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                            const std::array<Eigen::VectorXd, static_cast<std::size_t>(D)>& u,
                            const Filter& filter) {
  if constexpr (requires { op.laplacians(x, nl, i, u, filter); }) {
    return op.laplacians(x, nl, i, u, filter);
  } else {
    vec<D> l;
    for (int a = 0; a < D; ++a) l[a] = op.laplacian(x, nl, i, u[static_cast<std::size_t>(a)], filter);
    return l;
  }
}

}  // namespace mpskit::scheme::detail
