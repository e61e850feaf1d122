#pragma once
/// \file regularize/fickian_shifting.hpp
/// \brief Fickian particle shifting (Lind et al. 2012) with the concentration gradient of Jandaghian &
/// Shakibaeinia (2020), as used by BMMR (seed 001 eqs. 9–12; bmmr.md §2.5):
///   C_i = Σ_j W_ij / n0                                              (eq. 12)
///   ⟨∇C⟩_i = d/n0 Σ_j (C_i + C_j)/|r_ij|² r_ij W_ij                  (eq. 11)
///   Δr_i = −A_F l0² C_r Ma ⟨∇C⟩_i for inner fluid, 0 for free-surface particles   (eq. 9)
///   Δr_i ← min(0.05 l0, |Δr_i|) Δr_i/|Δr_i|                          (eq. 10)
///
/// Readings (docs/regularize.md): W and n0 at the operator's small radius (2.1 l0, bmmr.md [AMBIG]);
/// the sums run over every participating neighbour (fluid, wall, dummy: "j ∈ Ω_i"); shifted are movable
/// particles without flag::surface (eq. 9: surface particles do not move at all, not only along the
/// normal) and without flag::isolated; velocities are not corrected (bmmr.md §2.5). C_r and Ma have no
/// value in the paper: defaults 0.2 and 0.1 are polymps' (bmmr.md [EXT]).
#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/regularize/concepts.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/concepts.hpp"

namespace mpskit::regularize {

/// Numbers of Fickian shifting (BMMR defaults, bmmr.md §2.13).
struct fickian_shifting_params {
  double a_f = 2.0;         ///< A_F (paper range [1, 6]; BMMR uses 2, after Skillen et al. 2013)
  double courant = 0.2;     ///< C_r (not given by the paper; polymps default, bmmr.md [EXT])
  double mach = 0.1;        ///< Ma (not given by the paper; polymps default, bmmr.md [EXT])
  double max_shift = 0.05;  ///< cap of |Δr_i| in l0 (eq. 10)
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("fickian_shifting_params");
    v.positive("a_f", a_f)
        .positive("courant", courant)
        .positive("mach", mach)
        .positive("max_shift", max_shift);
    v.throw_if_any();
  }
};

/// What one application did.
struct shift_report {
  index_t shifted = 0;             ///< particles eligible for shifting (movable, not surface/isolated)
  index_t capped = 0;              ///< shifts limited by eq. 10
  double max_shift_over_l0 = 0.0;  ///< max |Δr_i| / l0 after the cap
};

/// Fickian shifting of inner fluid particles, seed 001 eqs. 9–12.
class fickian_shifting final {
 /// fields beyond the core: none (uses position, flags)
 public: using fields = field_list<>;
  using params_type = fickian_shifting_params;
  /// Validates p.
  explicit fickian_shifting(const params_type& p = {}) : p_(p) { p_.validate(); }
  const params_type& params() const { return p_; }  ///< the numbers

  /// C_i = Σ_j W_ij / n0 (eq. 12) for every particle (C has n entries).
  template <Execution E, surface::ClassicSupports Op, class Participates>
  void concentration(E e, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
                     const Participates& participates, Eigen::VectorXd& C) const {
    using K = typename Op::kernel_type;
    const double re = op.re_small(), inv_n0 = 1.0 / op.n0_small();
    C.resize(x.cols());
    for_each_particle(e, x.cols(), [&](index_t i) {
      double s = 0.0;
      nl.for_each_neighbour(x, i, op.small_support(), [&](index_t j, const vec<Op::dim>&, double r2) {
        if (participates(j)) s += K::w(std::sqrt(r2), re);
      });
      C[i] = s * inv_n0;
    });
  }

  /// Δr (D × n) without moving anything; zero for particles that are not shifted.
  template <Execution E, surface::ClassicSupports Op, class Participates, class Movable>
  shift_report displacement(E e, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl,
                            const Op& op, const Participates& participates, const Movable& movable,
                            std::span<const flag::type> flags, points<Op::dim>& dr) const {
    constexpr int D = Op::dim;
    using K = typename Op::kernel_type;
    const index_t n = x.cols();
    if (nl.rows() != n)
      fail("fickian_shifting: the neighbour list has ", nl.rows(), " rows for ", n, " particles");
    if (static_cast<index_t>(flags.size()) != n)
      fail("fickian_shifting: flags has ", flags.size(), " entries for ", n, " particles");
    const double l0 = op.params().l0, re = op.re_small(), n0 = op.n0_small();
    const double diff = p_.a_f * l0 * l0 * p_.courant * p_.mach;  // A_F l0² C_r Ma (eq. 9)
    const double cap = p_.max_shift * l0;                         // eq. 10
    Eigen::VectorXd C;
    concentration(e, x, nl, op, participates, C);
    dr.setZero(D, n);
    std::vector<std::uint8_t> eligible(static_cast<std::size_t>(n), 0),
        capped(static_cast<std::size_t>(n), 0);
    for_each_particle(e, n, [&](index_t i) {
      const std::size_t k = static_cast<std::size_t>(i);
      if (!movable(i) || (flags[k] & (flag::surface | flag::isolated))) return;  // eq. 9: Δr = 0 on 𝔽
      eligible[k] = 1;
      vec<D> g = vec<D>::Zero();
      nl.for_each_neighbour(x, i, op.small_support(), [&](index_t j, const vec<D>& d, double r2) {
        if (participates(j)) g += ((C[i] + C[j]) * K::w(std::sqrt(r2), re) / r2) * d;  // eq. 11
      });
      vec<D> s = (-diff * double(D) / n0) * g;  // eq. 9 with eq. 11's d/n0
      const double len = s.norm();
      if (len > cap) {  // eq. 10
        s *= cap / len;
        capped[k] = 1;
      }
      dr.col(i) = s;
    });
    shift_report rep;
    const auto add = [](index_t a, index_t b) { return a + b; };
    rep.shifted = reduce(
        e, n, index_t{0}, [&](index_t i) { return index_t{eligible[static_cast<std::size_t>(i)]}; }, add);
    rep.capped = reduce(
        e, n, index_t{0}, [&](index_t i) { return index_t{capped[static_cast<std::size_t>(i)]}; }, add);
    const double max_shift = reduce(
        e, n, 0.0, [&](index_t i) { return dr.col(i).norm(); },
        [](double a, double b) { return std::max(a, b); });
    rep.max_shift_over_l0 = max_shift / l0;
    return rep;
  }

  /// x ← x + Δr (seed 001 eq. 19: r' = r^t + Δr^t); returns the report (max |Δr| / l0).
  template <Execution E, surface::ClassicSupports Op, class Participates, class Movable>
  shift_report apply(E e, points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
                     const Participates& participates, const Movable& movable,
                     std::span<const flag::type> flags) const {
    points<Op::dim> dr;
    const shift_report rep = displacement(e, x, nl, op, participates, movable, flags, dr);
    for_each_particle(e, x.cols(), [&](index_t i) { x.col(i) += dr.col(i); });
    return rep;
  }

 private:
  params_type p_;
};

}  // namespace mpskit::regularize
