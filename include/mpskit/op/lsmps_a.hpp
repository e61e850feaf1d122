#pragma once
/// \file op/lsmps_a.hpp
/// \brief LSMPS type A: derivatives at particles (Tanaka 2018 eqs. 41–46; Tamai & Koshizuka 2014), orders
/// 1–3 in 2D and 3D, with the Neumann-constrained variant (Tanaka eqs. 85–87).
///
/// Per particle i: M_i = Σ_j w_ij p(x_ij/L_i) p(x_ij/L_i)ᵀ (eq. 44) is factorised once by `compute` and
/// stored as M_i⁻¹ (the per-particle factor; 2D order 2: 25 doubles). Row weights are generated on demand,
/// c_ij = H_i M_i⁻¹ w_ij p(x_ij/L_i) with H_i = diag(α!/L_i^|α|) (eq. 41, 43 read with L^−|α|), so
/// ⟨D_x φ⟩_i = Σ_j c_ij (φ_j − φ_i) (+ the Neumann term); application and assembly share this one path.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/op/detail/lsmps_basis.hpp"
#include "mpskit/op/lsmps_params.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"

namespace mpskit::op {

/// \brief The Neumann constraint as a row-contribution hook (Tanaka eq. 87): on a constrained particle adds
/// selᵀ H_i (M_i + N_i)⁻¹ w(0) q_i · (−L_i ∂φ/∂n|_i) to the row's constant (a right-hand side in a PPE).
struct neumann_rows final {
  const Eigen::VectorXd* dfdn = nullptr;  ///< ∂φ/∂n per particle (read on constrained particles only)
  /// hook(i, row, builder) (op/concepts.hpp RowContribution).
  template <class Row, class B>
  void operator()(index_t i, const Row& row, B& b) const {
    if (row.constrained) b.add_constant(row.weight(row.neumann_vector()) * (-row.L * (*dfdn)[i]));
  }
};

/// \brief LSMPS type A of order Order (1–3) with kernel K (Tanaka eq. 29 by default).
/// Precondition of every stencil/application call: the x, list, sizes and filter of the last `compute`.
template <int D, int Order, Kernel K = kernel::quadratic>
requires Dimension<D> &&(Order >= 1 && Order <= 3) class lsmps_a final {
 public:
  using basis = detail::lsmps_basis<D, Order>;
  static constexpr int dim = D;                   ///< spatial dimension
  static constexpr int order = Order;             ///< polynomial order
  static constexpr int basis_size = basis::size;  ///< m = 2/5/9 (2D), 3/9/19 (3D)
  using kernel_type = K;
  using vector = Eigen::Matrix<double, basis_size, 1>;           ///< a row over D_x (eq. 42 order)
  using matrix = Eigen::Matrix<double, basis_size, basis_size>;  ///< a moment matrix or its inverse

  /// Row view handed to a row-contribution hook (op/concepts.hpp).
  struct row_view {
    vector lhat;               ///< selᵀ H_i M_i⁻¹: the row's functional over weighted basis vectors
    vector neumann;            ///< w(0) q_i of the Neumann constraint (zero when i is unconstrained)
    double L = 0.0;            ///< L_i
    bool constrained = false;  ///< i carries the Neumann constraint
    /// Weight the row gives a virtual neighbour whose weighted basis vector is v (w p(x/L_i)).
    double weight(const vector& v) const { return lhat.dot(v); }
    /// w(0) q_i (Tanaka eq. 86–87's vector).
    const vector& neumann_vector() const { return neumann; }
  };

  explicit lsmps_a(const lsmps_params& p = {}) : p_(p) { p_.validate(); }

  const lsmps_params& params() const { return p_; }  ///< the numbers

  /// Precompute (moments + inverse, degenerate test and fallback) for every column of x.
  template <Execution E, SizeModel S, class Filter = all_neighbours>
  void compute(E e, const points<D>& x, const search::neighbour_list<D>& nl, const S& size,
               const Filter& filter = {}) {
    np_ = {};
    compute_impl(e, x, nl, size, nullptr, filter);
  }

  /// Precompute with the Neumann constraint on the particles marked in `nc` (Tanaka eqs. 85–86:
  /// M_i + N_i, N_i = w(0) q q ᵀ). Requires a kernel finite at zero.
  template <Execution E, SizeModel S, class Filter = all_neighbours>
  void compute(E e, const points<D>& x, const search::neighbour_list<D>& nl, const S& size,
               const neumann_constraint<D>& nc, const Filter& filter = {}) {
    static_assert(
        K::finite_at_zero,
        "mpskit: the Neumann-constrained LSMPS needs w(0) (Tanaka eq. 86): use a kernel finite at zero");
    if (!nc.normal || !nc.constrained)
      fail("lsmps_a: neumann_constraint needs both `normal` and `constrained`");
    if (nc.normal->cols() != x.cols() || static_cast<index_t>(nc.constrained->size()) != x.cols())
      fail("lsmps_a: neumann_constraint arrays have ", nc.normal->cols(), " normals and ",
           nc.constrained->size(), " marks for ", x.cols(), " particles");
    compute_impl(e, x, nl, size, &nc, filter);
  }

  /// Precompute with Neumann points: every marked neighbour j enters the fits of its neighbours as the
  /// equation n_j·∇φ(x_j) = q_j (weighted like a value neighbour) instead of a value φ_j. Only the scalar
  /// row, gradient and derivative calls accept such an operator (the data q_j are read through np.dfdn).
  template <Execution E, SizeModel S, class Filter = all_neighbours>
  void compute(E e, const points<D>& x, const search::neighbour_list<D>& nl, const S& size,
               const neumann_points<D>& np, const Filter& filter = {}) {
    if (!np.normal || !np.mark || !np.dfdn) fail("lsmps_a: neumann_points needs `normal`, `mark` and `dfdn`");
    if (np.normal->cols() != x.cols() || static_cast<index_t>(np.mark->size()) != x.cols())
      fail("lsmps_a: neumann_points arrays have ", np.normal->cols(), " normals and ", np.mark->size(),
           " marks for ", x.cols(), " particles");
    np_ = np;
    compute_impl(e, x, nl, size, nullptr, filter);
  }

  index_t size() const { return n_; }                              ///< particles of the last compute
  const std::vector<flag::type>& flags() const { return flags_; }  ///< flag::degenerate per particle
  /// Exact order achieved at i: Order, a lower order (fallback), or 0 (regularised or isolated).
  int order_used(index_t i) const { return order_[static_cast<std::size_t>(i)]; }
  /// cond₁ = ‖M‖₁‖M⁻¹‖₁ of the moment block used at i (after a fallback: of the lower-order block; when
  /// regularised: ‖M‖₁‖(M + δI)⁻¹‖₁; 0 for a zero factor).
  double condition(index_t i) const { return cond_[static_cast<std::size_t>(i)]; }
  /// Particles flagged degenerate by the last compute.
  index_t degenerate_count() const {
    index_t c = 0;
    for (flag::type f : flags_) c += (f & flag::degenerate) != 0;
    return c;
  }
  /// M_i⁻¹ (or (M_i + N_i)⁻¹; zero-padded beyond a fallback order).
  Eigen::Map<const matrix> inverse_moments(index_t i) const {
    return Eigen::Map<const matrix>(factors_.data() + static_cast<std::size_t>(i) * msq);
  }
  double diameter(index_t i) const { return L_ ? (*L_)[i] : l_; }   ///< L_i
  double re(index_t i) const { return p_.re_ratio * diameter(i); }  ///< R_i = re_ratio · L_i

  /// M_i recomputed (eq. 44, + N_i when constrained; full symmetric) — a diagnostic, not the stored factor.
  template <class Filter = all_neighbours>
  matrix moments(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                 const Filter& filter = {}) const {
    matrix M = moment_lower(x, nl, i, filter);
    return M.template selfadjointView<Eigen::Lower>();
  }

  static vector gradient_selector(int a) { return basis::gradient_selector(a); }  ///< ∂/∂x_a
  static vector laplacian_selector() { return basis::laplacian_selector(); }      ///< ∇²
  static vector directional_selector(const vec<D>& n) { return basis::directional_selector(n); }  ///< n·∇
  /// Index of ∂^α in D_x (e.g. derivative_index(1, 1) = ∂²/∂x∂y); −1 if beyond the order.
  static constexpr int derivative_index(int ax, int ay, int az = 0) { return basis::index_of(ax, ay, az); }

  /// Calls f(j, c_ij) with c_ij ∈ R^m, ⟨D_x φ⟩_i = Σ_j c_ij (φ_j − φ_i) (eq. 41 as a stencil).
  template <class Filter, class F>
  void for_each_row_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                           const Filter& filter, F&& f) const {
    no_points("stencil weights");
    const vector h = basis::h_diag(diameter(i));
    const matrix A = h.asDiagonal() * inverse_moments(i);
    vector pv;
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      basis::eval(s, pv);
      f(j, vector(A * (w * pv)));
    });
  }

  /// Calls f(j, a_ij) for the combination `sel` of D_x (e.g. laplacian_selector()).
  template <class Filter, class F>
  void for_each_row_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                           const vector& sel, const Filter& filter, F&& f) const {
    no_points("stencil weights");
    const vector lhat = functional(i, sel);
    vector pv;
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      basis::eval(s, pv);
      f(j, w * lhat.dot(pv));
    });
  }

  /// Gradient stencil (GradientStencil): f(j, c_ij), ⟨∇φ⟩_i = Σ c_ij (φ_j − φ_i).
  template <class Filter, class F>
  void for_each_gradient_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                const Filter& filter, F&& f) const {
    no_points("stencil weights");
    const double Linv = 1.0 / diameter(i);
    const Eigen::Matrix<double, D, basis_size> G = Linv * inverse_moments(i).template topRows<D>();
    vector pv;
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      basis::eval(s, pv);
      f(j, vec<D>(G * (w * pv)));
    });
  }

  /// Laplacian stencil (LaplacianStencil): f(j, a_ij), ⟨∇²φ⟩_i = Σ a_ij (φ_j − φ_i); zero rows at order 1.
  template <class Filter, class F>
  void for_each_laplacian_weight(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                                 const Filter& filter, F&& f) const {
    for_each_row_weight(x, nl, i, laplacian_selector(), filter, std::forward<F>(f));
  }

  /// Emits row i of the combination `sel` into a RowBuilder, then calls hook(i, row_view, builder).
  template <class Filter, class B, class Hook = no_contribution>
  requires RowBuilder<B>
  void build_row(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const vector& sel,
                 const Filter& filter, B& builder, const Hook& hook = {}) const {
    row_view rv = view(i, sel);
    double diag = 0.0;
    vector pv;
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      if (is_point(j)) {  // a Neumann point: its known datum L_i q_j goes to the row's constant
        basis::eval_directional(s, np_.normal->col(j), pv);
        builder.add_constant(w * rv.lhat.dot(pv) * rv.L * (*np_.dfdn)[j]);
        return;
      }
      basis::eval(s, pv);
      const double a = w * rv.lhat.dot(pv);
      builder.add(j, a);
      diag -= a;
    });
    builder.add_diagonal(diag);
    hook(i, rv, builder);
  }

  /// The row view of row i for the combination sel (what a hook receives).
  row_view view(index_t i, const vector& sel) const {
    row_view rv;
    rv.lhat = functional(i, sel);
    rv.L = diameter(i);
    rv.constrained = is_constrained(i);
    rv.neumann = rv.constrained ? neumann_vector(i) : vector::Zero().eval();
    return rv;
  }

  /// All derivatives ⟨D_x φ⟩_i (eq. 41); with `dfdn`, constrained particles add the Neumann term c_i
  /// (eq. 87).
  template <class Filter = all_neighbours>
  vector derivatives(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                     const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {},
                     const Eigen::VectorXd* dfdn = nullptr) const {
    vector b = moment_vector(x, nl, i, phi, filter);  // eq. 45
    if (dfdn && is_constrained(i)) b += neumann_vector(i) * (-diameter(i) * (*dfdn)[i]);
    return basis::h_diag(diameter(i)).cwiseProduct(inverse_moments(i) * b);
  }

  /// ⟨∇φ⟩_i.
  template <class Filter = all_neighbours>
  vec<D> gradient(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                  const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {}) const {
    const vector b = moment_vector(x, nl, i, phi, filter);
    return vec<D>((inverse_moments(i).template topRows<D>() * b) / diameter(i));
  }

  /// ⟨∇²φ⟩_i (zero at order 1).
  template <class Filter = all_neighbours>
  double laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                   const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter = {}) const {
    return functional(i, laplacian_selector()).dot(moment_vector(x, nl, i, phi, filter));
  }

  /// ⟨∇φ_a⟩_i of D fields as the rows of one matrix (∇u for u's components), from one neighbour sweep
  /// (moment_vectors): row a is gradient(x, nl, i, phi[a], filter) to the bit.
  template <class Filter = all_neighbours>
  mat<D> gradients(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                   const std::array<Eigen::VectorXd, D>& phi, const Filter& filter = {}) const {
    const Eigen::Matrix<double, basis_size, D> B = moment_vectors(x, nl, i, phi, filter);
    mat<D> G;
    for (int a = 0; a < D; ++a) {
      const vector b = B.col(a);
      G.row(a) = vec<D>((inverse_moments(i).template topRows<D>() * b) / diameter(i)).transpose();
    }
    return G;
  }

  /// ⟨∇²φ_a⟩_i of D fields from one neighbour sweep: entry a is laplacian(x, nl, i, phi[a], filter) to the
  /// bit.
  template <class Filter = all_neighbours>
  vec<D> laplacians(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                    const std::array<Eigen::VectorXd, D>& phi, const Filter& filter = {}) const {
    const Eigen::Matrix<double, basis_size, D> B = moment_vectors(x, nl, i, phi, filter);
    const vector f = functional(i, laplacian_selector());
    vec<D> l;
    for (int a = 0; a < D; ++a) {
      const vector b = B.col(a);
      l[a] = f.dot(b);
    }
    return l;
  }

  /// ⟨∇²φ⟩_i for an Eigen::VectorXd (exact match: a VectorXd also converts to points<D>).
  template <class Filter = all_neighbours>
  double laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                   const Eigen::VectorXd& phi, const Filter& filter = {}) const {
    return laplacian(x, nl, i, Eigen::Ref<const Eigen::VectorXd>(phi), filter);
  }

  /// ⟨∇φ⟩_i and ⟨∇²φ⟩_i from one neighbour sweep (the projection step's pair).
  template <class Filter = all_neighbours>
  std::pair<vec<D>, double> gradient_laplacian(const points<D>& x, const search::neighbour_list<D>& nl,
                                               index_t i, const Eigen::Ref<const Eigen::VectorXd>& phi,
                                               const Filter& filter = {}) const {
    const vector b = moment_vector(x, nl, i, phi, filter);
    const Eigen::Map<const matrix> Mi = inverse_moments(i);
    const vec<D> g = (Mi.template topRows<D>() * b) / diameter(i);
    double lap = 0.0;
    if constexpr (Order >= 2) {
      const double L2inv = 2.0 / (diameter(i) * diameter(i));  // α! / L² for α = 2 e_a
      for (int a = 0; a < D; ++a) lap += L2inv * Mi.row(second_index(a)).dot(b);
    }
    return {g, lap};
  }

  /// ⟨∇·u⟩_i = Σ_a ⟨∂u_a/∂x_a⟩_i.
  template <class Filter = all_neighbours>
  double divergence(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const points<D>& u,
                    const Filter& filter = {}) const {
    no_points("divergence");
    const Eigen::Matrix<double, basis_size, D> B = moment_matrix(x, nl, i, u, filter);
    const Eigen::Map<const matrix> Mi = inverse_moments(i);
    double s = 0.0;
    for (int a = 0; a < D; ++a) s += Mi.row(a).dot(B.col(a));
    return s / diameter(i);
  }

  /// ⟨∇²u⟩_i of a vector field, component-wise (the viscous term).
  template <class Filter = all_neighbours>
  vec<D> laplacian(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const points<D>& u,
                   const Filter& filter = {}) const {
    no_points("vector laplacian");
    const Eigen::Matrix<double, basis_size, D> B = moment_matrix(x, nl, i, u, filter);
    return vec<D>((functional(i, laplacian_selector()).transpose() * B).transpose());
  }

 private:
  static constexpr std::size_t msq = static_cast<std::size_t>(basis_size) * basis_size;

  /// Index in D_x of ∂²/∂x_a².
  static constexpr int second_index(int a) {
    return a == 0 ? basis::index_of(2, 0, 0) : a == 1 ? basis::index_of(0, 2, 0) : basis::index_of(0, 0, 2);
  }

  /// selᵀ H_i M_i⁻¹.
  vector functional(index_t i, const vector& sel) const {
    const vector hs = sel.cwiseProduct(basis::h_diag(diameter(i)));
    return inverse_moments(i).transpose() * hs;
  }

  bool is_point(index_t j) const { return np_.mark && (*np_.mark)[static_cast<std::size_t>(j)] != 0; }
  void no_points(const char* what) const {
    if (np_.mark) fail("lsmps_a: ", what, " of an operator computed with Neumann points is not defined");
  }

  bool is_constrained(index_t i) const { return nc_normal_ && (*nc_mark_)[static_cast<std::size_t>(i)] != 0; }

  /// w(0) q_i: the constraint row (Tanaka eqs. 86–87; `derivative` reading: linear entries of p(−n)).
  vector neumann_vector(index_t i) const {
    vector q;
    const vec<D> mn = -nc_normal_->col(i);
    basis::eval(mn, q);
    if (nc_form_ == neumann_form::derivative) q.template tail<basis_size - D>().setZero();
    return K::w(0.0, re(i)) * q;
  }

  /// Calls f(j, w_ij, x_ij / L_i) for accepted neighbours with w_ij > 0 (Tanaka eqs. 28–29 radius).
  template <class Filter, class F>
  void sweep(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const Filter& filter,
             F&& f) const {
    if (!L_) {
      const double R = p_.re_ratio * l_, Linv = 1.0 / l_;
      nl.for_each_neighbour(x, i, search::support<search::uniform_radius>{{R}, p_.rule},
                            [&](index_t j, const vec<D>& d, double r2) {
                              if (!filter(j)) return;
                              const double w = K::w(std::sqrt(r2), R);
                              if (w != 0.0) f(j, w, vec<D>(d * Linv));
                            });
    } else {
      const double Li = (*L_)[i], Linv = 1.0 / Li, Ri = p_.re_ratio * Li;
      nl.for_each_neighbour(x, i, search::support<search::per_particle_radius>{{L_, p_.re_ratio}, p_.rule},
                            [&](index_t j, const vec<D>& d, double r2) {
                              if (!filter(j)) return;
                              const double Rij =
                                  std::sqrt(search::pair_radius2(p_.rule, Ri, p_.re_ratio * (*L_)[j]));
                              const double w = K::w(std::sqrt(r2), Rij);
                              if (w != 0.0) f(j, w, vec<D>(d * Linv));
                            });
    }
  }

  /// b_i = Σ_j w_ij p(x_ij/L_i) (φ_j − φ_i) (eq. 45).
  template <class Filter>
  vector moment_vector(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                       const Eigen::Ref<const Eigen::VectorXd>& phi, const Filter& filter) const {
    vector b = vector::Zero(), pv;
    const double phii = phi[i];
    const double Li = diameter(i);
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      if (is_point(j)) {
        basis::eval_directional(s, np_.normal->col(j), pv);
        b += (w * Li * (*np_.dfdn)[j]) * pv;
        return;
      }
      basis::eval(s, pv);
      b += (w * (phi[j] - phii)) * pv;
    });
    return b;
  }

  /// Eq. 45 for D fields in one sweep: column a is moment_vector(x, nl, i, phi[a], filter), the same terms
  /// added in the same order (so the same to the bit).
  template <class Filter>
  Eigen::Matrix<double, basis_size, D> moment_vectors(const points<D>& x, const search::neighbour_list<D>& nl,
                                                      index_t i, const std::array<Eigen::VectorXd, D>& phi,
                                                      const Filter& filter) const {
    return moment_columns(x, nl, i, filter,
                          [&](int a, index_t j) { return phi[static_cast<std::size_t>(a)][j]; });
  }

  /// Eq. 45 for the D columns value(a, ·), a < D, in one sweep: column a gets w_ij (value(a, j) − value(a,
  /// i)) p(x_ij/L_i), and a Neumann point j adds w_ij L_i (∂φ/∂n)_j p_n to every column, as moment_vector
  /// does.
  template <class Filter, class Value>
  Eigen::Matrix<double, basis_size, D> moment_columns(const points<D>& x, const search::neighbour_list<D>& nl,
                                                      index_t i, const Filter& filter,
                                                      const Value& value) const {
    Eigen::Matrix<double, basis_size, D> B = Eigen::Matrix<double, basis_size, D>::Zero();
    vector pv;
    vec<D> vi;
    for (int a = 0; a < D; ++a) vi[a] = value(a, i);
    const double Li = diameter(i);
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      if (is_point(j)) {
        basis::eval_directional(s, np_.normal->col(j), pv);
        const double c = w * Li * (*np_.dfdn)[j];
        for (int a = 0; a < D; ++a) B.col(a) += c * pv;
        return;
      }
      basis::eval(s, pv);
      for (int a = 0; a < D; ++a) B.col(a) += (w * (value(a, j) - vi[a])) * pv;
    });
    return B;
  }

  /// B_i = Σ_j w_ij p(x_ij/L_i) (u_j − u_i)ᵀ (eq. 45 per component; its callers refuse Neumann points).
  template <class Filter>
  Eigen::Matrix<double, basis_size, D> moment_matrix(const points<D>& x, const search::neighbour_list<D>& nl,
                                                     index_t i, const points<D>& u,
                                                     const Filter& filter) const {
    return moment_columns(x, nl, i, filter, [&](int a, index_t j) { return u(a, j); });
  }

  template <Execution E, SizeModel S, class Filter>
  void compute_impl(E e, const points<D>& x, const search::neighbour_list<D>& nl, const S& size,
                    const neumann_constraint<D>* nc, const Filter& filter) {
    const index_t n = x.cols();
    if (nl.rows() != n) fail("lsmps_a: the neighbour list has ", nl.rows(), " rows for ", n, " particles");
    if constexpr (S::uniform) {
      if (!(std::isfinite(size.L) && size.L > 0.0))
        fail("lsmps_a: diameter L = ", size.L, ": must be a finite number > 0");
      L_ = nullptr;
      l_ = size.L;
    } else {
      if (!size.L) fail("lsmps_a: per_particle_size has no array");
      if (size.L->size() != n) fail("lsmps_a: ", size.L->size(), " diameters for ", n, " particles");
      for (index_t i = 0; i < n; ++i)
        if (!(std::isfinite((*size.L)[i]) && (*size.L)[i] > 0.0))
          fail("lsmps_a: diameter of particle ", i, " = ", (*size.L)[i], ": must be a finite number > 0");
      L_ = size.L;
    }
    if (nc) np_ = {};
    nc_normal_ = nc ? nc->normal : nullptr;
    nc_mark_ = nc ? nc->constrained : nullptr;
    nc_form_ = nc ? nc->form : neumann_form::derivative;
    n_ = n;
    factors_.resize(static_cast<std::size_t>(n) * msq);
    flags_.assign(static_cast<std::size_t>(n), 0);
    order_.assign(static_cast<std::size_t>(n), 0);
    cond_.assign(static_cast<std::size_t>(n), 0.0);
    for_each_particle(e, n, [&](index_t i) { factor_one(x, nl, i, filter); });
  }

  /// Lower triangle of M_i (eq. 44) + N_i (eq. 86) when constrained.
  template <class Filter>
  matrix moment_lower(const points<D>& x, const search::neighbour_list<D>& nl, index_t i,
                      const Filter& filter) const {
    // Two phases per chunk of neighbours: gather (w, x_ij/L) from the sweep, then accumulate the packed lower
    // triangle in a tight loop whose accumulators stay in registers (accumulating inside the sweep's
    // callback kept them in memory: ~2× the instructions). Summation order is the neighbour order either way.
    constexpr int chunk = 64;
    std::array<double, basis_size*(basis_size + 1) / 2> acc{};
    std::array<double, chunk> wb;
    std::array<vec<D>, chunk> sb;
    int k = 0;
    auto flush = [&] {
      vector pv;
      for (int q = 0; q < k; ++q) {
        basis::eval(sb[static_cast<std::size_t>(q)], pv);
        const double w = wb[static_cast<std::size_t>(q)];
        int t = 0;
        MPSKIT_UNROLL
        for (int a = 0; a < basis_size; ++a) {
          const double wpa = w * pv[a];
          MPSKIT_UNROLL
          for (int b = 0; b <= a; ++b) acc[static_cast<std::size_t>(t++)] += wpa * pv[b];
        }
      }
      k = 0;
    };
    matrix Mp;  // Neumann points' part (only with neumann_points)
    if (np_.mark) Mp.setZero();
    sweep(x, nl, i, filter, [&](index_t j, double w, const vec<D>& s) {
      if (is_point(j)) {  // a Neumann point: w d dᵀ with d = n_j·∇_s p(s)
        vector d;
        basis::eval_directional(s, np_.normal->col(j), d);
        Mp.noalias() += w * d * d.transpose();
        return;
      }
      wb[static_cast<std::size_t>(k)] = w;
      sb[static_cast<std::size_t>(k)] = s;
      if (++k == chunk) flush();
    });
    flush();
    matrix M = matrix::Zero();
    {
      int t = 0;
      for (int a = 0; a < basis_size; ++a)
        for (int b = 0; b <= a; ++b) M(a, b) = acc[static_cast<std::size_t>(t++)];
    }
    if (np_.mark) M.template triangularView<Eigen::Lower>() += Mp;
    if (is_constrained(i)) {
      const vector q = neumann_vector(i);  // w(0) q
      const double w0 = K::w(0.0, re(i));
      // w(0) q qᵀ
      for (int a = 0; a < basis_size; ++a) for (int b = 0; b <= a; ++b) M(a, b) += q[a] * q[b] / w0;
    }
    return M;
  }

  /// Moments, the pivot test and the fallback for particle i.
  template <class Filter>
  void factor_one(const points<D>& x, const search::neighbour_list<D>& nl, index_t i, const Filter& filter) {
    const matrix M = moment_lower(x, nl, i, filter);
    matrix inv;
    const detail::factor_result r = detail::factorise(
        M, Order, [](int p) { return basis::size_at(p); }, 1, p_.fallback == degenerate_fallback::lower_order,
        p_.max_condition, p_.regularisation, p_.fallback == degenerate_fallback::lower_order ? D : basis_size,
        inv);
    Eigen::Map<matrix>(factors_.data() + static_cast<std::size_t>(i) * msq) = inv;
    if (r.degenerate) flags_[static_cast<std::size_t>(i)] |= flag::degenerate;
    order_[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(r.order);
    cond_[static_cast<std::size_t>(i)] = r.condition;
  }

  lsmps_params p_;
  const Eigen::VectorXd* L_ = nullptr;
  double l_ = 0.0;
  const points<D>* nc_normal_ = nullptr;
  const std::vector<std::uint8_t>* nc_mark_ = nullptr;
  neumann_form nc_form_ = neumann_form::derivative;
  neumann_points<D> np_{};
  index_t n_ = 0;
  std::vector<double> factors_;
  std::vector<flag::type> flags_;
  std::vector<std::uint8_t> order_;
  std::vector<double> cond_;
};

}  // namespace mpskit::op
