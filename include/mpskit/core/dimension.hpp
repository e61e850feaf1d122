#pragma once
/// \file core/dimension.hpp
/// \brief Dimension tag and the Eigen aliases used everywhere (ARCHITECTURE.md §3).
#include <Eigen/Core>
#include <cstdint>

namespace mpskit {

/// Spatial dimension: 2 or 3.
template <int D>
concept Dimension = (D == 2 || D == 3);

/// Compile-time dimension tag.
template <int D>
  requires Dimension<D>
struct dim {
  static constexpr int value = D;
};

/// A point or vector in D dimensions.
template <int D>
using vec = Eigen::Matrix<double, D, 1>;
/// A D×D matrix (moments, deformation gradients).
template <int D>
using mat = Eigen::Matrix<double, D, D>;
/// Particle positions, velocities, any vector field: particle i is `.col(i)` (structure of arrays).
template <int D>
using points = Eigen::Matrix<double, D, Eigen::Dynamic>;
/// Scalar field over particles.
using scalars = Eigen::VectorXd;

/// Particle index inside a state (changes on reorder); signed so that `npos` = -1 can mark "none".
using index_t = std::int64_t;
/// "No particle".
inline constexpr index_t npos = -1;
/// Persistent particle id, never reused.
using particle_id = std::uint64_t;
/// Id of a ghost (ghosts are not particles and have no id until promoted).
inline constexpr particle_id no_id = ~particle_id{0};

}  // namespace mpskit
