#pragma once
/// \file resolution/graded_lattice.hpp
/// \brief A graded initial particle distribution in 2D: the square lattice of spacing L, each lattice cell subdivided
/// until the split trigger of split_merge is satisfied, so a multi-resolution run starts at its target diameter
/// instead of splitting its start lattice in its first steps (ours: Tanaka 2018 does not say how the initial
/// distribution of a multi-resolution case is made; docs/resolution.md, "Graded start").
///
/// A square cell of side h centred at x (a particle of diameter h, volume h²) is a leaf when the trigger does not
/// ask it to split at L*(x). Otherwise, if a particle of diameter h/√2 would not be asked to split either (at
/// the same point x), the cell holds two particles of diameter h/√2 at x ± (h/4)(1, 1), its two diagonal
/// quadrant centres (one split of split_merge: the two together form the 45°-rotated square lattice of spacing
/// h/√2); else it is divided into its four quadrants, each treated the same way. So every particle lies strictly
/// inside its start cell, an even number of splits gives the cell-centred square lattice of spacing L/2^(k/2), an
/// odd number the rotated one, volumes are L²/2^k exactly and sum to the cells' area. The trigger is asked at
/// the square cells' centres: a leaf square does not ask to split at its own position; a diagonal pair was
/// decided at its cell's centre, (h/4)√2 from each particle, so where L* varies across a cell one of the two may
/// ask to split (or merge) in the first step (the test measures how many).
///
/// 2D only for now (the 3D analogue, not written: a cube's two diagonal octant centres after one split, four
/// alternating octant centres after two, its eight octants after three).
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/resolution/concepts.hpp"
#include "mpskit/resolution/split_merge.hpp"

namespace mpskit::resolution {

/// The particles of a graded lattice (2D): positions, volumes (V = L²/2^k) and split generations k.
struct graded_points {
  std::vector<vec<2>> x;
  std::vector<double> volume;
  std::vector<int> generation;
  std::size_t size() const { return x.size(); }
};

/// Fills the box [lo, hi] with square cells of side L (centres lo + (i + ½, j + ½) L strictly inside the box),
/// subdivides them as in the file comment (`Trigger::decide<2>(target(x), h)`, target(x) the target diameter L*,
/// called at every square cell's centre, in lattice order), and keeps the particles for which `keep(x, h)` is
/// true (e.g. the signed wall distance ≥ h/2). Cells are subdivided before `keep` is asked, so a cell whose centre
/// is too close to a wall can still leave its inner particles. Refused: L or the box not positive and finite, a
/// target that is not finite and > 0, more than `max_generations` splits (a target far below L).
template <class Trigger = tanaka_thresholds, class Target, class Keep>
graded_points graded_lattice(const vec<2>& lo, const vec<2>& hi, double L, const Target& target, const Keep& keep,
                             int max_generations = 20) {
  static_assert(resolution::Trigger<Trigger>, "graded_lattice: Trigger must model resolution::Trigger");
  if (!(std::isfinite(L) && L > 0.0))
    fail("graded_lattice: the start spacing L is ", L, ": accepted range (0, inf)");
  if (!(lo.allFinite() && hi.allFinite() && (hi - lo).minCoeff() > 0.0))
    fail("graded_lattice: the box [(", lo.transpose(), "), (", hi.transpose(), ")] is empty or not finite");
  if (max_generations < 0 || max_generations > 60)
    fail("graded_lattice: max_generations is ", max_generations, ": accepted range [0, 60]");
  struct cell {
    vec<2> x;  // centre
    int k;     // even: the cell's side is L/2^(k/2), its particle's volume L²/2^k
  };
  graded_points out;
  const auto emit = [&](const vec<2>& x, int k) {
    const double V = std::ldexp(L * L, -k);  // exact halving
    const double h = std::sqrt(V);
    if (!keep(x, h)) return;
    out.x.push_back(x);
    out.volume.push_back(V);
    out.generation.push_back(k);
  };
  const auto asks_split = [&](const vec<2>& x, double Ls, int k) {
    if (Trigger::template decide<2>(Ls, std::sqrt(std::ldexp(L * L, -k))) != want::split) return false;
    if (k >= max_generations)
      fail("graded_lattice: the particle at (", x.transpose(), ") still asks to split after ", max_generations,
           " generations (diameter ", std::sqrt(std::ldexp(L * L, -k)), ", target ", Ls, ")");
    return true;
  };
  std::vector<cell> stack;
  const vec<2> ext = hi - lo;
  for (long i = 0; (static_cast<double>(i) + 0.5) * L < ext.x(); ++i)
    for (long j = 0; (static_cast<double>(j) + 0.5) * L < ext.y(); ++j) {
      stack.push_back({lo + vec<2>((static_cast<double>(i) + 0.5) * L, (static_cast<double>(j) + 0.5) * L), 0});
      while (!stack.empty()) {
        const cell c = stack.back();
        stack.pop_back();
        const double Ls = target(c.x);
        if (!(std::isfinite(Ls) && Ls > 0.0))
          fail("graded_lattice: the target diameter is ", Ls, " at (", c.x.transpose(), "): accepted range (0, inf)");
        if (!asks_split(c.x, Ls, c.k)) {
          emit(c.x, c.k);
          continue;
        }
        const double q = 0.25 * std::sqrt(std::ldexp(L * L, -c.k));  // a quarter of the cell's side
        if (!asks_split(c.x, Ls, c.k + 1)) {  // the diagonal pair (one split)
          emit(c.x - vec<2>(q, q), c.k + 1);
          emit(c.x + vec<2>(q, q), c.k + 1);
          continue;
        }
        // The four quadrants, depth first; popped (and emitted) lower-left, lower-right, upper-left, upper-right.
        for (const vec<2>& d : {vec<2>(q, q), vec<2>(-q, q), vec<2>(q, -q), vec<2>(-q, -q)})
          stack.push_back({c.x + d, c.k + 2});
      }
    }
  return out;
}

}  // namespace mpskit::resolution
