#pragma once
/// \file wall/dummy_layers.hpp
/// \brief Wall + dummy particle layers (Koshizuka & Oka 1996; bmmr.md §2.4, §2.8): one layer of wall
/// particles in contact with the fluid, solved in the PPE, and dummy layers behind it that only complete
/// the number density of wall particles; a dummy's pressure is never an unknown but is read relative to
/// the row that needs it, P_j = P_i + ρ g·x_ij (Matsunaga et al. 2020's simplified Neumann condition,
/// bmmr.md eq. 17, in polymps' reading: the term goes to the right-hand side, nothing to the matrix).
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/kinds.hpp"

namespace mpskit::wall {

/// The wall policy (the scheme reads particle kinds wall / dummy).
struct dummy_layers final {
  static constexpr bool has_wall_particles = true;
  int layers = 3;  ///< total solid layers (1 wall + layers−1 dummy); 3 cover 2.1 l0 and 3.1 l0 supports
};

/// Particles of one kind-tagged generator output.
template <int D>
struct particle_block {
  std::vector<vec<D>> x;   ///< positions
  std::vector<kind> kinds; ///< kind per position
  /// Number of particles.
  std::size_t size() const { return x.size(); }
  /// Appends another block.
  void append(const particle_block& o) {
    x.insert(x.end(), o.x.begin(), o.x.end());
    kinds.insert(kinds.end(), o.kinds.begin(), o.kinds.end());
  }
};

/// Fluid particles on the lattice lo + (i + ½) l0 filling the box [lo, hi] (cell-centred, so the walls
/// of box_walls sit one spacing from the nearest fluid particle).
template <int D>
particle_block<D> fill_box(const vec<D>& lo, const vec<D>& hi, double l0, kind k = kind::fluid) {
  if (!(std::isfinite(l0) && l0 > 0.0)) fail("fill_box: l0 = ", l0, ": must be a finite number > 0");
  std::array<long, D> n{};
  for (int a = 0; a < D; ++a) {
    if (!(hi[a] > lo[a])) fail("fill_box: hi[", a, "] = ", hi[a], " must exceed lo[", a, "] = ", lo[a]);
    n[a] = std::lround((hi[a] - lo[a]) / l0);
    if (n[a] < 1) fail("fill_box: the box is thinner than one spacing on axis ", a);
  }
  particle_block<D> b;
  std::array<long, D> c{};
  while (true) {
    vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = lo[a] + (double(c[a]) + 0.5) * l0;
    b.x.push_back(p);
    b.kinds.push_back(k);
    int a = 0;
    while (a < D && ++c[a] >= n[a]) c[a++] = 0;
    if (a == D) break;
  }
  return b;
}

/// Walls of a tank whose fluid space is [lo, hi] (the last axis is vertical): `layers` solid layers on
/// every face, the top one only when `open_top` is false; first layer kind::wall, the others kind::dummy,
/// on the same cell-centred lattice (layer m at distance (m + ½) l0 outside the box face), corners filled.
template <int D>
particle_block<D> box_walls(const vec<D>& lo, const vec<D>& hi, double l0, int layers, bool open_top = true) {
  if (layers < 1) fail("box_walls: layers = ", layers, ": must be >= 1");
  if (!(std::isfinite(l0) && l0 > 0.0)) fail("box_walls: l0 = ", l0, ": must be a finite number > 0");
  std::array<long, D> n{};
  for (int a = 0; a < D; ++a) {
    n[a] = std::lround((hi[a] - lo[a]) / l0);
    if (n[a] < 1) fail("box_walls: the box is thinner than one spacing on axis ", a);
  }
  particle_block<D> b;
  // Lattice index range including `layers` cells outside on every face except the top.
  std::array<long, D> from{}, to{};
  for (int a = 0; a < D; ++a) {
    from[a] = -layers;
    to[a] = (a == D - 1 && open_top) ? n[a] - 1 : n[a] - 1 + layers;
  }
  std::array<long, D> c = from;
  while (true) {
    // Distance in layers outside the box (Chebyshev): 0 inside.
    long out = 0;
    for (int a = 0; a < D; ++a) {
      if (c[a] < 0) out = std::max(out, -c[a]);
      if (c[a] >= n[a]) out = std::max(out, c[a] - n[a] + 1);
    }
    if (out >= 1) {
      vec<D> p;
      for (int a = 0; a < D; ++a) p[a] = lo[a] + (double(c[a]) + 0.5) * l0;
      b.x.push_back(p);
      b.kinds.push_back(out == 1 ? kind::wall : kind::dummy);
    }
    int a = 0;
    while (a < D && ++c[a] > to[a]) {
      c[a] = from[a];
      ++a;
    }
    if (a == D) break;
  }
  return b;
}

}  // namespace mpskit::wall
