#pragma once
/// \file ppe/sources.hpp
/// \brief PPE source terms as policies. Every source gives b_i in
///   ∇²p_i − (ρ α_c / Δt²) p_i = b_i,
/// where α_c (m s² kg⁻¹) is the restricted / artificial compressibility, a parameter of the scheme
/// (Tanaka 2018 eq. 24 written as p/(ρ s²) ⇔ BMMR's α_c = 1/(ρ s²): one parameter, both spellings).
/// Notation: n0 the reference number density, n′ the one at the temporary positions x + Δt u′
/// (Tanaka writes n* for the reference and n^{k′} for the temporary; BMMR writes n** for the temporary).
#include "mpskit/core/params.hpp"
#include "mpskit/ppe/concepts.hpp"

namespace mpskit::ppe {

/// PND condition with relaxation (Tanaka 2018 eqs. 18 and 23): b = ρ α_p/Δt² (n0 − n′)/n0.
struct pnd final {
  static constexpr bool needs_divergence = false;
  static constexpr bool needs_current_density = false;
  double alpha_p = 1.0;  ///< relaxation α_p (eq. 23; 1 gives eq. 18)
  void validate() const { validator("ppe::pnd").in_range("alpha_p", alpha_p, 0.0, 1.0).throw_if_any(); }
  double rhs(const source_inputs& in) const {
    return in.rho * alpha_p / (in.dt * in.dt) * (in.n0 - in.n_temporary) / in.n0;
  }
};

/// Divergence-free condition (Tanaka 2018 eq. 19): b = ρ/Δt ∇·u′.
struct divergence final {
  static constexpr bool needs_divergence = true;
  static constexpr bool needs_current_density = false;
  void validate() const {}
  double rhs(const source_inputs& in) const { return in.rho / in.dt * in.divergence; }
};

/// Mixed DF + PND (Tanaka & Masunaga 2010; Tanaka 2018 eq. 25):
/// b = ρ/Δt ∇·u′ + ρ α_p/Δt² (n0 − n′)/n0.
struct mixed final {
  static constexpr bool needs_divergence = true;
  static constexpr bool needs_current_density = false;
  double alpha_p = 0.01;  ///< PND weight α_p (Tanaka & Masunaga use small values, e.g. 0.01)
  void validate() const { validator("ppe::mixed").in_range("alpha_p", alpha_p, 0.0, 1.0).throw_if_any(); }
  double rhs(const source_inputs& in) const {
    return in.rho / in.dt * in.divergence +
           in.rho * alpha_p / (in.dt * in.dt) * (in.n0 - in.n_temporary) / in.n0;
  }
};

/// Mixed source in the weighting of Tang & Wan (seed 004 eq. 9), with n at the step start x^k:
/// b = (1 − γ) ρ/Δt ∇·u* − γ ρ/Δt² (n^k − n0)/n0.
struct mixed_tang_wan final {
  static constexpr bool needs_divergence = true;
  static constexpr bool needs_current_density = true;
  double gamma = 0.01;  ///< γ (0.01 for uniform resolution in seed 004)
  void validate() const {
    validator("ppe::mixed_tang_wan").in_range("gamma", gamma, 0.0, 1.0).throw_if_any();
  }
  double rhs(const source_inputs& in) const {
    return (1.0 - gamma) * in.rho / in.dt * in.divergence -
           gamma * in.rho / (in.dt * in.dt) * (in.n_current - in.n0) / in.n0;
  }
};

/// TCPI source (Cheng et al. 2021 as used by BMMR, bmmr.md §2.10 eq. 25–26 [RECON]): the mixed source
/// with the time scale Δt replaced by l0/c_s:
/// b = c_s² ρ/l0² (n0 − n′)/n0 + c_s ρ/l0 ∇·u′.
struct tcpi final {
  static constexpr bool needs_divergence = true;
  static constexpr bool needs_current_density = false;
  double c_s = 2.0;  ///< artificial sound speed (m/s); BMMR uses 2.0 in all cases
  void validate() const { validator("ppe::tcpi").positive("c_s", c_s).throw_if_any(); }
  double rhs(const source_inputs& in) const {
    return c_s * c_s * in.rho / (in.l0 * in.l0) * (in.n0 - in.n_temporary) / in.n0 +
           c_s * in.rho / in.l0 * in.divergence;
  }
};

static_assert(SourceTerm<pnd> && SourceTerm<divergence> && SourceTerm<mixed> && SourceTerm<mixed_tang_wan> &&
              SourceTerm<tcpi>);

}  // namespace mpskit::ppe
