#pragma once
/// \file io/concepts.hpp
/// \brief Concepts of io/: what a writer needs of a particle state, and what a scheme or policy offers
/// to be saved in a checkpoint.
#include <concepts>

#include "mpskit/core/dimension.hpp"

namespace mpskit::io {

class checkpoint_sections;

/// A particle state the writers accept (mpskit::particle_state models it).
template <class S>
concept ParticleState = requires(const S& s) {
  { S::dim } -> std::convertible_to<int>;
  typename S::fields;
  { s.size() } -> std::convertible_to<index_t>;
  { s.n_real() } -> std::convertible_to<index_t>;
  { s.next_id() } -> std::convertible_to<particle_id>;
};

/// Something whose state goes into a checkpoint beside the particles (time-step controller, counters,
/// time and step, bodies): it adds named sections and reads them back.
template <class T>
concept Checkpointable = requires(const T& c, T& m, checkpoint_sections& out, const checkpoint_sections& in) {
  c.save(out);
  m.load(in);
};

}  // namespace mpskit::io
