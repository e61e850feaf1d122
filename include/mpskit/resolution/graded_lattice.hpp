#pragma once
/// \file resolution/graded_lattice.hpp
/// \brief A graded initial particle distribution in 2D and 3D: the square (cubic) lattice of spacing L, each
/// lattice cell subdivided until the split trigger of split_merge is satisfied, so a multi-resolution run
/// starts at its target diameter instead of splitting its start lattice in its first steps (ours: Tanaka 2018
/// does not say how the initial distribution of a multi-resolution case is made; docs/resolution.md, "Graded
/// start").
///
/// A cell of side h centred at x (a particle of volume h^D) is a leaf when the trigger does not ask its
/// particle to split at L*(x). Otherwise it takes the smallest r in 1..D−1 for which a particle of volume
/// h^D/2^r would not be asked (at the same point x) and holds 2^r such particles at sub-cell centres x
/// + (h/4) s, s ∈ {±1}^D (r splits of split_merge); if there is none it is divided into its 2^D sub-cells,
/// each treated the same way. The sub-cell centres used:
///   - 2D, r = 1: s = ±(1, 1), the diagonal pair: with the neighbouring cells the 45°-rotated square lattice
///     of spacing h/√2;
///   - 3D, r = 1: s = ±(1, 1, 1), the body-diagonal pair: the body-centred cubic lattice (nearest distance
///     (√3/2) h = 1.09 diameters);
///   - 3D, r = 2: the four s with s₁s₂s₃ = +1: the face-centred cubic lattice (nearest distance h/√2 = 1.12
///     diameters).
/// So every particle lies strictly inside its start cell, volumes are L^D/2^k exactly and sum to the cells'
/// volume, and D splits give the cell-centred lattice of spacing h/2. The trigger is asked at the cells'
/// centres: a leaf cell does not ask to split at its own position; the particles of a pattern were decided at
/// their cell's centre, (h/4)√D from each particle, so where L* varies across a cell one of them may ask to
/// split (or merge) in the first step (the tests measure how many). A pattern's particles lie a quarter cell
/// from the cell's faces, less than half their diameter: beside a wall aligned with the cells, `keep` (a
/// clearance test) drops them, so a target that asks for r in 1..D−1 beside such a wall leaves a gap there
/// (the Poiseuille start refuses it, cases/).
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/resolution/concepts.hpp"
#include "mpskit/resolution/split_merge.hpp"

namespace mpskit::resolution {

/// The particles of a graded lattice: positions, volumes (V = L^D/2^k) and split generations k, and the
/// volume of the particles `keep` rejected (0 when every start cell is filled: a caller can refuse a gap at a
/// wall).
template <int D>
struct graded_points {
  std::vector<vec<D>> x;
  std::vector<double> volume;
  std::vector<int> generation;
  double dropped_volume = 0.0;
  std::size_t size() const { return x.size(); }
};

/// Fills the box [lo, hi] with cells of side L (centres lo + (i + ½) L strictly inside the box, in lattice
/// order: x outermost, the last axis innermost), subdivides them as in the file comment
/// (`Trigger::decide<D>(target(x), h)`, target(x) the target diameter L*, called at every cell's centre), and
/// keeps the particles for which `keep(x, h)` is true (e.g. the signed wall distance ≥ h/2). Cells are
/// subdivided before `keep` is asked, so a cell whose centre is too close to a wall can still leave its inner
/// particles. Refused: L or the box not positive and finite, a target that is not finite and > 0, more than
/// `max_generations` splits (a target far below L).
template <class Trigger = tanaka_thresholds, int D, class Target, class Keep>
graded_points<D> graded_lattice(const vec<D>& lo, const vec<D>& hi, double L, const Target& target,
                                const Keep& keep, int max_generations = 20) {
  static_assert(D == 2 || D == 3, "graded_lattice: D must be 2 or 3");
  static_assert(resolution::Trigger<Trigger>, "graded_lattice: Trigger must model resolution::Trigger");
  if (!(std::isfinite(L) && L > 0.0))
    fail("graded_lattice: the start spacing L is ", L, ": accepted range (0, inf)");
  if (!(lo.allFinite() && hi.allFinite() && (hi - lo).minCoeff() > 0.0))
    fail("graded_lattice: the box [(", lo.transpose(), "), (", hi.transpose(), ")] is empty or not finite");
  if (max_generations < 0 || max_generations > 60)
    fail("graded_lattice: max_generations is ", max_generations, ": accepted range [0, 60]");
  struct cell {
    vec<D> x;  // centre
    int k;     // a multiple of D: the cell's side is L/2^(k/D), its particle's volume L^D/2^k
  };
  const double LD = D == 2 ? L * L : L * L * L;
  const auto diameter = [&](int k) {
    const double V = std::ldexp(LD, -k);
    return D == 2 ? std::sqrt(V) : std::cbrt(V);
  };
  graded_points<D> out;
  const auto emit = [&](const vec<D>& x, int k) {
    const double h = diameter(k);
    if (!keep(x, h)) {
      out.dropped_volume += std::ldexp(LD, -k);
      return;
    }
    out.x.push_back(x);
    out.volume.push_back(std::ldexp(LD, -k));  // exact halving
    out.generation.push_back(k);
  };
  const auto asks_split = [&](const vec<D>& x, double Ls, int k) {
    if (Trigger::template decide<D>(Ls, diameter(k)) != want::split) return false;
    if (k >= max_generations)
      fail("graded_lattice: the particle at (", x.transpose(), ") still asks to split after ",
           max_generations, " generations (diameter ", diameter(k), ", target ", Ls, ")");
    return true;
  };
  // Sub-cell sign patterns s ∈ {±1}^D, as offsets (h/4) s: index r − 1 holds the 2^r particles after r splits
  // (r < D); `all` the 2^D sub-cells, in the order they are pushed (popped, and so emitted, in reverse).
  using pattern = std::vector<vec<D>>;
  std::vector<pattern> part;
  pattern all;
  if constexpr (D == 2) {
    part.push_back({vec<2>(-1.0, -1.0), vec<2>(1.0, 1.0)});
    all = {vec<2>(1.0, 1.0), vec<2>(-1.0, 1.0), vec<2>(1.0, -1.0),
           vec<2>(-1.0, -1.0)};  // popped lower-left ... upper-right
  } else {
    part.push_back({vec<3>(-1.0, -1.0, -1.0), vec<3>(1.0, 1.0, 1.0)});
    part.push_back(
        {vec<3>(-1.0, -1.0, 1.0), vec<3>(-1.0, 1.0, -1.0), vec<3>(1.0, -1.0, -1.0), vec<3>(1.0, 1.0, 1.0)});
    for (int c = 7; c >= 0; --c)
      all.push_back(vec<3>(c & 1 ? 1.0 : -1.0, c & 2 ? 1.0 : -1.0, c & 4 ? 1.0 : -1.0));
  }
  std::vector<cell> stack;
  const vec<D> ext = hi - lo;
  const auto n_cells = [&](int a) {
    long n = 0;
    while ((static_cast<double>(n) + 0.5) * L < ext[a]) ++n;
    return n;
  };
  const long nx = n_cells(0), ny = n_cells(1), nz = D == 3 ? n_cells(D - 1) : 1;
  for (long i = 0; i < nx; ++i)
    for (long j = 0; j < ny; ++j)
      for (long l = 0; l < nz; ++l) {
        vec<D> c0;
        c0[0] = (static_cast<double>(i) + 0.5) * L;
        c0[1] = (static_cast<double>(j) + 0.5) * L;
        if constexpr (D == 3) c0[2] = (static_cast<double>(l) + 0.5) * L;
        stack.push_back({lo + c0, 0});
        while (!stack.empty()) {
          const cell c = stack.back();
          stack.pop_back();
          const double Ls = target(c.x);
          if (!(std::isfinite(Ls) && Ls > 0.0))
            fail("graded_lattice: the target diameter is ", Ls, " at (", c.x.transpose(),
                 "): accepted range (0, inf)");
          if (!asks_split(c.x, Ls, c.k)) {
            emit(c.x, c.k);
            continue;
          }
          // a quarter of the cell's side (exact: a power of two)
          const double q = 0.25 * std::ldexp(L, -c.k / D);
          bool done = false;
          for (int r = 1; r < D && !done; ++r) {
            if (asks_split(c.x, Ls, c.k + r)) continue;
            for (const vec<D>& s : part[static_cast<std::size_t>(r - 1)]) emit(c.x + q * s, c.k + r);
            done = true;
          }
          if (done) continue;
          for (const vec<D>& s : all) stack.push_back({c.x + q * s, c.k + D});  // depth first
        }
      }
  return out;
}

}  // namespace mpskit::resolution
