// op/: classic MPS (eqs. 8–12, 22; corrected-matrix gradient; Tang & Wan interface forms), LSMPS type A
// and type B orders 1–3 in 2D/3D, the Neumann-constrained variant, rows and the row-contribution hook,
// degenerate neighbourhoods. References: Tanaka 2018 §4.2, §5.1 (Table 1), eqs. 85–87; bmmr.md eq. 29;
// Tang & Wan eqs. 18–20. Every tolerance is written beside its assertion with its reason.
#include <doctest/doctest.h>

#include "cases/tanaka_table1.hpp"
#include "support/support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <span>
#include <utility>
#include <vector>

#include "mpskit/kernel/classic.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/op/concepts.hpp"
#include "mpskit/op/lsmps_a.hpp"
#include "mpskit/op/lsmps_b.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/op/row.hpp"
#include "mpskit/search/neighbour_list.hpp"

using namespace mpskit;

static_assert(op::GradientStencil<op::mps<2>, 2> && op::LaplacianStencil<op::mps<3>, 3>);
static_assert(op::GradientStencil<op::lsmps_a<2, 2>, 2> && op::LaplacianStencil<op::lsmps_a<2, 2>, 2>);
static_assert(op::GradientStencil<op::lsmps_a<3, 3>, 3> && op::LaplacianStencil<op::lsmps_a<3, 1>, 3>);
static_assert(!op::GradientStencil<int, 2>);
static_assert(op::RowBuilder<op::row_value> && op::RowBuilder<op::row_entries> && !op::RowBuilder<int>);
static_assert(op::SizeModel<op::uniform_size> && op::SizeModel<op::per_particle_size> && !op::SizeModel<int>);
static_assert(op::RowContribution<op::no_contribution, op::lsmps_a<2, 2>::row_view, op::row_entries>);
static_assert(op::RowContribution<op::neumann_rows, op::lsmps_a<2, 2>::row_view, op::row_value>);
// Archetypes of the op/ concepts (the least a type must offer), checked here.
namespace archetype {
struct row_builder {
  void add(index_t, double) {}
  void add_diagonal(double) {}
  void add_constant(double) {}
};
struct size_model {
  static constexpr bool uniform = true;
  double operator()(index_t) const { return 1.0; }
};
struct hook {
  template <class Row, class B>
  void operator()(index_t, const Row&, B&) const {}
};
}  // namespace archetype
static_assert(op::RowBuilder<archetype::row_builder> && op::SizeModel<archetype::size_model>);
static_assert(op::RowContribution<archetype::hook, op::mps<2>::row_view, archetype::row_builder>);
static_assert(!op::RowContribution<int, op::mps<2>::row_view, archetype::row_builder>);

static_assert(op::detail::basis_size(2, 1) == 2 && op::detail::basis_size(2, 2) == 5 &&
              op::detail::basis_size(2, 3) == 9);
static_assert(op::detail::basis_size(3, 1) == 3 && op::detail::basis_size(3, 2) == 9 &&
              op::detail::basis_size(3, 3) == 19);

namespace {

/// Seed: MPSKIT_TEST_SEED overrides the default (printed by every randomised case).
std::uint64_t test_seed() {
  static const std::uint64_t s = [] {
    const char* e = std::getenv("MPSKIT_TEST_SEED");
    return e ? std::strtoull(e, nullptr, 10) : std::uint64_t{20181001};
  }();
  return s;
}

// ---- point sets ------------------------------------------------------------------------------------

using mpskit::test::jittered_lattice;

/// Dart throwing in [0, box]^D with minimum distance dmin (brute force; small sets only).
template <int D>
points<D> min_distance_cloud(double box, double dmin, index_t target, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0.0, box);
  std::vector<vec<D>> pts;
  for (index_t tries = 0; tries < 200 * target && static_cast<index_t>(pts.size()) < target; ++tries) {
    vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = U(rng);
    bool ok = true;
    for (const vec<D>& q : pts)
      if ((q - p).squaredNorm() < dmin * dmin) {
        ok = false;
        break;
      }
    if (ok) pts.push_back(p);
  }
  points<D> x(D, static_cast<index_t>(pts.size()));
  for (std::size_t k = 0; k < pts.size(); ++k) x.col(static_cast<index_t>(k)) = pts[k];
  return x;
}

// ---- polynomials with exact derivatives ------------------------------------------------------------

/// Σ_α c_α x^α over all |α| ≤ p (α includes 0).
template <int D>
struct polynomial {
  std::vector<std::array<int, 3>> alpha;
  std::vector<double> coef;
  static double falling(int n, int k) {  // n (n−1) … (n−k+1)
    double r = 1.0;
    for (int t = 0; t < k; ++t) r *= n - t;
    return r;
  }
  /// ∂^β f at x.
  double d(const vec<D>& x, const std::array<int, 3>& beta) const {
    double s = 0.0;
    for (std::size_t k = 0; k < alpha.size(); ++k) {
      double v = coef[k];
      for (int a = 0; a < D; ++a) {
        if (alpha[k][a] < beta[a]) {
          v = 0.0;
          break;
        }
        v *= falling(alpha[k][a], beta[a]) * std::pow(x[a], alpha[k][a] - beta[a]);
      }
      s += v;
    }
    return s;
  }
  double value(const vec<D>& x) const { return d(x, {0, 0, 0}); }
  Eigen::VectorXd sample(const points<D>& x) const {
    Eigen::VectorXd f(x.cols());
    for (index_t i = 0; i < x.cols(); ++i) f[i] = value(x.col(i));
    return f;
  }
};

template <int D>
polynomial<D> random_polynomial(int p, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-10.0, 10.0);
  polynomial<D> f;
  for (int ax = 0; ax <= p; ++ax)
    for (int ay = 0; ax + ay <= p; ++ay)
      for (int az = 0; ax + ay + az <= p; ++az) {
        if (D == 2 && az > 0) continue;
        f.alpha.push_back({ax, ay, az});
        f.coef.push_back(U(rng));
      }
  return f;
}

/// Every derivative index of D_x up to order p (as exponents), in the basis order.
template <int D, int P>
std::vector<std::array<int, 3>> derivative_list() {
  std::vector<std::array<int, 3>> out;
  const auto& t = op::detail::lsmps_basis<D, P>::table;
  for (int k = 0; k < op::detail::lsmps_basis<D, P>::size; ++k) out.push_back(t.alpha[k]);
  return out;
}

template <int D>
search::neighbour_list<D> list_for(const points<D>& x, double R) {
  search::neighbour_list<D> nl;
  nl.build(exec::seq{}, x, search::uniform_radius{R});
  return nl;
}

template <int D>
search::neighbour_list<D> list_for(const points<D>& x, const Eigen::VectorXd& L, double ratio) {
  search::neighbour_list<D> nl;
  nl.build(exec::seq{}, x, search::per_particle_radius{&L, ratio});
  return nl;
}

// ---- the two-size block of Tanaka 2018 §5.1 --------------------------------------------------------

struct block {
  points<2> x;
  Eigen::VectorXd L;
  std::vector<std::uint8_t> interface;  // particles within 3.1 max(L) of x = 0 (Tanaka's red particles)
};

/// Diameter 1 for x < 0 (lattice of spacing 1, 12 × 24), diameter s for x > 0 (spacing s, same extent);
/// lattice points at cell centres, so the interface is x = 0. Tanaka's block extent and alignment are not
/// in the text (validation-cases.md A1): this is our choice.
block tanaka_block(double s) {
  const double W = 12.0, H = 24.0;
  std::vector<vec<2>> pts;
  std::vector<double> L;
  for (int b = 0; b < int(H); ++b)
    for (int a = 0; a < int(W); ++a) {
      pts.push_back(vec<2>(-W + 0.5 + a, b + 0.5));
      L.push_back(1.0);
    }
  const int nx = static_cast<int>(std::floor(W / s)), ny = static_cast<int>(std::floor(H / s));
  for (int b = 0; b < ny; ++b)
    for (int a = 0; a < nx; ++a) {
      pts.push_back(vec<2>((a + 0.5) * s, (b + 0.5) * s));
      L.push_back(s);
    }
  block B;
  B.x.resize(2, static_cast<index_t>(pts.size()));
  B.L.resize(static_cast<index_t>(pts.size()));
  B.interface.resize(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k) {
    B.x.col(static_cast<index_t>(k)) = pts[k];
    B.L[static_cast<index_t>(k)] = L[k];
    B.interface[k] = std::abs(pts[k][0]) < 3.1 * s;
  }
  return B;
}

/// Table 1 of Tanaka 2018 (validation-cases.md A1): f = ax² + by² + cxy + dx + ey + f.
constexpr const auto& table1 = mpskit::cases::tanaka_table1;

polynomial<2> table1_poly(int set) {
  const double* c = table1[set];
  polynomial<2> f;
  f.alpha = {{2, 0, 0}, {0, 2, 0}, {1, 1, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}};
  f.coef = {c[0], c[1], c[2], c[3], c[4], c[5]};
  return f;
}

// ---- checks shared by type A cases -----------------------------------------------------------------

/// Error scale per derivative: max |∂^β f| over the points and over every β of the same order |β| (a
/// random cubic can have a tiny ∂³f/∂x³ alone; normalising by it alone would measure nothing).
template <int D>
std::vector<double> derivative_scales(const polynomial<D>& f, const points<D>& x,
                                      const std::vector<std::array<int, 3>>& ders) {
  std::array<double, 4> by_order{0, 0, 0, 0};
  for (index_t i = 0; i < x.cols(); ++i)
    for (const auto& b : ders)
      by_order[static_cast<std::size_t>(b[0] + b[1] + b[2])] =
          std::max(by_order[static_cast<std::size_t>(b[0] + b[1] + b[2])], std::abs(f.d(x.col(i), b)));
  std::vector<double> s;
  for (const auto& b : ders) s.push_back(by_order[static_cast<std::size_t>(b[0] + b[1] + b[2])]);
  return s;
}

/// Max over particles (mask) and derivatives of |computed − exact| / (derivative scale), divided by the
/// particle's tolerance max(tol, 1e-12 · cond₁(M_i)): reproduction is exact up to rounding, and the
/// rounding of φ_ij and of the factorisation is amplified by the moment matrix's condition — cond₁ ~ 10²
/// inside a cloud, up to the 1e8 limit (params().max_condition) at one-sided order-3 edge particles.
/// Measured over seeds 1–60: error ≤ 1e-11 where cond₁ < 10³ and error / cond₁ ≤ 2e-14 above, so 1e-12
/// keeps a factor 50. A returned value < 1 passes.
template <class Op, int D>
double type_a_reproduction_error(const Op& A, const points<D>& x, const search::neighbour_list<D>& nl,
                                 const polynomial<D>& f, double tol,
                                 const std::vector<std::uint8_t>* mask = nullptr) {
  constexpr int P = Op::order;
  const auto ders = derivative_list<D, P>();
  const Eigen::VectorXd phi = f.sample(x);
  const std::vector<double> scale = derivative_scales<D>(f, x, ders);
  double err = 0.0;
  for (index_t i = 0; i < x.cols(); ++i) {
    if (mask && !(*mask)[static_cast<std::size_t>(i)]) continue;
    const typename Op::vector got = A.derivatives(x, nl, i, phi);
    const double tol_i = std::max(tol, 1e-12 * A.condition(i));
    for (std::size_t k = 0; k < ders.size(); ++k) {
      const double e =
          std::abs(got[static_cast<int>(k)] - f.d(x.col(i), ders[k])) / std::max(scale[k], 1e-300);
      err = std::max(err, e / tol_i);
    }
  }
  return err;
}

template <class Op, int D>
double type_b_reproduction_error(const Op& B, const points<D>& x, const polynomial<D>& f, const points<D>& q,
                                 double l, double tol, index_t& flagged) {
  constexpr int P = Op::order;
  auto ders = derivative_list<D, P>();
  ders.insert(ders.begin(), {0, 0, 0});
  const Eigen::VectorXd phi = f.sample(x);
  std::vector<index_t> all(static_cast<std::size_t>(x.cols()));
  for (index_t j = 0; j < x.cols(); ++j) all[static_cast<std::size_t>(j)] = j;
  const std::vector<double> scale = derivative_scales<D>(f, q, ders);
  double err = 0.0;
  flagged = 0;
  for (index_t i = 0; i < q.cols(); ++i) {
    const auto st = B.stencil(x, vec<D>(q.col(i)), l, all, op::uniform_size{l});
    flagged += (st.flags & flag::degenerate) != 0;
    const typename Op::vector got = st.apply(phi);
    // as type_a_reproduction_error (cond₁ ≥ cond₂/m)
    const double tol_i = std::max(tol, 1e-12 * st.condition);
    for (std::size_t k = 0; k < ders.size(); ++k)
      err = std::max(err, std::abs(got[static_cast<int>(k)] - f.d(q.col(i), ders[k])) /
                              std::max(scale[k], 1e-300) / tol_i);
  }
  return err;
}

template <int D>
std::vector<std::uint8_t> interior_mask(const points<D>& x, double lo, double hi, double margin) {
  std::vector<std::uint8_t> m(static_cast<std::size_t>(x.cols()));
  for (index_t i = 0; i < x.cols(); ++i) {
    bool in = true;
    for (int a = 0; a < D; ++a) in = in && x(a, i) >= lo + margin && x(a, i) <= hi - margin;
    m[static_cast<std::size_t>(i)] = in;
  }
  return m;
}

/// Flag check of a reproduction set; returns the particles whose reproduction is checked (the unflagged
/// ones). Particles ≥ R from the edge: none flagged, on lattices and clouds, every order. Edge particles of
/// a lattice at orders 1–2: none flagged. At order 3, and at the edge of a min-distance random cloud, a
/// corner particle can hold fewer neighbours inside 3.1 L than the basis has monomials (a 2D lattice
/// corner holds ~9 for 9 monomials; jitter can leave 7): genuinely degenerate, flagged and handled by the
/// fallback (tested in the "degenerate" cases); their number is printed.
template <class Op, int D>
std::vector<std::uint8_t> check_flags(const Op& A, const points<D>& x, bool cloud, double R) {
  std::vector<std::uint8_t> ok(static_cast<std::size_t>(x.cols()));
  const vec<D> lo = x.rowwise().minCoeff(), hi = x.rowwise().maxCoeff();
  const bool edges_must_pass = !cloud && Op::order <= 2;
  index_t flagged = 0, edge_flagged = 0;
  for (index_t i = 0; i < x.cols(); ++i) {
    const bool f = (A.flags()[static_cast<std::size_t>(i)] & flag::degenerate) != 0;
    bool inside = true;
    for (int a = 0; a < D; ++a) inside = inside && x(a, i) >= lo[a] + R && x(a, i) <= hi[a] - R;
    ok[static_cast<std::size_t>(i)] = !f;
    if (inside || edges_must_pass)
      flagged += f;
    else
      edge_flagged += f;
  }
  if (edge_flagged > 0)
    MESSAGE(edge_flagged << " edge particle(s) flagged of " << x.cols() << " (order " << Op::order << ")");
  CHECK(flagged == 0);
  return ok;
}

/// Least-squares slope of log(err) against log(h).
double fitted_slope(const std::vector<double>& h, const std::vector<double>& e) {
  double mx = 0, my = 0;
  for (std::size_t k = 0; k < h.size(); ++k) {
    mx += std::log(h[k]);
    my += std::log(e[k]);
  }
  mx /= double(h.size());
  my /= double(h.size());
  double sxy = 0, sxx = 0;
  for (std::size_t k = 0; k < h.size(); ++k) {
    sxy += (std::log(h[k]) - mx) * (std::log(e[k]) - my);
    sxx += (std::log(h[k]) - mx) * (std::log(h[k]) - mx);
  }
  return sxy / sxx;
}

}  // namespace

TEST_SUITE("operators") {
  // ======================================================================================================
  // LSMPS basis
  // ======================================================================================================
  TEST_CASE("op: lsmps basis order and H = diag(α!/L^|α|)") {
    using B = op::detail::lsmps_basis<2, 2>;
    // Tanaka eq. 46: [x, y, x², xy, y²]
    CHECK(B::index_of(1, 0) == 0);
    CHECK(B::index_of(0, 1) == 1);
    CHECK(B::index_of(2, 0) == 2);
    CHECK(B::index_of(1, 1) == 3);
    CHECK(B::index_of(0, 2) == 4);
    const B::vector h = B::h_diag(0.5);
    // H of eq. 43 with L^−|α| (the extraction's L^−1 on the second-derivative rows is a typo): exact values.
    CHECK(h[0] == 2.0);
    CHECK(h[2] == 8.0);
    CHECK(h[3] == 4.0);
    CHECK(h[4] == 8.0);
    using B3 = op::detail::lsmps_basis<3, 3>;
    CHECK(B3::table.factorial[B3::index_of(2, 1, 0)] == 2.0);
    CHECK(B3::table.factorial[B3::index_of(3, 0, 0)] == 6.0);
    CHECK(B3::index_of(0, 0, 3) == 18);
  }

  using basis_2_1 = op::detail::lsmps_basis<2, 1>;
  using basis_2_2 = op::detail::lsmps_basis<2, 2>;
  using basis_2_3 = op::detail::lsmps_basis<2, 3>;
  using basis_3_1 = op::detail::lsmps_basis<3, 1>;
  using basis_3_2 = op::detail::lsmps_basis<3, 2>;
  using basis_3_3 = op::detail::lsmps_basis<3, 3>;
  TEST_CASE_TEMPLATE("op: the written-out basis equals the monomial table", B, basis_2_1, basis_2_2,
                     basis_2_3, basis_3_1, basis_3_2, basis_3_3) {
    std::mt19937_64 rng(test_seed());
    std::uniform_real_distribution<double> U(-3.0, 3.0);
    constexpr int D = B::dim;
    for (int t = 0; t < 20; ++t) {
      vec<D> x;
      for (int a = 0; a < D; ++a) x[a] = U(rng);
      typename B::vector p, q;
      B::eval(x, p);
      B::eval_table(x, q);
      // the same monomials, products associated differently (x·z·z vs x·z²): equal to a few ulps
      CHECK((p - q).norm() <= 4e-16 * q.norm());
    }
  }

  // ======================================================================================================
  // Tanaka 2018 §5.1: two-size block, Table 1 quadratics
  // ======================================================================================================
  TEST_CASE_TEMPLATE("op: lsmps is exact on Tanaka's two-size block (§5.1, Table 1)", Op, op::lsmps_a<2, 2>,
                     op::lsmps_a<2, 3>) {
    for (double s : {1.0, 1.5, 2.0, 2.5, 3.0}) {
      CAPTURE(s);
      const block B = tanaka_block(s);
      const search::neighbour_list<2> nl = list_for(B.x, B.L, 3.1);
      Op A;  // R_e = 3.1, pair-mean radius, quadratic kernel (Tanaka eqs. 27–29)
      A.compute(exec::seq{}, B.x, nl, op::per_particle_size{&B.L});
      CHECK(A.degenerate_count() == 0);
      for (int set = 0; set < 10; ++set) {
        CAPTURE(set);
        const polynomial<2> f = table1_poly(set);
        const Eigen::VectorXd phi = f.sample(B.x);
        double gx = 0, gy = 0, ex = 0, ey = 0, el = 0, ei = 0;
        for (index_t i = 0; i < B.x.cols(); ++i) {
          gx = std::max(gx, std::abs(f.d(B.x.col(i), {1, 0, 0})));
          gy = std::max(gy, std::abs(f.d(B.x.col(i), {0, 1, 0})));
        }
        const double lap = 2 * table1[set][0] + 2 * table1[set][1];
        for (index_t i = 0; i < B.x.cols(); ++i) {
          const auto [g, l] = A.gradient_laplacian(B.x, nl, i, phi);
          ex = std::max(ex, std::abs(g[0] - f.d(B.x.col(i), {1, 0, 0})) / gx);
          ey = std::max(ey, std::abs(g[1] - f.d(B.x.col(i), {0, 1, 0})) / gy);
          el = std::max(el, std::abs(l - lap) / std::abs(lap));
          if (B.interface[static_cast<std::size_t>(i)]) ei = std::max(ei, std::abs(l - lap) / std::abs(lap));
        }
        // Order ≥ 2 reproduces quadratics exactly (validation-cases.md A1); 1e-9 leaves room for the
        // rounding of a 5×5 (9×9) inverse over a block of extent ~36 L.
        CHECK(ex < 1e-9);
        CHECK(ey < 1e-9);
        CHECK(el < 1e-9);
        CHECK(ei < 1e-9);
      }
    }
  }

  TEST_CASE(
      "op: lsmps type A, D components in one sweep (gradients, laplacians) equal D scalar calls bitwise") {
    // The schemes take ∇u and ∇²u of a velocity's components from one neighbour sweep (moment_vectors); the
    // sums are the same terms in the same order, so the results must be equal to the bit, with per-particle
    // sizes and with a filter (every third particle left out). Fields: two unrelated samples with noise.
    const block B = tanaka_block(2.0);
    const search::neighbour_list<2> nl = list_for(B.x, B.L, 3.1);
    op::lsmps_a<2, 2> A;
    A.compute(exec::seq{}, B.x, nl, op::per_particle_size{&B.L});
    std::mt19937_64 rng(test_seed() + 41);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    std::array<Eigen::VectorXd, 2> u;
    for (auto& c : u) {
      c.resize(B.x.cols());
      for (index_t i = 0; i < B.x.cols(); ++i) c[i] = std::sin(7.0 * B.x(0, i)) + U(rng);
    }
    const auto every_third_out = [](index_t j) { return j % 3 != 0; };
    long differ = 0;
    for (index_t i = 0; i < B.x.cols(); ++i) {
      const mat<2> G = A.gradients(B.x, nl, i, u), Gf = A.gradients(B.x, nl, i, u, every_third_out);
      const vec<2> l = A.laplacians(B.x, nl, i, u), lf = A.laplacians(B.x, nl, i, u, every_third_out);
      for (int a = 0; a < 2; ++a) {
        const Eigen::VectorXd& ua = u[static_cast<std::size_t>(a)];
        differ += (G.row(a).transpose().array() != A.gradient(B.x, nl, i, ua).array()).count();
        differ +=
            (Gf.row(a).transpose().array() != A.gradient(B.x, nl, i, ua, every_third_out).array()).count();
        differ += l[a] != A.laplacian(B.x, nl, i, ua);
        differ += lf[a] != A.laplacian(B.x, nl, i, ua, every_third_out);
      }
    }
    CHECK(differ == 0);
  }

  TEST_CASE("op: lsmps type B is exact on Tanaka's block at particles and between sizes") {
    op::lsmps_b<2, 2> B;
    for (double s : {1.0, 2.0, 3.0}) {
      CAPTURE(s);
      const block K = tanaka_block(s);
      std::vector<index_t> all(static_cast<std::size_t>(K.x.cols()));
      for (index_t j = 0; j < K.x.cols(); ++j) all[static_cast<std::size_t>(j)] = j;
      const polynomial<2> f = table1_poly(4);
      const Eigen::VectorXd phi = f.sample(K.x);
      double err = 0.0;
      for (double y : {3.3, 10.1}) {
        for (double xq : {-2.0, -0.5, 0.0, 0.5 * s, 2.0 * s}) {
          const vec<2> q(xq, y);
          const double l = xq < 0 ? 1.0 : s;
          const auto st = B.stencil(K.x, q, l, all, op::per_particle_size{&K.L});
          CHECK(st.flags == 0);
          const auto v = st.apply(phi);
          err = std::max(err, std::abs(v[0] - f.value(q)) / 1e3);
          err = std::max(err, std::abs(v[1] - f.d(q, {1, 0, 0})) / 1e2);
          err = std::max(err, std::abs(st.laplacian(phi) - (2 * table1[4][0] + 2 * table1[4][1])) / 10.0);
        }
      }
      CHECK(err < 1e-9);  // exact reproduction (scales: |f| ≤ 1e3·…, |∇f| ~ 1e2, ∇²f ~ 10 on the block)
    }
  }

  // ======================================================================================================
  // Polynomial reproduction, orders 1–3, type A and B, 2D and 3D
  // ======================================================================================================
  TEST_CASE_TEMPLATE("op: lsmps type A reproduces every polynomial of degree ≤ p (2D)", Op, op::lsmps_a<2, 1>,
                     op::lsmps_a<2, 2>, op::lsmps_a<2, 3>) {
    std::mt19937_64 rng(test_seed());
    MESSAGE("seed " << test_seed() << " (set MPSKIT_TEST_SEED to replay)");
    const double h = 0.1;
    const points<2> lat = jittered_lattice<2>(16, h, 0.2, rng);
    const points<2> cloud = min_distance_cloud<2>(1.6, 0.8 * h, 256, rng);
    for (const points<2>* x : {&lat, &cloud}) {
      const search::neighbour_list<2> nl = list_for(*x, 3.1 * h);
      Op A;
      A.compute(exec::seq{}, *x, nl, op::uniform_size{h});
      const std::vector<std::uint8_t> ok = check_flags(A, *x, x == &cloud, 3.1 * h);
      for (int t = 0; t < 3; ++t) {
        const polynomial<2> f = random_polynomial<2>(Op::order, rng);
        CHECK(type_a_reproduction_error(A, *x, nl, f, 1e-9, &ok) < 1.0);
      }
    }
  }

  TEST_CASE_TEMPLATE("op: lsmps type A reproduces every polynomial of degree ≤ p (3D)", Op, op::lsmps_a<3, 1>,
                     op::lsmps_a<3, 2>, op::lsmps_a<3, 3>) {
    std::mt19937_64 rng(test_seed() + 3);
    MESSAGE("seed " << test_seed() + 3 << " (set MPSKIT_TEST_SEED to replay)");
    const double h = 0.1;
    const points<3> lat = jittered_lattice<3>(7, h, 0.2, rng);
    const points<3> cloud = min_distance_cloud<3>(0.7, 0.8 * h, 343, rng);
    for (const points<3>* x : {&lat, &cloud}) {
      const search::neighbour_list<3> nl = list_for(*x, 3.1 * h);
      Op A;
      A.compute(exec::seq{}, *x, nl, op::uniform_size{h});
      const std::vector<std::uint8_t> ok = check_flags(A, *x, x == &cloud, 3.1 * h);
      const polynomial<3> f = random_polynomial<3>(Op::order, rng);
      CHECK(type_a_reproduction_error(A, *x, nl, f, 1e-9, &ok) < 1.0);
    }
  }

  TEST_CASE("op: lsmps type A, 3D: ten seeded quadratics on a two-size block") {
    std::mt19937_64 rng(test_seed() + 5);
    MESSAGE("seed " << test_seed() + 5 << " (set MPSKIT_TEST_SEED to replay)");
    // diameter 1 for x < 0 and 2 for x > 0 (the 3D analogue of §5.1)
    std::vector<vec<3>> pts;
    std::vector<double> L;
    for (int c = 0; c < 6; ++c)
      for (int b = 0; b < 6; ++b)
        for (int a = 0; a < 5; ++a) {
          pts.push_back(vec<3>(-5 + 0.5 + a, b + 0.5, c + 0.5));
          L.push_back(1.0);
        }
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 3; ++b)
        for (int a = 0; a < 3; ++a) {
          pts.push_back(vec<3>(2.0 * a + 1.0, 2.0 * b + 1.0, 2.0 * c + 1.0));
          L.push_back(2.0);
        }
    points<3> x(3, static_cast<index_t>(pts.size()));
    Eigen::VectorXd Ls(static_cast<index_t>(pts.size()));
    for (std::size_t k = 0; k < pts.size(); ++k) {
      x.col(static_cast<index_t>(k)) = pts[k];
      Ls[static_cast<index_t>(k)] = L[k];
    }
    const search::neighbour_list<3> nl = list_for(x, Ls, 3.1);
    op::lsmps_a<3, 2> A;
    A.compute(exec::seq{}, x, nl, op::per_particle_size{&Ls});
    CHECK(A.degenerate_count() == 0);
    for (int t = 0; t < 10; ++t) {
      const polynomial<3> f = random_polynomial<3>(2, rng);
      CHECK(type_a_reproduction_error(A, x, nl, f, 1e-9) < 1.0);
    }
  }

  TEST_CASE_TEMPLATE("op: lsmps type B reproduces every polynomial of degree ≤ p at any point", Op,
                     op::lsmps_b<2, 1>, op::lsmps_b<2, 2>, op::lsmps_b<2, 3>, op::lsmps_b<3, 1>,
                     op::lsmps_b<3, 2>, op::lsmps_b<3, 3>) {
    constexpr int D = Op::dim;
    std::mt19937_64 rng(test_seed() + 7);
    MESSAGE("seed " << test_seed() + 7 << " (set MPSKIT_TEST_SEED to replay)");
    const double h = 0.1;
    const points<D> lat = jittered_lattice<D>(D == 2 ? 12 : 7, h, 0.2, rng);
    const points<D> cloud = min_distance_cloud<D>(D == 2 ? 1.2 : 0.7, 0.8 * h, D == 2 ? 144 : 343, rng);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    for (const points<D>* x : {&lat, &cloud}) {
      // query points: random points anywhere in the set's box, plus three particle positions
      // query points: random points in the set's box (clouds: ≥ R from its edge, see check_flags), plus
      // three particle positions (r = 0 in the kernel)
      const double margin = x == &cloud ? 3.1 * h : 0.0;
      const vec<D> lo = x->rowwise().minCoeff().array() + margin,
                   hi = x->rowwise().maxCoeff().array() - margin;
      points<D> q(D, 23);
      for (index_t k = 0; k < 20; ++k)
        for (int a = 0; a < D; ++a) q(a, k) = lo[a] + U(rng) * (hi[a] - lo[a]);
      for (index_t k = 20; k < 23; ++k) q.col(k) = x == &cloud ? q.col(k - 20).eval() : x->col(k * 3).eval();
      Op B;
      const polynomial<D> f = random_polynomial<D>(Op::order, rng);
      index_t flagged = 0;
      CHECK(type_b_reproduction_error(B, *x, f, q, h, 1e-9, flagged) < 1.0);
      CHECK(flagged == 0);
    }
  }

  TEST_CASE(
      "op: lsmps type B into a reused stencil and workspace: the returning form's numbers, bit for bit") {
    // The in-place form (regularize::boundary_filter's loop) overwrites every member and reuses the vectors'
    // capacity: points with large, small (a corner: fewer candidates, a larger condition number), degenerate
    // (the two particles nearest the centre: a fallback, flagged) and again large neighbourhoods, through one
    // stencil and one workspace, give exactly what a fresh call gives. Fails if a member or the scratch is
    // not reset. (The returning form calls the in-place one with fresh objects: this checks the reuse, not
    // the fit, whose exactness the reproduction tests above check.)
    std::mt19937_64 rng(test_seed() + 41);
    MESSAGE("seed " << test_seed() + 41 << " (set MPSKIT_TEST_SEED to replay)");
    const double h = 0.1;
    const points<2> x = jittered_lattice<2>(12, h, 0.2, rng);
    std::vector<index_t> all(static_cast<std::size_t>(x.cols()));
    for (index_t j = 0; j < x.cols(); ++j) all[static_cast<std::size_t>(j)] = j;
    const vec<2> centre = x.rowwise().mean(), corner = x.col(0);
    std::vector<index_t> two = all;  // the two particles nearest the centre
    std::partial_sort(two.begin(), two.begin() + 2, two.end(), [&](index_t a, index_t b) {
      return (x.col(a) - centre).squaredNorm() < (x.col(b) - centre).squaredNorm();
    });
    two.resize(2);
    using query = std::pair<vec<2>, const std::vector<index_t>*>;
    Eigen::VectorXd L = Eigen::VectorXd::Constant(x.cols(), h);
    for (index_t j = 0; j < x.cols(); j += 3) L[j] = 1.3 * h;  // mixed sizes: pair radii differ
    const op::lsmps_b<2, 2> B;
    op::lsmps_b<2, 2>::point_stencil st;
    op::lsmps_b<2, 2>::workspace ws;
    int degenerate = 0;
    for (const auto& [q, cand] : {query{centre, &all}, query{corner, &all}, query{centre, &two},
                                  query{vec<2>(centre + vec<2>(0.37 * h, -0.21 * h)), &all}}) {
      const std::span<const index_t> c(*cand);
      const auto ref = B.stencil(x, q, 1.1 * h, c, op::per_particle_size{&L});
      B.stencil(x, q, 1.1 * h, c, op::per_particle_size{&L}, op::all_neighbours{}, st, ws);
      CHECK(ref.columns == st.columns);
      CHECK(mpskit::test::same_bits(ref.weights, st.weights));
      CHECK(ref.order_used == st.order_used);
      CHECK(ref.flags == st.flags);
      CHECK(mpskit::test::same_bits(ref.condition, st.condition));
      CHECK(mpskit::test::same_bits(ref.x, st.x));
      CHECK(ref.l == st.l);
      if (cand == &two) CHECK(st.columns.size() == 2);  // both in range: a real two-point fit
      if (ref.flags & flag::degenerate) ++degenerate;
    }
    CHECK(degenerate == 1);  // the two-candidate point fell back (and the next point's flags were cleared)
  }

  TEST_CASE("op: row_entries::merge sorts by column and sums repeats in call order, short and long rows") {
    // merge sorts short rows (≤ 64 entries) by insertion and longer ones by std::stable_sort: both must give
    // the entries sorted by column with repeated columns summed left to right in call order. The values
    // 1e16, 1, −1e16 make the sum order visible in the bits: (1e16 + 1) − 1e16 = 0 but (1e16 − 1e16) + 1 = 1.
    std::mt19937_64 rng(test_seed() + 43);
    MESSAGE("seed " << test_seed() + 43 << " (set MPSKIT_TEST_SEED to replay)");
    for (const std::size_t len : {std::size_t{0}, std::size_t{1}, std::size_t{12}, std::size_t{64},
                                  std::size_t{65}, std::size_t{300}}) {
      CAPTURE(len);
      const auto top = static_cast<index_t>(len / 3 + 1);  // columns 0..top, so most of them repeat
      const index_t i = top + 1;                            // the row: outside the drawn columns
      op::row_entries row(i);
      std::vector<std::pair<index_t, double>> calls;
      std::uniform_int_distribution<index_t> col(0, top);
      const double vals[3] = {1e16, 1.0, -1e16};
      double diag = 0.0;  // j == i is folded into the diagonal, in call order from 0
      for (std::size_t k = 0; k < len; ++k) {
        const index_t j = col(rng);
        const double a = vals[k % 3] * (1.0 + 0.125 * static_cast<double>(k % 5));
        calls.emplace_back(j, a);
        row.add(j, a);
        if (k % 7 == 3) {
          row.add(i, a);
          diag += a;
        }
      }
      REQUIRE(row.columns().size() == len);  // exactly len entries to merge: both sides of 64 are reached
      row.merge();
      // Reference: for each column in ascending order, its values summed in call order.
      std::vector<std::pair<index_t, double>> expected;
      for (index_t j = 0; j <= top; ++j) {
        bool seen = false;
        double sum = 0.0;
        for (const auto& [cj, a] : calls)
          if (cj == j) {
            sum = seen ? sum + a : a;
            seen = true;
          }
        if (seen) expected.emplace_back(j, sum);
      }
      REQUIRE(row.columns().size() == expected.size());
      for (std::size_t k = 0; k < expected.size(); ++k) {
        CHECK(row.columns()[k].first == expected[k].first);
        CHECK(mpskit::test::same_bits(row.columns()[k].second, expected[k].second));
      }
      CHECK(mpskit::test::same_bits(row.diagonal(), diag));
    }
  }

  // ======================================================================================================
  // Convergence for sin x cos y on jittered lattices
  // ======================================================================================================
  TEST_CASE_TEMPLATE("op: lsmps type A converges at order p + 1 − k for the k-th derivative", Op,
                     op::lsmps_a<2, 1>, op::lsmps_a<2, 2>, op::lsmps_a<2, 3>) {
    constexpr int P = Op::order;
    std::mt19937_64 rng(test_seed() + 11);
    MESSAGE("seed " << test_seed() + 11 << " (set MPSKIT_TEST_SEED to replay)");
    const auto ders = derivative_list<2, P>();
    // exact derivatives of sin x cos y
    auto exact = [](const vec<2>& p, const std::array<int, 3>& a) {
      auto dsin = [](double x, int k) {
        const double v[4] = {std::sin(x), std::cos(x), -std::sin(x), -std::cos(x)};
        return v[k % 4];
      };
      auto dcos = [](double y, int k) {
        const double v[4] = {std::cos(y), -std::sin(y), -std::cos(y), std::sin(y)};
        return v[k % 4];
      };
      return dsin(p[0], a[0]) * dcos(p[1], a[1]);
    };
    std::vector<double> hs;
    std::vector<std::array<double, 4>> rms;  // per derivative order k = 1..3
    const double box = 2.0;
    for (int m : {20, 30, 40}) {
      const double h = box / m;
      hs.push_back(h);
      const points<2> x = jittered_lattice<2>(m + 1, h, 0.1, rng);  // ±0.1 L
      const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
      Op A;
      A.compute(exec::seq{}, x, nl, op::uniform_size{h});
      Eigen::VectorXd phi(x.cols());
      for (index_t i = 0; i < x.cols(); ++i) phi[i] = std::sin(x(0, i)) * std::cos(x(1, i));
      const auto mask = interior_mask<2>(x, 0.0, box, 3.1 * h);  // particles ≥ R from the edge
      std::array<double, 4> s{0, 0, 0, 0};
      std::array<index_t, 4> c{0, 0, 0, 0};
      for (index_t i = 0; i < x.cols(); ++i) {
        if (!mask[static_cast<std::size_t>(i)]) continue;
        const auto d = A.derivatives(x, nl, i, phi);
        for (std::size_t k = 0; k < ders.size(); ++k) {
          const int deg = ders[k][0] + ders[k][1];
          const double e = d[static_cast<int>(k)] - exact(x.col(i), ders[k]);
          s[static_cast<std::size_t>(deg)] += e * e;
          ++c[static_cast<std::size_t>(deg)];
        }
      }
      for (int k = 1; k <= P; ++k)
        s[static_cast<std::size_t>(k)] =
            std::sqrt(s[static_cast<std::size_t>(k)] / double(c[static_cast<std::size_t>(k)]));
      rms.push_back(s);
    }
    for (int k = 1; k <= P; ++k) {
      std::vector<double> e;
      for (const auto& r : rms) e.push_back(r[static_cast<std::size_t>(k)]);
      const double slope = fitted_slope(hs, e);
      CAPTURE(k);
      CAPTURE(slope);
      MESSAGE("order " << P << " derivative order " << k << ": slope " << slope << " (rms " << e[0] << " → "
                       << e[2] << ")");
      CHECK(slope >= P + 1 - k - 0.3);  // issue 3 bound: p + 1 − k − 0.3
    }
  }

  TEST_CASE("op: lsmps type A converges in 3D (order 2, sin x cos y cos z)") {
    std::mt19937_64 rng(test_seed() + 12);
    MESSAGE("seed " << test_seed() + 12 << " (set MPSKIT_TEST_SEED to replay)");
    std::vector<double> hs, eg, el;
    const double box = 2.0;
    for (int m : {14, 18, 22}) {
      const double h = box / m;
      hs.push_back(h);
      const points<3> x = jittered_lattice<3>(m + 1, h, 0.1, rng);
      const search::neighbour_list<3> nl = list_for(x, 3.1 * h);
      op::lsmps_a<3, 2> A;
      A.compute(exec::seq{}, x, nl, op::uniform_size{h});
      Eigen::VectorXd phi(x.cols());
      for (index_t i = 0; i < x.cols(); ++i)
        phi[i] = std::sin(x(0, i)) * std::cos(x(1, i)) * std::cos(x(2, i));
      const auto mask = interior_mask<3>(x, 0.0, box, 3.1 * h);
      double sg = 0, sl = 0;
      index_t c = 0;
      for (index_t i = 0; i < x.cols(); ++i) {
        if (!mask[static_cast<std::size_t>(i)]) continue;
        const auto [g, l] = A.gradient_laplacian(x, nl, i, phi);
        const double X = x(0, i), Y = x(1, i), Z = x(2, i);
        const vec<3> ge(std::cos(X) * std::cos(Y) * std::cos(Z), -std::sin(X) * std::sin(Y) * std::cos(Z),
                        -std::sin(X) * std::cos(Y) * std::sin(Z));
        sg += (g - ge).squaredNorm() / 3.0;
        sl += std::pow(l + 3.0 * phi[i], 2);
        ++c;
      }
      eg.push_back(std::sqrt(sg / double(c)));
      el.push_back(std::sqrt(sl / double(c)));
    }
    const double s1 = fitted_slope(hs, eg), s2 = fitted_slope(hs, el);
    MESSAGE("3D order 2: gradient slope " << s1 << ", Laplacian slope " << s2);
    CHECK(s1 >= 2 + 1 - 1 - 0.3);  // issue 3 bound, k = 1
    CHECK(s2 >= 2 + 1 - 2 - 0.3);  // k = 2
  }

  TEST_CASE("op: lsmps compute is identical with exec::seq and exec::par") {
    std::mt19937_64 rng(test_seed() + 14);
    const double h = 0.1;
    const points<2> x = jittered_lattice<2>(30, h, 0.2, rng);
    const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
    op::lsmps_a<2, 2> A, B;
    A.compute(exec::seq{}, x, nl, op::uniform_size{h});
    B.compute(exec::par{}, x, nl, op::uniform_size{h});
    bool same = true;
    for (index_t i = 0; i < x.cols(); ++i) same = same && A.inverse_moments(i) == B.inverse_moments(i);
    CHECK(same);  // each particle writes only its own slot: bitwise, for any thread count
    CHECK(A.flags() == B.flags());
  }

  TEST_CASE_TEMPLATE("op: lsmps type B converges at order p + 1 − k at off-particle points", Op,
                     op::lsmps_b<2, 1>, op::lsmps_b<2, 2>, op::lsmps_b<2, 3>) {
    constexpr int P = Op::order;
    std::mt19937_64 rng(test_seed() + 13);
    MESSAGE("seed " << test_seed() + 13 << " (set MPSKIT_TEST_SEED to replay)");
    std::vector<double> hs;
    std::vector<std::array<double, 2>> rms;  // k = 0 (value), 1 (gradient)
    const double box = 2.0;
    std::uniform_real_distribution<double> U(0.6, 1.4);
    std::vector<vec<2>> q;
    for (int k = 0; k < 40; ++k) q.push_back(vec<2>(U(rng), U(rng)));
    for (int m : {20, 30, 40}) {
      const double h = box / m;
      hs.push_back(h);
      const points<2> x = jittered_lattice<2>(m + 1, h, 0.1, rng);
      Eigen::VectorXd phi(x.cols());
      for (index_t i = 0; i < x.cols(); ++i) phi[i] = std::sin(x(0, i)) * std::cos(x(1, i));
      std::vector<index_t> all(static_cast<std::size_t>(x.cols()));
      for (index_t j = 0; j < x.cols(); ++j) all[static_cast<std::size_t>(j)] = j;
      Op B;
      double s0 = 0, s1 = 0;
      for (const vec<2>& p : q) {
        const auto st = B.stencil(x, p, h, all, op::uniform_size{h});
        const auto v = st.apply(phi);
        s0 += std::pow(v[0] - std::sin(p[0]) * std::cos(p[1]), 2);
        s1 += std::pow(v[1] - std::cos(p[0]) * std::cos(p[1]), 2) +
              std::pow(v[2] + std::sin(p[0]) * std::sin(p[1]), 2);
      }
      rms.push_back({std::sqrt(s0 / double(q.size())), std::sqrt(s1 / (2.0 * double(q.size())))});
    }
    for (int k = 0; k <= 1; ++k) {
      std::vector<double> e;
      for (const auto& r : rms) e.push_back(r[static_cast<std::size_t>(k)]);
      const double slope = fitted_slope(hs, e);
      CAPTURE(k);
      CAPTURE(slope);
      CHECK(slope >= P + 1 - k - 0.3);  // issue 3 bound
    }
  }

  // ======================================================================================================
  // Neumann constraint (Tanaka eqs. 85–87) and the row-contribution hook
  // ======================================================================================================
  namespace {
  /// A one-sided cloud: particle 0 on the wall y = 0 with normal +y (towards the fluid), neighbours in y ≥ 0.
  points<2> one_sided_cloud(std::mt19937_64& rng, double h) {
    std::vector<vec<2>> pts{vec<2>(0.0, 0.0)};
    std::uniform_real_distribution<double> U(-0.15, 0.15);
    for (int b = 0; b <= 3; ++b)
      for (int a = -3; a <= 3; ++a) {
        if (a == 0 && b == 0) continue;
        vec<2> p((a + U(rng)) * h, (b + (b > 0 ? U(rng) : 0.0)) * h);
        if (p.norm() < 3.0 * h) pts.push_back(p);
      }
    points<2> x(2, static_cast<index_t>(pts.size()));
    for (std::size_t k = 0; k < pts.size(); ++k) x.col(static_cast<index_t>(k)) = pts[k];
    return x;
  }

  }  // namespace

  TEST_CASE("op: neumann-constrained lsmps is exact for a quadratic with exact ∂f/∂n on a one-sided cloud") {
    std::mt19937_64 rng(test_seed() + 17);
    MESSAGE("seed " << test_seed() + 17 << " (set MPSKIT_TEST_SEED to replay)");
    const double h = 0.1;
    const points<2> x = one_sided_cloud(rng, h);
    const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
    points<2> n = points<2>::Zero(2, x.cols());
    n.row(1).setOnes();  // wall normal +y, towards the fluid
    std::vector<std::uint8_t> mark(static_cast<std::size_t>(x.cols()), 0);
    mark[0] = 1;
    const polynomial<2> f = random_polynomial<2>(2, rng);
    const Eigen::VectorXd phi = f.sample(x);
    Eigen::VectorXd dfdn = Eigen::VectorXd::Zero(x.cols());
    dfdn[0] = f.d(x.col(0), {0, 1, 0});  // exact ∂f/∂n = ∂f/∂y at the wall particle

    op::lsmps_a<2, 2> A;
    A.compute(exec::seq{}, x, nl, op::uniform_size{h}, op::neumann_constraint<2>{&n, &mark});
    CHECK(A.flags()[0] == 0);
    const auto d = A.derivatives(x, nl, 0, phi, op::all_neighbours{}, &dfdn);
    const auto ders = derivative_list<2, 2>();
    double err = 0.0;
    for (std::size_t k = 0; k < ders.size(); ++k)
      err = std::max(err, std::abs(d[static_cast<int>(k)] - f.d(x.col(0), ders[k])));
    CHECK(err < 1e-9 * 100.0);  // exact (|coefficients| ≤ 10, derivatives ≤ ~40): 1e-9 relative

    // The literal reading of eqs. 86–87 (p(−n) with its quadratic entries) has an O(L²) truncation in the
    // constraint row, so the same quadratic is NOT reproduced: the reading matters (docs/operators.md).
    op::lsmps_a<2, 2> Alit;
    Alit.compute(exec::seq{}, x, nl, op::uniform_size{h},
                 op::neumann_constraint<2>{&n, &mark, op::neumann_form::literal});
    const auto dl = Alit.derivatives(x, nl, 0, phi, op::all_neighbours{}, &dfdn);
    double err_lit = 0.0;
    for (std::size_t k = 0; k < ders.size(); ++k)
      err_lit = std::max(err_lit, std::abs(dl[static_cast<int>(k)] - f.d(x.col(0), ders[k])));
    CHECK(err_lit > 1e-6);

    // The row-contribution hook gives the same Laplacian and normal-derivative rows as the application.
    for (const op::lsmps_a<2, 2>::vector& sel : {op::lsmps_a<2, 2>::laplacian_selector(),
                                                 op::lsmps_a<2, 2>::directional_selector(vec<2>(0.0, 1.0))}) {
      op::row_entries row(0);
      A.build_row(x, nl, 0, sel, op::all_neighbours{}, row, op::neumann_rows{&dfdn});
      row.merge();
      const double from_row = row.apply(phi);
      CHECK(from_row == doctest::Approx(sel.dot(d)).epsilon(1e-12));  // same arithmetic up to summation order
      op::row_value rv(phi, 0);
      A.build_row(x, nl, 0, sel, op::all_neighbours{}, rv, op::neumann_rows{&dfdn});
      CHECK(rv.value() == doctest::Approx(from_row).epsilon(1e-12));
      CHECK(row.constant() != 0.0);  // the hook's constant is there (∂f/∂n ≠ 0 for this seed's f)
    }
  }

  TEST_CASE_TEMPLATE(
      "op: neumann points: wall points carrying exact ∂f/∂n reproduce a quadratic beside a wall", Dim,
      std::integral_constant<int, 2>, std::integral_constant<int, 3>) {
    // The wall y = 0 sampled at spacing h (normal +y, toward the fluid), a jittered fluid lattice above it
    // from y = 0.3 h. Every fluid particle's fit (type A, order 2) takes the wall points as the equations
    // n·∇f(x_k) = q_k (op::neumann_points, the scheme's copy_row = neumann_points): for a quadratic f with
    // exact q_k every derivative is exact to rounding, and the wall points' values are never read (set to
    // 1e6 here). The row path (build_row: the wall data in the constant) agrees with the application.
    constexpr int D = Dim::value;
    using A_t = op::lsmps_a<D, 2>;
    std::mt19937_64 rng(test_seed() + 29);
    MESSAGE("seed " << test_seed() + 29 << " (set MPSKIT_TEST_SEED to replay)");
    const double h = 0.1;
    const int m = 6;
    std::uniform_real_distribution<double> J(-0.2 * h, 0.2 * h);
    std::vector<vec<D>> pts;
    std::vector<std::uint8_t> mark;
    const int mz = D == 3 ? m : 1;
    for (int k = 0; k < mz; ++k)
      for (int i = 0; i < m; ++i) {  // wall points
        vec<D> q = vec<D>::Zero();
        q[0] = i * h;
        if constexpr (D == 3) q[2] = k * h;
        pts.push_back(q);
        mark.push_back(1);
      }
    for (int k = 0; k < mz; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < m; ++i) {  // fluid
          vec<D> q;
          q[0] = i * h + J(rng);
          q[1] = (0.5 + j) * h + J(rng);
          if constexpr (D == 3) q[2] = k * h + J(rng);
          pts.push_back(q);
          mark.push_back(0);
        }
    points<D> x(D, static_cast<index_t>(pts.size()));
    for (std::size_t k = 0; k < pts.size(); ++k) x.col(static_cast<index_t>(k)) = pts[k];
    const search::neighbour_list<D> nl = list_for(x, 3.1 * h);
    points<D> n = points<D>::Zero(D, x.cols());
    n.row(1).setOnes();
    const polynomial<D> f = random_polynomial<D>(2, rng);
    Eigen::VectorXd phi = f.sample(x), dfdn = Eigen::VectorXd::Zero(x.cols());
    for (index_t k = 0; k < x.cols(); ++k)
      if (mark[static_cast<std::size_t>(k)]) {
        dfdn[k] = f.d(x.col(k), {0, 1, 0});
        phi[k] = 1e6;  // never read as a value
      }
    A_t A;
    A.compute(exec::seq{}, x, nl, op::uniform_size{h}, op::neumann_points<D>{&n, &mark, &dfdn});
    const auto ders = derivative_list<D, 2>();
    double err = 0.0, err_row = 0.0, err_plain = 0.0;
    A_t plain;  // control: the same cloud with the wall points read as values (1e6) is far off
    plain.compute(exec::seq{}, x, nl, op::uniform_size{h});
    for (index_t i = 0; i < x.cols(); ++i) {
      if (mark[static_cast<std::size_t>(i)]) continue;
      CHECK(A.flags()[static_cast<std::size_t>(i)] == 0);
      const auto d = A.derivatives(x, nl, i, phi);
      for (std::size_t k = 0; k < ders.size(); ++k) {
        err = std::max(err, std::abs(d[static_cast<int>(k)] - f.d(x.col(i), ders[k])));
        err_plain = std::max(err_plain, std::abs(plain.derivatives(x, nl, i, phi)[static_cast<int>(k)] -
                                                 f.d(x.col(i), ders[k])));
      }
      const vec<D> g = A.gradient(x, nl, i, phi);
      for (int a = 0; a < D; ++a) {
        std::array<int, 3> e{0, 0, 0};
        e[static_cast<std::size_t>(a)] = 1;
        err = std::max(err, std::abs(g[a] - f.d(x.col(i), e)));
      }
      op::row_entries row(i);
      A.build_row(x, nl, i, A_t::laplacian_selector(), op::all_neighbours{}, row);
      row.merge();
      double lap = 0.0;
      for (int a = 0; a < D; ++a) {
        std::array<int, 3> e{0, 0, 0};
        e[static_cast<std::size_t>(a)] = 2;
        lap += f.d(x.col(i), e);
      }
      err_row = std::max(err_row, std::abs(row.apply(phi) - lap));
    }
    // The fused sweep (gradients, laplacians of D fields) adds the wall points' term to every column as the
    // scalar calls do: equal to the bit.
    std::array<Eigen::VectorXd, D> comps;
    for (int a = 0; a < D; ++a) comps[static_cast<std::size_t>(a)] = (a + 1.0) * phi;
    long differ = 0;
    for (index_t i = 0; i < x.cols(); ++i) {
      if (mark[static_cast<std::size_t>(i)]) continue;
      const mat<D> G = A.gradients(x, nl, i, comps);
      const vec<D> l = A.laplacians(x, nl, i, comps);
      for (int a = 0; a < D; ++a) {
        const Eigen::VectorXd& ca = comps[static_cast<std::size_t>(a)];
        differ += (G.row(a).transpose().array() != A.gradient(x, nl, i, ca).array()).count();
        differ += l[a] != A.laplacian(x, nl, i, ca);
      }
    }
    CHECK(differ == 0);
    MESSAGE(D << "D: max derivative error " << err << " (row " << err_row
              << "; values read as values: " << err_plain << ")");
    CHECK(err < 1e-7);      // exact up to rounding (|coefficients| ≤ 10, h = 0.1: second derivatives ~ 20)
    CHECK(err_row < 1e-7);  // the row's constant carries the wall data
    CHECK(err_plain > 1.0);  // so a value read at a wall point would show
    // Bad input: the vector-field calls are not defined with Neumann points and say so.
    CHECK_THROWS_AS(A.divergence(x, nl, static_cast<index_t>(x.cols() - 1), x), mpskit::error);
    CHECK_THROWS_AS(
        A.compute(exec::seq{}, x, nl, op::uniform_size{h}, op::neumann_points<D>{&n, &mark, nullptr}),
        mpskit::error);
  }

  TEST_CASE("op: the neumann constraint repairs a wall particle whose neighbours are all on the wall") {
    // Order 1, neighbours only on y = 0: M is singular in y without the constraint, regular with it.
    const double h = 0.1;
    points<2> x(2, 7);
    for (index_t k = 0; k < 7; ++k) x.col(k) = vec<2>((double(k) - 3.0) * h, 0.0);
    const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
    points<2> n = points<2>::Zero(2, 7);
    n.row(1).setOnes();
    std::vector<std::uint8_t> mark(7, 1);
    Eigen::VectorXd phi(7), dfdn = Eigen::VectorXd::Constant(7, -2.0);
    for (index_t k = 0; k < 7; ++k) phi[k] = 3.0 * x(0, k) - 2.0 * x(1, k) + 1.0;  // ∂f/∂y = −2
    op::lsmps_a<2, 1> plain, con;
    plain.compute(exec::seq{}, x, nl, op::uniform_size{h});
    CHECK(plain.degenerate_count() == 7);
    con.compute(exec::seq{}, x, nl, op::uniform_size{h}, op::neumann_constraint<2>{&n, &mark});
    CHECK(con.degenerate_count() == 0);
    for (index_t i = 0; i < 7; ++i) {
      const auto d = con.derivatives(x, nl, i, phi, op::all_neighbours{}, &dfdn);
      CHECK(d[0] == doctest::Approx(3.0).epsilon(1e-12));  // exact for a linear field
      CHECK(d[1] == doctest::Approx(-2.0).epsilon(1e-12));
    }
  }

  // ======================================================================================================
  // Degenerate neighbourhoods: flagged, documented fallback, never NaN
  // ======================================================================================================
  namespace {
  template <class Op, int D>
  bool all_finite(const Op& A, const points<D>& x, const search::neighbour_list<D>& nl,
                  const Eigen::VectorXd& phi) {
    for (index_t i = 0; i < x.cols(); ++i)
      if (!A.derivatives(x, nl, i, phi).allFinite()) return false;
    return true;
  }
  }  // namespace

  TEST_CASE("op: degenerate — too few neighbours falls back to a lower order") {
    // Particle 0 with 3 neighbours: order 2 needs 5 independent monomials; order 1 needs 2.
    const double h = 0.1;
    points<2> x(2, 4);
    x << 0.0, 0.1, 0.0, -0.1, 0.0, 0.0, 0.1, -0.05;
    const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
    op::lsmps_a<2, 2> A;
    A.compute(exec::seq{}, x, nl, op::uniform_size{h});
    CHECK((A.flags()[0] & flag::degenerate) != 0);
    CHECK(A.order_used(0) == 1);
    Eigen::VectorXd phi(4);
    for (index_t k = 0; k < 4; ++k) phi[k] = 2.0 * x(0, k) + 5.0 * x(1, k);
    const auto d = A.derivatives(x, nl, 0, phi);
    CHECK(d[0] == doctest::Approx(2.0).epsilon(1e-12));  // order 1 is exact for linear fields
    CHECK(d[1] == doctest::Approx(5.0).epsilon(1e-12));
    CHECK(d[2] == 0.0);  // the dropped second derivatives are reported as 0
    CHECK(all_finite(A, x, nl, phi));
  }

  TEST_CASE("op: degenerate — collinear points (2D) and coplanar points (3D)") {
    const double h = 0.1;
    {
      points<2> x(2, 7);
      // y = x
      for (index_t k = 0; k < 7; ++k) x.col(k) = vec<2>((double(k) - 3.0) * h, (double(k) - 3.0) * h);
      const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
      op::lsmps_a<2, 2> A;
      A.compute(exec::seq{}, x, nl, op::uniform_size{h});
      CHECK(A.degenerate_count() == 7);
      CHECK(A.order_used(3) == 0);  // order 1 fails too → regularised order 1
      Eigen::VectorXd phi(7);
      for (index_t k = 0; k < 7; ++k) phi[k] = x(0, k) + x(1, k);
      const auto d = A.derivatives(x, nl, 3, phi);
      // Along the line the regularised fit recovers the directional derivative (1,1)/√2 · ∇φ = √2 up to the
      // relative shift δ = 1e-6 of the regularisation: tolerance 1e-5.
      CHECK((d[0] + d[1]) / std::sqrt(2.0) == doctest::Approx(std::sqrt(2.0)).epsilon(1e-5));
      CHECK(all_finite(A, x, nl, phi));
    }
    {
      std::mt19937_64 rng(test_seed() + 19);
      points<3> x = jittered_lattice<3>(5, h, 0.2, rng);
      x.row(2).setZero();  // every particle on z = 0
      const search::neighbour_list<3> nl = list_for(x, 3.1 * h);
      op::lsmps_a<3, 2> A;
      A.compute(exec::seq{}, x, nl, op::uniform_size{h});
      CHECK(A.degenerate_count() == x.cols());
      Eigen::VectorXd phi = x.row(0).transpose();
      CHECK(all_finite(A, x, nl, phi));
    }
  }

  TEST_CASE("op: degenerate — an isolated particle gets zero derivatives, flagged") {
    points<2> x(2, 3);
    x << 0.0, 10.0, 10.1, 0.0, 0.0, 0.0;
    const search::neighbour_list<2> nl = list_for(x, 0.31);
    op::lsmps_a<2, 3> A;
    A.compute(exec::seq{}, x, nl, op::uniform_size{0.1});
    CHECK((A.flags()[0] & flag::degenerate) != 0);
    CHECK(A.order_used(0) == 0);
    const Eigen::VectorXd phi = Eigen::VectorXd::Ones(3);
    CHECK(A.derivatives(x, nl, 0, phi).isZero(0.0));
    // type B far from every particle: nothing to fit, zero, flagged
    op::lsmps_b<2, 2> B;
    const std::vector<index_t> all{0, 1, 2};
    const auto st = B.stencil(x, vec<2>(5.0, 5.0), 0.1, all, op::uniform_size{0.1});
    CHECK((st.flags & flag::degenerate) != 0);
    CHECK(st.apply(phi).isZero(0.0));
    // type B with one particle in reach: order 0, the weighted average (the particle's value)
    const auto st1 = B.stencil(x, vec<2>(0.05, 0.0), 0.1, all, op::uniform_size{0.1});
    CHECK(st1.order_used == 0);
    CHECK(st1.value(phi) == doctest::Approx(1.0).epsilon(1e-14));
  }

  TEST_CASE("op: degenerate — ill-conditioned moments (nearly collinear) are flagged, finite") {
    const double h = 0.1;
    std::mt19937_64 rng(test_seed() + 23);
    MESSAGE("seed " << test_seed() + 23 << " (set MPSKIT_TEST_SEED to replay)");
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    points<2> x(2, 9);
    for (index_t k = 0; k < 9; ++k) x.col(k) = vec<2>((double(k) - 4.0) * 0.7 * h, 1e-7 * h * U(rng));
    const search::neighbour_list<2> nl = list_for(x, 3.1 * h);
    op::lsmps_a<2, 2> A;  // cond₁ test: the y column scales like 1e-7, y² like 1e-14 → cond ≫ 1e8 → fails
    A.compute(exec::seq{}, x, nl, op::uniform_size{h});
    CHECK(A.degenerate_count() == 9);
    Eigen::VectorXd phi(9);
    for (index_t k = 0; k < 9; ++k) phi[k] = std::sin(x(0, k) * 10.0) + 1e3 * x(1, k);
    CHECK(all_finite(A, x, nl, phi));
    // the regularise fallback also flags and stays finite
    op::lsmps_params p;
    p.fallback = op::degenerate_fallback::regularise;
    op::lsmps_a<2, 2> R(p);
    R.compute(exec::seq{}, x, nl, op::uniform_size{h});
    CHECK(R.degenerate_count() == 9);
    CHECK(all_finite(R, x, nl, phi));
  }

  // ======================================================================================================
  // Stencils agree with application; bad input
  // ======================================================================================================
  TEST_CASE("op: lsmps stencils, rows and application agree; rows vanish on constants") {
    std::mt19937_64 rng(test_seed() + 29);
    const double h = 0.1;
    const points<3> x = jittered_lattice<3>(6, h, 0.2, rng);
    const search::neighbour_list<3> nl = list_for(x, 3.1 * h);
    op::lsmps_a<3, 2> A;
    A.compute(exec::seq{}, x, nl, op::uniform_size{h});
    const polynomial<3> f = random_polynomial<3>(3, rng);
    const Eigen::VectorXd phi = f.sample(x);
    points<3> u(3, x.cols());
    for (index_t i = 0; i < x.cols(); ++i) u.col(i) = vec<3>(phi[i], 2.0 * phi[i], -phi[i]);
    for (index_t i : {0, 50, 107}) {
      vec<3> g = vec<3>::Zero();
      double lap = 0.0, sum_a = 0.0;
      A.for_each_gradient_weight(x, nl, i, op::all_neighbours{},
                                 [&](index_t j, const vec<3>& c) { g += c * (phi[j] - phi[i]); });
      A.for_each_laplacian_weight(x, nl, i, op::all_neighbours{}, [&](index_t j, double a) {
        lap += a * (phi[j] - phi[i]);
        sum_a += a;
      });
      const auto [g2, lap2] = A.gradient_laplacian(x, nl, i, phi);
      CHECK((g - g2).norm() <= 1e-11 * g2.norm());  // same sums in another association
      CHECK(lap == doctest::Approx(lap2).epsilon(1e-11));
      CHECK(A.laplacian(x, nl, i, phi) == doctest::Approx(lap2).epsilon(1e-11));
      CHECK(A.divergence(x, nl, i, u) == doctest::Approx(g2[0] + 2.0 * g2[1] - g2[2]).epsilon(1e-11));
      op::row_entries row(i);
      A.build_row(x, nl, i, A.laplacian_selector(), op::all_neighbours{}, row);
      row.merge();
      CHECK(row.apply(phi) == doctest::Approx(lap2).epsilon(1e-11));
      CHECK(std::abs(row.apply(Eigen::VectorXd::Constant(x.cols(), 7.0))) <= 1e-12 * std::abs(sum_a) * 7.0);
    }
  }

  TEST_CASE("op: lsmps bad input is refused with the value named") {
    op::lsmps_params p;
    p.re_ratio = -1.0;
    CHECK_THROWS_WITH_AS((op::lsmps_a<2, 2>{p}), doctest::Contains("re_ratio = -1"), mpskit::error);
    p = {};
    p.max_condition = 0.5;
    CHECK_THROWS_WITH_AS((op::lsmps_b<2, 2>{p}), doctest::Contains("max_condition = 0.5"), mpskit::error);
    points<2> x(2, 3);
    x << 0.0, 0.1, 0.2, 0.0, 0.0, 0.1;
    const search::neighbour_list<2> nl = list_for(x, 0.31);
    op::lsmps_a<2, 2> A;
    Eigen::VectorXd L(3);
    L << 0.1, -0.1, 0.1;
    CHECK_THROWS_WITH_AS(A.compute(exec::seq{}, x, nl, op::per_particle_size{&L}),
                         doctest::Contains("diameter of particle 1"), mpskit::error);
    Eigen::VectorXd L2 = Eigen::VectorXd::Constant(2, 0.1);
    CHECK_THROWS_WITH_AS(A.compute(exec::seq{}, x, nl, op::per_particle_size{&L2}),
                         doctest::Contains("2 diameters"), mpskit::error);
    CHECK_THROWS_WITH_AS(A.compute(exec::seq{}, x, nl, op::uniform_size{0.0}), doctest::Contains("L = 0"),
                         mpskit::error);
    CHECK_THROWS_AS(A.compute(exec::seq{}, x, nl, op::uniform_size{0.1}, op::neumann_constraint<2>{}),
                    mpskit::error);
    op::lsmps_b<2, 2> B;
    const std::vector<index_t> all{0, 1, 2};
    CHECK_THROWS_WITH_AS(B.stencil(x, vec<2>::Zero(), -1.0, all, op::uniform_size{0.1}),
                         doctest::Contains("l = -1"), mpskit::error);
  }

  // ======================================================================================================
  // Classic MPS: exactness where theory gives it, per-particle n0/λ, corrected matrix, interface forms
  // ======================================================================================================
  TEST_CASE(
      "op: mps gradient is exact for linear fields and the Laplacian for quadratics on a lattice interior") {
    const double l0 = 0.1;
    std::mt19937_64 rng(test_seed() + 31);
    for (auto norm : {op::mps_normalisation::reference_lattice, op::mps_normalisation::per_particle}) {
      points<2> x = jittered_lattice<2>(15, l0, 0.0, rng);  // exact lattice
      const search::neighbour_list<2> nl = list_for(x, 3.1 * l0);
      op::mps_params p{l0};
      p.normalisation = norm;
      op::mps<2> M(p);
      Eigen::VectorXd lin(x.cols()), quad(x.cols());
      for (index_t i = 0; i < x.cols(); ++i) {
        lin[i] = 3.0 * x(0, i) - 2.0 * x(1, i);
        quad[i] = 1.5 * x(0, i) * x(0, i) + x(0, i) * x(1, i) - 0.5 * x(1, i) * x(1, i) + x(0, i);
      }
      const auto mask = interior_mask<2>(x, 0.0, 14 * l0, 3.1 * l0);  // full supports only
      for (index_t i = 0; i < x.cols(); ++i) {
        if (!mask[static_cast<std::size_t>(i)]) continue;
        // Σ w x xᵀ / r² = n0/d I on a full lattice (symmetry): eq. 9 is exact for linear fields
        const vec<2> g = M.gradient(x, nl, i, lin);
        CHECK(g[0] == doctest::Approx(3.0).epsilon(1e-12));
        CHECK(g[1] == doctest::Approx(-2.0).epsilon(1e-12));
        // Σ w x_a x_b = δ_ab n0 λ0/d on a full lattice: eq. 10 is exact for quadratics (∇² = 3 − 1 = 2)
        CHECK(M.laplacian(x, nl, i, quad) == doctest::Approx(2.0).epsilon(1e-12));
        CHECK(M.lambda(x, nl, i) == doctest::Approx(M.lambda0()).epsilon(1e-12));
      }
    }
  }

  TEST_CASE(
      "op: mps corrected-matrix gradient is exact for linear fields on a jittered cloud, edges included") {
    std::mt19937_64 rng(test_seed() + 37);
    MESSAGE("seed " << test_seed() + 37 << " (set MPSKIT_TEST_SEED to replay)");
    const double l0 = 0.1;
    const points<3> x = jittered_lattice<3>(6, l0, 0.2, rng);
    const search::neighbour_list<3> nl = list_for(x, 3.1 * l0);
    op::mps<3> M(op::mps_params{l0});
    Eigen::VectorXd lin(x.cols());
    for (index_t i = 0; i < x.cols(); ++i) lin[i] = x(0, i) - 4.0 * x(1, i) + 2.0 * x(2, i);
    const Eigen::VectorXd shifted = lin.array() + 5.0;
    for (index_t i = 0; i < x.cols(); ++i) {
      flag::type fl = 0;
      const vec<3> g = M.corrected_gradient(x, nl, i, lin, op::all_neighbours{}, &fl);
      CHECK(fl == 0);
      CHECK((g - vec<3>(1.0, -4.0, 2.0)).norm() < 1e-11);  // C_i⁻¹ Σ x xᵀ w/r² = I exactly (eq. 29)
      // with p̂_i = min the corrected form is no longer exact; it must still be finite and differ by
      // C_i⁻¹ Σ (φ_i − p̂_i) x w / r²
      CHECK(M.corrected_min_pressure_gradient(x, nl, i, shifted).allFinite());
    }
    // degenerate C_i (collinear neighbours): flagged, falls back to the plain eq. 9 coefficient
    points<2> y(2, 5);
    for (index_t k = 0; k < 5; ++k) y.col(k) = vec<2>((double(k) - 2.0) * l0, 0.0);
    const search::neighbour_list<2> nly = list_for(y, 2.1 * l0);
    op::mps<2> M2(op::mps_params{l0});
    flag::type fl = 0;
    const mat<2> C = M2.correction_matrix(y, nly, 2, op::all_neighbours{}, &fl);
    CHECK((fl & flag::degenerate) != 0);
    CHECK(C.allFinite());
    CHECK(C(0, 0) == doctest::Approx(2.0 / M2.n0_small()).epsilon(1e-15));
  }

  TEST_CASE("op: mps with per-particle sizes equal to l0 matches the single-resolution operators") {
    std::mt19937_64 rng(test_seed() + 41);
    const double l0 = 0.1;
    const points<2> x = jittered_lattice<2>(12, l0, 0.2, rng);
    const Eigen::VectorXd L = Eigen::VectorXd::Constant(x.cols(), l0);
    const search::neighbour_list<2> nl = list_for(x, 3.1 * l0);
    op::mps<2> U(op::mps_params{l0}), S(op::mps_params{l0, 2.1, 3.1, search::radius_rule::pair_mean});
    S.set_sizes(&L);
    Eigen::VectorXd phi(x.cols());
    for (index_t i = 0; i < x.cols(); ++i) phi[i] = std::sin(3.0 * x(0, i)) + x(1, i) * x(1, i);
    for (index_t i = 0; i < x.cols(); i += 7) {
      // R_ij = sqrt((ratio L)²) may differ from ratio·l0 in the last bit: 1e-13
      CHECK(S.laplacian(x, nl, i, phi) == doctest::Approx(U.laplacian(x, nl, i, phi)).epsilon(1e-13));
      CHECK((S.gradient(x, nl, i, phi) - U.gradient(x, nl, i, phi)).norm() <=
            1e-13 * (1.0 + U.gradient(x, nl, i, phi).norm()));
      // equal sizes: every mass factor is 1, so the interface forms equal the plain ones
      CHECK(S.mass_factor(i, (i + 1) % x.cols()) == doctest::Approx(1.0).epsilon(1e-15));
      CHECK(S.mass_weighted_laplacian(x, nl, i, phi) ==
            doctest::Approx(U.laplacian(x, nl, i, phi)).epsilon(1e-13));
    }
  }

  TEST_CASE(
      "op: mps mass-weighted interface forms conserve momentum across a size jump (Tang & Wan eqs. 18–20)") {
    const block B = tanaka_block(2.0);
    const search::neighbour_list<2> nl = list_for(B.x, B.L, 3.1);
    op::mps_params p{1.0};
    p.rule = search::radius_rule::pair_mean;  // symmetric w_ij (Tang & Wan eqs. 16–17)
    op::mps<2> M(p);
    M.set_sizes(&B.L);
    std::mt19937_64 rng(test_seed() + 43);
    MESSAGE("seed " << test_seed() + 43 << " (set MPSKIT_TEST_SEED to replay)");
    std::uniform_real_distribution<double> U(0.0, 1.0);
    Eigen::VectorXd P(B.x.cols()), phi(B.x.cols());
    for (index_t i = 0; i < B.x.cols(); ++i) {
      P[i] = U(rng);
      phi[i] = U(rng);
    }
    vec<2> F = vec<2>::Zero(), Fabs = vec<2>::Zero();
    double V = 0.0, Vabs = 0.0;
    for (index_t i = 0; i < B.x.cols(); ++i) {
      const double mi = B.L[i] * B.L[i];
      const vec<2> g = M.mass_weighted_gradient(B.x, nl, i, P);
      F += mi * g;
      Fabs += mi * g.cwiseAbs();
      const double l = M.mass_weighted_laplacian(B.x, nl, i, phi);
      V += mi * l;
      Vabs += mi * std::abs(l);
    }
    // m_i A_{j→i} is symmetric and (P_i + P_j) x_ij antisymmetric: Σ m_i ⟨∇P⟩_i = 0 up to rounding.
    CHECK(F.norm() <= 1e-12 * Fabs.norm());
    // m_i a_ij = m_j a_ji (eq. 20): Σ m_i ⟨∇²φ⟩_i = 0 up to rounding.
    CHECK(std::abs(V) <= 1e-12 * Vabs);
    // the conservative form of eq. 5 without A_{j→i} does not conserve across the jump (that is why eq. 18
    // exists). (In 2D with λ0 ∝ L² and m ∝ L² eq. 20 reduces to eq. 10 exactly, so no such check there.)
    vec<2> Fp = vec<2>::Zero();
    for (index_t i = 0; i < B.x.cols(); ++i) {
      vec<2> g = vec<2>::Zero();
      M.for_each_gradient_weight(B.x, nl, i, op::all_neighbours{},
                                 [&](index_t j, const vec<2>& c) { g += c * (P[j] + P[i]); });
      Fp += B.L[i] * B.L[i] * g;
    }
    CHECK(Fp.norm() > 1e-6 * Fabs.norm());
  }

  TEST_CASE("op: mps laplacian rows and the hook: a virtual neighbour mapped onto an existing column") {
    std::mt19937_64 rng(test_seed() + 47);
    const double l0 = 0.1;
    const points<2> x = jittered_lattice<2>(8, l0, 0.2, rng);
    const search::neighbour_list<2> nl = list_for(x, 3.1 * l0);
    op::mps<2> M(op::mps_params{l0});
    Eigen::VectorXd phi(x.cols());
    for (index_t i = 0; i < x.cols(); ++i) phi[i] = std::cos(2.0 * x(0, i)) * x(1, i);
    const index_t i = 9;
    op::row_entries plain(i);
    M.build_laplacian_row(x, nl, i, op::all_neighbours{}, plain);
    CHECK(plain.apply(phi) == doctest::Approx(M.laplacian(x, nl, i, phi)).epsilon(1e-13));
    // An ERP-like hook: a mirror neighbour at displacement d whose value is φ_k (column k) plus 0.5.
    const vec<2> d(0.0, -1.2 * l0);
    const index_t k = 17;
    auto hook = [&](index_t row_i, const op::mps<2>::row_view& row, auto& b) {
      const double a = row.weight(d);
      b.add(k, a);
      b.add_diagonal(-a);
      b.add_constant(0.5 * a);
      CHECK(row_i == i);
    };
    op::row_entries with(i);
    M.build_laplacian_row(x, nl, i, op::all_neighbours{}, with, hook);
    with.merge();
    const double a =
        op::mps<2>::row_view{&M, i, 2.0 * 2 / (M.lambda0() * M.n0_large()), M.re_large()}.weight(d);
    CHECK(a > 0.0);
    CHECK(with.apply(phi) ==
          doctest::Approx(M.laplacian(x, nl, i, phi) + a * (phi[k] + 0.5 - phi[i])).epsilon(1e-13));
  }
}
