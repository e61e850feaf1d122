#pragma once
/// \file surface/pnd_threshold.hpp
/// \brief Particle-number-density threshold (Tanaka 2018 eq. 20, the traditional MPS test of Koshizuka &
/// Oka 1996): i is on the free surface when n_i < α_d n0.
#include <Eigen/Core>
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

/// Numbers of the PND threshold.
struct pnd_threshold_params {
  double alpha_d = 0.97;                          ///< α_d (Tanaka 2018 parameter table: 0.97)
  support_choice radius = support_choice::small;  ///< support of n_i and n0 (classic MPS: the PND radius)
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("pnd_threshold_params");
    v.require(alpha_d > 0.0 && alpha_d <= 1.0, "alpha_d",
              mpskit::detail::concat("is ", alpha_d, "; must be in (0, 1]"));
    v.throw_if_any();
  }
};

/// n_i < α_d n0 (Tanaka 2018 eq. 20; n0 of the chosen support, op::mps).
class pnd_threshold final {
 /// fields beyond the core: none (uses position, flags)
 public: using fields = field_list<>;
  using params_type = pnd_threshold_params;
  /// Validates p.
  explicit pnd_threshold(const params_type& p = {}) : p_(p) { p_.validate(); }
  const params_type& params() const { return p_; }  ///< the numbers

  /// n_i = Σ_{j≠i} w(r_ij, re) over participating neighbours (Tanaka 2018 eq. 8).
  template <ClassicSupports Op, class Participates = all_participate>
  double value(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
               const Participates& participates, index_t i) const {
    double n = 0.0;
    detail::for_each_weighted(x, nl, op, p_.radius, participates, i,
                              [&](index_t, const vec<Op::dim>&, double, double w) { n += w; });
    return n;
  }
  /// α_d n0.
  template <ClassicSupports Op>
  double threshold(const Op& op) const {
    return p_.alpha_d * detail::n0_of(op, p_.radius);
  }

  /// Sets flag::surface where candidate[i] != 0 and n_i < α_d n0, clears it on the other candidates;
  /// `values` (optional) receives n_i (NaN for non-candidates).
  template <Execution E, ClassicSupports Op, class Participates>
  void detect(E e, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
              const Participates& participates, std::span<const std::uint8_t> candidate,
              std::vector<flag::type>& flags, Eigen::VectorXd* values = nullptr) const {
    detail::check_sizes("pnd_threshold", x, nl, candidate, flags);
    const double t = threshold(op);
    detail::sweep(e, x.cols(), candidate, flags, values, [&](index_t i) {
      const double n = value(x, nl, op, participates, i);
      return detail::decision{n < t, n};  // Tanaka 2018 eq. 20
    });
  }

 private:
  params_type p_;
};

}  // namespace mpskit::surface
