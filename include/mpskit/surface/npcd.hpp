#pragma once
/// \file surface/npcd.hpp
/// \brief Neighbourhood-particles centroid deviation (NPCD, Tsukamoto et al. 2016) as used by BMMR
/// (seed 001 eqs. 14–16; bmmr.md §2.7): a rough PND pass n_i < β_F n0 picks candidates, and a candidate
/// is on the free surface when σ_i > ϱ_F l0 **or** N_i ≤ 4.
///
/// Readings (docs/surface.md): the extraction prints "and" in eq. 15; read literally a particle of a flat
/// surface (17 neighbours within 3.1 l0) could never be a surface particle, so mpskit reads "or"
/// (bmmr.md §2.7 [RECON/INCONS], as polymps). Radii (not stated by the paper, bmmr.md [EXT]): W and n_i
/// at the small radius (2.1 l0), N_i counted within the large radius (3.1 l0).
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/concepts.hpp"
#include "mpskit/surface/detail/sweep.hpp"

namespace mpskit::surface {

/// Numbers of NPCD (BMMR defaults, bmmr.md §2.13).
struct npcd_params {
  double beta_f = 0.93;    ///< β_F of the rough pass n_i < β_F n0 (paper range [0.8, 1))
  double rho_f = 0.25;     ///< ϱ_F of σ_i > ϱ_F l0 (paper range [0.2, ∞))
  int max_neighbours = 4;  ///< a candidate with N_i ≤ this many neighbours is a surface particle
  support_choice weight_radius = support_choice::small;  ///< support of W_ij in n_i and σ_i (2.1 l0)
  support_choice count_radius = support_choice::large;   ///< support in which N_i is counted (3.1 l0)
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("npcd_params");
    v.require(beta_f > 0.0 && beta_f <= 1.0, "beta_f",
              mpskit::detail::concat("is ", beta_f, "; must be in (0, 1]"));
    v.positive("rho_f", rho_f);
    v.require(max_neighbours >= 0, "max_neighbours",
              mpskit::detail::concat("is ", max_neighbours, "; must be an integer >= 0"));
    v.throw_if_any();
  }
};

/// The three NPCD quantities of one particle.
struct npcd_measure {
  double n = 0.0;      ///< n_i = Σ W_ij at the weight radius
  double sigma = 0.0;  ///< σ_i = |Σ W_ij x_ij| / Σ W_ij (m); 0 when Σ W_ij = 0 (no neighbour)
  index_t count = 0;   ///< N_i within the count radius
};

/// NPCD free-surface detection (seed 001 eqs. 14–16, "or" reading).
class npcd final {
 /// fields beyond the core: none (uses position, flags)
 public: using fields = field_list<>;
  using params_type = npcd_params;
  /// Validates p.
  explicit npcd(const params_type& p = {}) : p_(p) { p_.validate(); }
  const params_type& params() const { return p_; }  ///< the numbers

  /// n_i, σ_i (seed 001 eq. 16, with x, y, z: bmmr.md [RECON]) and N_i of particle i.
  template <ClassicSupports Op, class Participates = all_participate>
  npcd_measure measure(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
                       const Participates& participates, index_t i) const {
    npcd_measure m;
    vec<Op::dim> s = vec<Op::dim>::Zero();
    detail::for_each_weighted(x, nl, op, p_.weight_radius, participates, i,
                              [&](index_t, const vec<Op::dim>& d, double, double w) {
                                m.n += w;
                                s += w * d;  // Σ W_ij (x_j − x_i), eq. 16 numerator
                              });
    m.sigma = m.n > 0.0 ? s.norm() / m.n : 0.0;
    nl.for_each_neighbour(x, i, detail::support_of(op, p_.count_radius),
                          [&](index_t j, const vec<Op::dim>&, double) {
                            if (participates(j)) ++m.count;
                          });
    return m;
  }
  /// σ_i (m), the deviation compared with ϱ_F l0.
  template <ClassicSupports Op, class Participates = all_participate>
  double value(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
               const Participates& participates, index_t i) const {
    return measure(x, nl, op, participates, i).sigma;
  }
  /// ϱ_F l0 (m).
  template <ClassicSupports Op>
  double threshold(const Op& op) const {
    return p_.rho_f * op.params().l0;
  }
  /// β_F n0 of the rough pass.
  template <ClassicSupports Op>
  double rough_threshold(const Op& op) const {
    return p_.beta_f * detail::n0_of(op, p_.weight_radius);
  }
  /// The decision on one measure: n_i < β_F n0 (eq. 14) and (σ_i > ϱ_F l0 or N_i ≤ max_neighbours) (eq. 15).
  template <ClassicSupports Op>
  bool is_surface(const npcd_measure& m, const Op& op) const {
    if (!(m.n < rough_threshold(op))) return false;                  // eq. 14: inner
    return m.sigma > threshold(op) || m.count <= p_.max_neighbours;  // eq. 15, "or" reading
  }

  /// Sets flag::surface on candidates that pass both passes, clears it on the other candidates;
  /// `values` (optional) receives σ_i (NaN for non-candidates).
  template <Execution E, ClassicSupports Op, class Participates>
  void detect(E e, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
              const Participates& participates, std::span<const std::uint8_t> candidate,
              std::vector<flag::type>& flags, Eigen::VectorXd* values = nullptr) const {
    detail::check_sizes("npcd", x, nl, candidate, flags);
    detail::sweep(e, x.cols(), candidate, flags, values, [&](index_t i) {
      const npcd_measure m = measure(x, nl, op, participates, i);
      return detail::decision{is_surface(m, op), m.sigma};
    });
  }

 private:
  params_type p_;
};

}  // namespace mpskit::surface
