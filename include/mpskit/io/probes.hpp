#pragma once
/// \file io/probes.hpp
/// \brief Probes: values at points interpolated from particles (LSMPS type B of first order, exact for
/// linear fields, or kernel/Shepard interpolation, exact for constants) written as CSV time series every
/// n-th step; the surge-front position; the largest connected body (to keep spray out of a front); integrals
/// (volume, mass, kinetic and potential energy).
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <sstream>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/union_find.hpp"
#include "mpskit/io/concepts.hpp"
#include "mpskit/io/csv.hpp"
#include "mpskit/io/detail/type_names.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/search/domain.hpp"

namespace mpskit::io {

/// A set of particle kinds as bits (1 << kind).
using kind_mask = std::uint32_t;
/// The mask of one kind.
constexpr kind_mask mask_of(kind k) { return kind_mask{1} << static_cast<unsigned>(k); }
/// True when kind k is in mask m.
constexpr bool in_mask(kind_mask m, kind k) { return (m & mask_of(k)) != 0; }

/// \brief A point interpolation: weights c_k on candidate particles j_k (all with |x_j − q| < re) such
/// that φ(q) ≈ Σ_k c_k φ_{j_k}; returns false when the neighbourhood cannot support it (too few or
/// degenerate neighbours). `description` names the method in output headers.
template <class I, int D>
concept PointInterpolation = requires(const I& in, const points<D>& x, const vec<D>& q, double re,
                                      std::span<const index_t> cand, std::vector<double>& c) {
  { in.weights(x, q, re, cand, c) } -> std::same_as<bool>;
  { I::description } -> std::convertible_to<std::string_view>;
};

/// \brief LSMPS type B of first order at a point (Tamai & Koshizuka 2014; Tanaka 2018 eqs. 47–52 with
/// the polynomial basis truncated to p̂(d) = [1, d/re]): M = Σ_j w_j p̂_j p̂_jᵀ, φ(q) = e₀ᵀ M⁻¹ Σ_j w_j p̂_j
/// φ_j, so c_j = w_j p̂_jᵀ M⁻¹ e₀ (M is symmetric). Exact for fields linear in x whenever M is regular.
/// Scaling d by re (instead of the particle diameter) changes only the conditioning, not the value.
template <int D, Kernel K = kernel::quadratic>
class lsmps_b1_interpolation final {
  static_assert(K::finite_at_zero, "mpskit: a probe on top of a particle needs a kernel finite at r = 0");

 public:
  static constexpr std::string_view description = "LSMPS type B, first order (exact for linear fields)";
  /// Moment matrices with a reciprocal condition estimate below this are refused (value NaN).
  double min_rcond = 1e-10;

  /// Weights of the particles `cand` for the value at q.
  bool weights(const points<D>& x, const vec<D>& q, double re, std::span<const index_t> cand,
               std::vector<double>& c) const {
    using vecp = Eigen::Matrix<double, D + 1, 1>;
    using matp = Eigen::Matrix<double, D + 1, D + 1>;
    c.assign(cand.size(), 0.0);
    if (cand.size() < static_cast<std::size_t>(D + 1)) return false;
    matp M = matp::Zero();
    std::vector<vecp> p(cand.size());
    for (std::size_t k = 0; k < cand.size(); ++k) {
      const vec<D> d = x.col(cand[k]) - q;
      p[k](0) = 1.0;
      p[k].template tail<D>() = d / re;
      c[k] = K::w(d.norm(), re);
      M.noalias() += c[k] * p[k] * p[k].transpose();
    }
    const Eigen::LDLT<matp> ldlt(M);
    if (ldlt.info() != Eigen::Success || !(ldlt.rcond() >= min_rcond)) return false;
    const vecp y = ldlt.solve(vecp::Unit(0));
    for (std::size_t k = 0; k < cand.size(); ++k) c[k] *= p[k].dot(y);
    return true;
  }
};

/// \brief Kernel (Shepard) interpolation: c_j = w_j / Σ_k w_k. Exact for constant fields only; smooth
/// and positive (never overshoots the neighbours' range). False when no neighbour has a weight.
template <int D, Kernel K = kernel::quadratic>
class kernel_interpolation final {
  static_assert(K::finite_at_zero, "mpskit: a probe on top of a particle needs a kernel finite at r = 0");

 public:
  static constexpr std::string_view description = "kernel (Shepard) interpolation (exact for constants)";
  /// Weights of the particles `cand` for the value at q.
  bool weights(const points<D>& x, const vec<D>& q, double re, std::span<const index_t> cand,
               std::vector<double>& c) const {
    c.assign(cand.size(), 0.0);
    double sum = 0.0;
    for (std::size_t k = 0; k < cand.size(); ++k) {
      c[k] = K::w((x.col(cand[k]) - q).norm(), re);
      sum += c[k];
    }
    if (!(sum > 0.0)) return false;
    for (double& v : c) v /= sum;
    return true;
  }
};

/// \brief The weights c for a value at q (φ(q) ≈ Σ_k c_k φ_{cand_k}): cand = the real particles j with
/// accept(j) and |x_j − q| < re, in index order; false when `interp` refuses the neighbourhood (too few or
/// degenerate). Used by probe_set and by runners that sample a point themselves.
template <ParticleState State, class Interp, class Accept>
  requires PointInterpolation<Interp, State::dim> && std::predicate<const Accept&, index_t>
bool point_weights(const State& s, const vec<State::dim>& q, double re, const Accept& accept,
                   const Interp& interp, std::vector<index_t>& cand, std::vector<double>& c) {
  cand.clear();
  const double re2 = re * re;
  for (index_t j = 0; j < s.n_real(); ++j)
    if (accept(j) && (s.x().col(j) - q).squaredNorm() < re2) cand.push_back(j);
  return interp.weights(s.x(), q, re, cand, c);
}

/// A named probe point.
template <int D>
struct probe_point {
  std::string name;       ///< column prefix, e.g. "P1"
  vec<D> x = vec<D>::Zero();  ///< position [m]
};

/// \brief Probes at fixed points: every `every`-th step, pressure (when the state has it) and velocity
/// interpolated from the real particles of the kinds in `kinds` within `re` of each point, one CSV row
/// ("time [s], step [1], <name>.p [Pa], <name>.u_x [m/s], ..."). A probe with no supporting neighbourhood
/// (in the air, or degenerate) writes NaN. The interpolation is named in a comment line of the file.
/// Candidates are found by a scan of all real particles: cost O(N) per probe and sample.
template <ParticleState State, class Interp = lsmps_b1_interpolation<State::dim>>
  requires PointInterpolation<Interp, State::dim>
class probe_set {
 public:
  static constexpr int D = State::dim;
  static constexpr bool has_pressure = State::template has<field::pressure>;

  /// Probes written to `csv`; re > 0 [m] is the interpolation radius, every >= 1 the sampling interval.
  probe_set(std::filesystem::path csv, std::vector<probe_point<D>> probes, double re, index_t every = 1,
            kind_mask kinds = mask_of(kind::fluid) | mask_of(kind::wall), csv_mode mode = csv_mode::truncate,
            Interp interp = {})
      : probes_(std::move(probes)),
        re_(re),
        every_(every),
        kinds_(kinds),
        interp_(std::move(interp)),
        csv_(check(csv, probes_, re, every), columns(probes_), mode,
             {std::string("mpskit probes: ") + std::string(Interp::description) + ", re = " + fmt(re) +
              " m, every " + std::to_string(every) + " steps"}) {}

  /// Samples when step % every == 0; returns true when a row was written.
  bool sample(const State& s, double t, index_t step) {
    if (step % every_ != 0) return false;
    std::vector<double> row{t, static_cast<double>(step)};
    std::vector<index_t> cand;
    std::vector<double> c;
    const auto accept = [&](index_t j) { return in_mask(kinds_, s.kinds()[static_cast<std::size_t>(j)]); };
    for (const auto& pr : probes_) {
      const bool ok = point_weights(s, pr.x, re_, accept, interp_, cand, c);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      if constexpr (has_pressure) {
        double p = 0.0;
        for (std::size_t k = 0; k < cand.size(); ++k) p += c[k] * s.template get<field::pressure>()[cand[k]];
        row.push_back(ok ? p : nan);
      }
      for (int a = 0; a < D; ++a) {
        double u = 0.0;
        for (std::size_t k = 0; k < cand.size(); ++k) u += c[k] * s.u()(a, cand[k]);
        row.push_back(ok ? u : nan);
      }
    }
    last_ = row;
    csv_.row(row);
    return true;
  }

  const std::vector<double>& last_row() const { return last_; }  ///< the values of the last sample
  const csv_writer& csv() const { return csv_; }                   ///< the output file

 private:
  static std::string fmt(double v) {
    std::ostringstream os;
    os.precision(17);
    os << v;
    return os.str();
  }
  static const std::filesystem::path& check(const std::filesystem::path& csv,
                                            const std::vector<probe_point<D>>& pr, double re, index_t every) {
    if (!(std::isfinite(re) && re > 0.0))
      fail("probe_set '", csv.string(), "': re = ", re, ": must be a finite length > 0 [m]");
    if (every < 1) fail("probe_set '", csv.string(), "': every = ", every, ": must be >= 1");
    if (pr.empty()) fail("probe_set '", csv.string(), "': no probe points");
    for (const auto& p : pr)
      if (!p.x.allFinite())
        fail("probe_set '", csv.string(), "': probe '", p.name, "' has a non-finite position");
    return csv;
  }
  static std::vector<csv_column> columns(const std::vector<probe_point<D>>& pr) {
    std::vector<csv_column> c{{"time", "s"}, {"step", "1"}};
    static constexpr const char* axis[] = {"x", "y", "z"};
    for (const auto& p : pr) {
      if constexpr (has_pressure) c.push_back({p.name + ".p", "Pa"});
      for (int a = 0; a < D; ++a) c.push_back({p.name + ".u_" + axis[a], "m/s"});
    }
    return c;
  }

  std::vector<probe_point<D>> probes_;
  double re_;
  index_t every_;
  kind_mask kinds_;
  Interp interp_;
  csv_writer csv_;
  std::vector<double> last_;
};

/// Integrals over particles. In 2D, volumes are per unit depth (m²) and mass and energies too (kg/m, J/m).
struct flow_integrals {
  index_t particles = 0;          ///< particles counted
  double volume = 0.0;            ///< Σ V_i [m^D]
  double mass = 0.0;              ///< Σ m_i, m_i = ρ V_i [kg (3D), kg/m (2D)]
  double kinetic_energy = 0.0;    ///< ½ Σ m_i |u_i|² [J (3D), J/m (2D)]
  double potential_energy = 0.0;  ///< −Σ m_i g·x_i, zero at the origin [J (3D), J/m (2D)]

  /// CSV columns matching values(): time, particles, volume, mass, kinetic and potential energy.
  static std::vector<csv_column> columns(int dim) {
    const bool two = dim == 2;
    return {{"time", "s"},           {"particles", "1"},
            {"volume", two ? "m^2" : "m^3"}, {"mass", two ? "kg/m" : "kg"},
            {"kinetic_energy", two ? "J/m" : "J"}, {"potential_energy", two ? "J/m" : "J"}};
  }
  /// A CSV row at time t.
  std::vector<double> values(double t) const {
    return {t, static_cast<double>(particles), volume, mass, kinetic_energy, potential_energy};
  }
};

/// \brief Volume, mass, kinetic and potential energy of the real particles of the kinds in `kinds`:
/// m_i = ρ V_i with V_i the state's `volume` field when it has one, else `particle_volume` (e.g. l0^D).
/// Summed in particle order (deterministic).
template <ParticleState State>
flow_integrals integrals(const State& s, double rho, const vec<State::dim>& g, double particle_volume = 0.0,
                         kind_mask kinds = mask_of(kind::fluid)) {
  constexpr bool has_volume = State::template has<field::volume>;
  if (!(std::isfinite(rho) && rho > 0.0))
    fail("integrals: rho = ", rho, ": must be a finite density > 0 [kg/m^3]");
  if (!has_volume && !(std::isfinite(particle_volume) && particle_volume > 0.0))
    fail("integrals: particle_volume = ", particle_volume,
         ": must be > 0 [m^D] (the state has no volume field)");
  flow_integrals r;
  for (index_t i = 0; i < s.n_real(); ++i) {
    if (!in_mask(kinds, s.kinds()[static_cast<std::size_t>(i)])) continue;
    double V = particle_volume;
    if constexpr (has_volume) V = s.template get<field::volume>()[i];
    const double m = rho * V;
    ++r.particles;
    r.volume += V;
    r.mass += m;
    r.kinetic_energy += 0.5 * m * s.u().col(i).squaredNorm();
    r.potential_energy -= m * g.dot(s.x().col(i));
  }
  return r;
}

/// \brief Surge-front position: the largest coordinate along `axis` of the real particles of the kinds
/// in `kinds`, plus `offset` (e.g. l0/2 to count the particle's extent; Martin & Moyce's z is measured
/// from the back wall, so subtract its position). NaN when no particle counts.
template <ParticleState State>
double front_position(const State& s, int axis = 0, double offset = 0.0,
                      kind_mask kinds = mask_of(kind::fluid)) {
  if (axis < 0 || axis >= State::dim)
    fail("front_position: axis = ", axis, ": must be in [0, ", State::dim, ")");
  double front = -std::numeric_limits<double>::infinity();
  bool any = false;
  for (index_t i = 0; i < s.n_real(); ++i)
    if (in_mask(kinds, s.kinds()[static_cast<std::size_t>(i)])) {
      front = std::max(front, s.x()(axis, i));
      any = true;
    }
  return any ? front + offset : std::numeric_limits<double>::quiet_NaN();
}

/// \brief The largest connected body among the first n particles with counted(i): particles i and j are
/// linked when |x_i − x_j| < link · (d_i + d_j)/2, and a body is a connected component of these links
/// (core/union_find.hpp over a cell grid of size link · max d). On the periodic axes of `dom` the distance is
/// the minimum image (search::domain), so a body that crosses the period box's side is one body. Returns one
/// flag per particle (1 for the members of the body with the largest Σ d^D, ties by its lowest index; 0
/// elsewhere, and all 0 when no particle counts). Refused: n beyond x or diam, link not finite and > 0, a bad
/// domain, a counted particle with a non-finite position or a diameter not finite and > 0, or one more than
/// 4e18 cells from the origin along a non-periodic axis (the cell index is an int64_t). Ours, for measures
/// that should not follow spray: a surge front taken over this body ignores clusters that have left the bulk
/// (Martin & Moyce measured the leading edge of the surge). The default link 1.5 is the merge radius α_r of
/// Tanaka 2018 §4.4: a gap wider than half a diameter between two particles' extents separates them.
template <int D, class Counted>
std::vector<char> largest_body(const points<D>& x, const Eigen::VectorXd& diam, index_t n,
                               const Counted& counted, const search::domain<D>& dom, double link = 1.5) {
  if (n < 0 || n > x.cols() || n > diam.size())
    fail("largest_body: n = ", n, " exceeds the positions (", x.cols(), ") or diameters (", diam.size(), ")");
  if (!(link > 0.0) || !std::isfinite(link)) fail("largest_body: link = ", link, ": must be finite and > 0");
  dom.validate();
  std::vector<char> member(static_cast<std::size_t>(n), 0);
  std::vector<index_t> ids;
  double d_max = 0.0;
  for (index_t i = 0; i < n; ++i) {
    if (!counted(i)) continue;
    if (!(diam[i] > 0.0) || !std::isfinite(diam[i]) || !x.col(i).allFinite())
      fail("largest_body: particle ", i, " has diameter ", diam[i], " or a non-finite position");
    ids.push_back(i);
    d_max = std::max(d_max, diam[i]);
  }
  if (ids.empty()) return member;
  // Cells: size h = link · max d on the open axes (every link is shorter than one cell); on a periodic axis m
  // cells of P/m >= h across the period (m >= 1, at most 4e18; with m < 3 the neighbour cells repeat, which
  // only repeats checks).
  const double h = link * d_max;
  std::array<double, D> cell_size{};
  std::array<std::int64_t, D> cells{};
  for (int a = 0; a < D; ++a) {
    const auto as = static_cast<std::size_t>(a);
    if (!dom.periodic[as]) {
      cell_size[as] = h;
      continue;
    }
    const double P = dom.period(a);
    std::int64_t m = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::min(P / h, 4e18)));
    if (m > 1 && P / static_cast<double>(m) < h) --m;  // P/h rounded up to a whole number: one cell fewer
    cells[as] = m;
    cell_size[as] = P / static_cast<double>(m);
  }
  for (index_t i : ids)  // the cell index (and its neighbours' ±1) must fit an int64_t
    for (int a = 0; a < D; ++a)
      if (!dom.periodic[static_cast<std::size_t>(a)] && !(std::abs(x(a, i) / h) < 4e18))
        fail("largest_body: particle ", i, " lies at ", x(a, i), " along axis ", a, ", beyond 4e18 cells of ",
             h, " (link x the largest diameter) from the origin");
  using key = std::array<std::int64_t, D>;
  auto cell = [&](index_t i) {
    const vec<D> y = dom.wrap(x.col(i));
    key k;
    for (int a = 0; a < D; ++a) {
      const auto as = static_cast<std::size_t>(a);
      if (dom.periodic[as])  // in [0, m): rounding may put a wrapped y[a] at the box's top
        k[as] = std::clamp<std::int64_t>(
            static_cast<std::int64_t>(std::floor((y[a] - dom.lo[a]) / cell_size[as])), 0, cells[as] - 1);
      else
        k[as] = static_cast<std::int64_t>(std::floor(y[a] / h));
    }
    return k;
  };
  std::vector<std::pair<key, index_t>> grid;
  grid.reserve(ids.size());
  for (index_t i : ids) grid.emplace_back(cell(i), i);
  std::sort(grid.begin(), grid.end());
  union_find sets(n);
  for (index_t i : ids) {
    const key c = cell(i);
    std::array<int, D> off{};
    off.fill(-1);
    while (true) {  // the 3^D cells around i's (across the period on periodic axes)
      key k = c;
      for (int a = 0; a < D; ++a) {
        const auto as = static_cast<std::size_t>(a);
        k[as] += off[as];
        if (dom.periodic[as]) k[as] = (k[as] % cells[as] + cells[as]) % cells[as];
      }
      auto it = std::lower_bound(grid.begin(), grid.end(), std::make_pair(k, index_t{-1}));
      for (; it != grid.end() && it->first == k; ++it) {
        const index_t j = it->second;
        if (j <= i) continue;
        vec<D> r = x.col(i) - x.col(j);
        dom.minimum_image(r);
        if (r.norm() < link * 0.5 * (diam[i] + diam[j])) sets.unite(i, j);
      }
      int a = 0;
      while (a < D && off[static_cast<std::size_t>(a)] == 1) off[static_cast<std::size_t>(a++)] = -1;
      if (a == D) break;
      ++off[static_cast<std::size_t>(a)];
    }
  }
  // Roots are the lowest index of their body (union_find links to the smaller root), so ties go to the lowest
  // index.
  std::vector<double> size(static_cast<std::size_t>(n), 0.0);
  for (index_t i : ids) size[static_cast<std::size_t>(sets.find(i))] += std::pow(diam[i], D);
  index_t best = ids.front();
  for (index_t i : ids)
    if (sets.find(i) == i && size[static_cast<std::size_t>(i)] > size[static_cast<std::size_t>(best)])
      best = i;
  for (index_t i : ids) member[static_cast<std::size_t>(i)] = sets.find(i) == best;
  return member;
}

/// largest_body without periodic axes.
template <int D, class Counted>
std::vector<char> largest_body(const points<D>& x, const Eigen::VectorXd& diam, index_t n,
                               const Counted& counted, double link = 1.5) {
  return largest_body(x, diam, n, counted, search::domain<D>{}, link);
}

}  // namespace mpskit::io
