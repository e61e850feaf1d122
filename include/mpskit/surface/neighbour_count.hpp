#pragma once
/// \file surface/neighbour_count.hpp
/// \brief Neighbour-count test (Tanaka & Masunaga 2010, as cited by Tanaka 2018 §4.6 and Tang & Wan,
/// seed 004 §2.5): i is on the free surface when N_i < β N0, N0 the neighbour count of an interior
/// particle of the reference lattice at the same radius.
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/kernel/reference_lattice.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/surface/concepts.hpp"
#include "mpskit/surface/detail/sweep.hpp"

namespace mpskit::surface {

/// Numbers of the neighbour-count test.
struct neighbour_count_params {
  /// β. The seeds cite the method without a value; 0.85 is mpskit's default (docs/surface.md): on the
  /// square lattice at 2.1 l0 it flags exactly the top row of a flat surface (8/12 = 0.67 < β < 11/12).
  double beta = 0.85;
  support_choice radius = support_choice::small;  ///< support in which neighbours are counted
  /// Throws mpskit::error listing every bad value.
  void validate() const {
    validator v("neighbour_count_params");
    v.require(beta > 0.0 && beta <= 1.0, "beta", mpskit::detail::concat("is ", beta, "; must be in (0, 1]"));
    v.throw_if_any();
  }
};

/// N_i < β N0.
class neighbour_count final {
 /// fields beyond the core: none (uses position, flags)
 public: using fields = field_list<>;
  using params_type = neighbour_count_params;
  /// Validates p.
  explicit neighbour_count(const params_type& p = {}) : p_(p) { p_.validate(); }
  const params_type& params() const { return p_; }  ///< the numbers

  /// N_i: participating neighbours j ≠ i with r_ij < re.
  template <ClassicSupports Op, class Participates = all_participate>
  double value(const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
               const Participates& participates, index_t i) const {
    index_t c = 0;
    nl.for_each_neighbour(x, i, detail::support_of(op, p_.radius),
                          [&](index_t j, const vec<Op::dim>&, double) {
                            if (participates(j)) ++c;
                          });
    return static_cast<double>(c);
  }
  /// N0: neighbours of an interior particle of the reference lattice at the chosen radius ratio.
  template <ClassicSupports Op>
  static double reference_count(const Op& op, support_choice c) {
    return kernel::reference_lattice<typename Op::kernel_type, Op::dim>(detail::ratio_of(op, c)).neighbours;
  }
  /// β N0.
  template <ClassicSupports Op>
  double threshold(const Op& op) const {
    return p_.beta * reference_count(op, p_.radius);
  }

  /// Sets flag::surface where candidate[i] != 0 and N_i < β N0, clears it on the other candidates;
  /// `values` (optional) receives N_i (NaN for non-candidates).
  template <Execution E, ClassicSupports Op, class Participates>
  void detect(E e, const points<Op::dim>& x, const search::neighbour_list<Op::dim>& nl, const Op& op,
              const Participates& participates, std::span<const std::uint8_t> candidate,
              std::vector<flag::type>& flags, Eigen::VectorXd* values = nullptr) const {
    detail::check_sizes("neighbour_count", x, nl, candidate, flags);
    const double t = threshold(op);
    detail::sweep(e, x.cols(), candidate, flags, values, [&](index_t i) {
      const double N = value(x, nl, op, participates, i);
      return detail::decision{N < t, N};
    });
  }

 private:
  params_type p_;
};

}  // namespace mpskit::surface
