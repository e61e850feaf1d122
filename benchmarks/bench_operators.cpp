// Operator micro-benchmarks (issue 3): per-particle cost of LSMPS type A moments + inverse (`compute`) and
// of applying gradient + Laplacian, 2D and 3D, orders 1–3, beside the classic MPS Laplacian and gradient.
// Jittered square/cubic lattice (spacing l0 = 1/side, jitter uniform in ±0.1 l0 per axis, fixed seed),
// LSMPS radius 3.1 L (quadratic kernel, Tanaka eqs. 27–29), MPS radii 2.1 / 3.1 l0, list built at 3.1 l0.
// n ≈ 1e5 particles; one thread unless OMP_NUM_THREADS says otherwise (the loops run through exec::seq).
//
// `bench_operators --mpskit_accuracy` instead prints the accuracy tables of docs/operators.md: error at a
// fixed spacing for every operator and order (sin x cos y [cos z]), and Tanaka 2018 §5.1 (two-size
// block, Table 1 quadratics) for classic MPS and LSMPS.
#include <benchmark/benchmark.h>

#include "cases/tanaka_table1.hpp"
#include "support/support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/op/lsmps_a.hpp"
#include "mpskit/op/lsmps_b.hpp"
#include "mpskit/op/mps.hpp"
#include "mpskit/search/neighbour_list.hpp"

#ifndef MPSKIT_BENCH_FLAGS
#define MPSKIT_BENCH_FLAGS "(see build)"
#endif

namespace {

using namespace mpskit;
constexpr std::uint64_t seed = 20181001;

template <int D>
points<D> jittered_lattice(int side, double h, double jitter, std::uint64_t s) {
  std::mt19937_64 rng(s);
  return mpskit::test::jittered_lattice<D>(side, h, jitter,
                                           rng);  // tests/support: one lattice for tests and benchmarks
}

/// One shared setup per dimension (n ≈ 1e5): positions, list at 3.1 l0, a smooth field.
template <int D>
struct setup {
  int side = D == 2 ? 316 : 46;
  double h = 1.0 / side;
  points<D> x;
  search::neighbour_list<D> nl;
  Eigen::VectorXd phi;
  setup() {
    x = jittered_lattice<D>(side, h, 0.1, seed);
    nl.build(exec::seq{}, x, search::uniform_radius{3.1 * h});
    phi.resize(x.cols());
    for (index_t i = 0; i < x.cols(); ++i) phi[i] = std::sin(x(0, i)) * std::cos(x(1, i));
  }
  static const setup& get() {
    static const setup s;
    return s;
  }
};

void per_particle(benchmark::State& st, index_t n) {
  st.counters["per_particle"] = benchmark::Counter(
      double(n), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  st.counters["n"] = double(n);
}

template <int D, int P>
void bm_lsmps_compute(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::lsmps_a<D, P> A;
  for (auto _ : st) {
    A.compute(exec::seq{}, s.x, s.nl, op::uniform_size{s.h});
    benchmark::DoNotOptimize(A.inverse_moments(0).data());
  }
  per_particle(st, s.x.cols());
  st.counters["degenerate"] = double(A.degenerate_count());
}

template <int D, int P>
void bm_lsmps_grad_lap(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::lsmps_a<D, P> A;
  A.compute(exec::seq{}, s.x, s.nl, op::uniform_size{s.h});
  for (auto _ : st) {
    double acc = 0.0;
    for (index_t i = 0; i < s.x.cols(); ++i) {
      const auto [g, l] = A.gradient_laplacian(s.x, s.nl, i, s.phi);
      acc += g[0] + l;
    }
    benchmark::DoNotOptimize(acc);
  }
  per_particle(st, s.x.cols());
}

template <int D, int P>
void bm_lsmps_laplacian_row(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::lsmps_a<D, P> A;
  A.compute(exec::seq{}, s.x, s.nl, op::uniform_size{s.h});
  const auto sel = A.laplacian_selector();
  for (auto _ : st) {
    double acc = 0.0;
    for (index_t i = 0; i < s.x.cols(); ++i)
      A.for_each_row_weight(s.x, s.nl, i, sel, op::all_neighbours{},
                            [&](index_t j, double a) { acc += a * s.phi[j]; });
    benchmark::DoNotOptimize(acc);
  }
  per_particle(st, s.x.cols());
}

template <int D>
void bm_mps_laplacian(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::mps<D> M(op::mps_params{s.h});
  for (auto _ : st) {
    double acc = 0.0;
    for (index_t i = 0; i < s.x.cols(); ++i) acc += M.laplacian(s.x, s.nl, i, s.phi);
    benchmark::DoNotOptimize(acc);
  }
  per_particle(st, s.x.cols());
}

template <int D>
void bm_mps_grad_lap(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::mps<D> M(op::mps_params{s.h});
  for (auto _ : st) {
    double acc = 0.0;
    for (index_t i = 0; i < s.x.cols(); ++i)
      acc += M.laplacian(s.x, s.nl, i, s.phi) + M.gradient(s.x, s.nl, i, s.phi)[0];
    benchmark::DoNotOptimize(acc);
  }
  per_particle(st, s.x.cols());
}

template <int D>
void bm_mps_corrected_gradient(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::mps<D> M(op::mps_params{s.h});
  for (auto _ : st) {
    double acc = 0.0;
    for (index_t i = 0; i < s.x.cols(); ++i) acc += M.corrected_gradient(s.x, s.nl, i, s.phi)[0];
    benchmark::DoNotOptimize(acc);
  }
  per_particle(st, s.x.cols());
}

template <int D, int P>
void bm_lsmps_b_point(benchmark::State& st) {
  const setup<D>& s = setup<D>::get();
  op::lsmps_b<D, P> B;
  // candidates: the stored neighbours of a particle plus itself, evaluated half a spacing away
  std::vector<index_t> cand;
  const index_t k = s.x.cols() / 2 + s.side / 2;
  cand.push_back(k);
  for (auto j : s.nl.neighbours(k)) cand.push_back(j);
  vec<D> q = s.x.col(k);
  q[0] += 0.5 * s.h;
  for (auto _ : st) {
    const auto sten = B.stencil(s.x, q, s.h, cand, op::uniform_size{s.h});
    benchmark::DoNotOptimize(sten.value(s.phi));
  }
  per_particle(st, 1);
}

}  // namespace

BENCHMARK(bm_mps_laplacian<2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_mps_grad_lap<2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_mps_corrected_gradient<2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_compute<2, 1>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_compute<2, 2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_compute<2, 3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_grad_lap<2, 1>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_grad_lap<2, 2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_grad_lap<2, 3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_laplacian_row<2, 2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_b_point<2, 2>)->Unit(benchmark::kMicrosecond);
BENCHMARK(bm_mps_laplacian<3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_mps_grad_lap<3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_mps_corrected_gradient<3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_compute<3, 1>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_compute<3, 2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_compute<3, 3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_grad_lap<3, 1>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_grad_lap<3, 2>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_grad_lap<3, 3>)->Unit(benchmark::kMillisecond);
BENCHMARK(bm_lsmps_b_point<3, 2>)->Unit(benchmark::kMicrosecond);

// ---- accuracy tables (--mpskit_accuracy) ---------------------------------------------------------------
namespace {

/// RMS errors of ∇ and ∇² of f = sin x cos y [cos z] over particles ≥ 3.1 h from the edge of a jittered
/// lattice (±0.1 h) on [0, 2]^D with spacing h.
template <int D>
struct field_errors {
  double grad = 0.0, lap = 0.0;
};

template <int D>
double fval(const vec<D>& p) {
  double v = std::sin(p[0]) * std::cos(p[1]);
  if constexpr (D == 3) v *= std::cos(p[2]);
  return v;
}
template <int D>
vec<D> fgrad(const vec<D>& p) {
  vec<D> g;
  const double cz = D == 3 ? std::cos(p[2]) : 1.0;
  g[0] = std::cos(p[0]) * std::cos(p[1]) * cz;
  g[1] = -std::sin(p[0]) * std::sin(p[1]) * cz;
  if constexpr (D == 3) g[2] = -std::sin(p[0]) * std::cos(p[1]) * std::sin(p[2]);
  return g;
}
template <int D>
double flap(const vec<D>& p) {
  return -double(D) * fval<D>(p);
}

template <int D, class GradLap>
field_errors<D> errors_on(const points<D>& x, double h, double box, GradLap&& gl) {
  double sg = 0, sl = 0;
  index_t c = 0;
  for (index_t i = 0; i < x.cols(); ++i) {
    bool in = true;
    for (int a = 0; a < D; ++a) in = in && x(a, i) >= 3.1 * h && x(a, i) <= box - 3.1 * h;
    if (!in) continue;
    const auto [g, l] = gl(i);
    sg += (g - fgrad<D>(x.col(i))).squaredNorm() / D;
    sl += std::pow(l - flap<D>(x.col(i)), 2);
    ++c;
  }
  return {std::sqrt(sg / double(c)), std::sqrt(sl / double(c))};
}

template <int D>
void accuracy_table(double h) {
  const double box = 2.0;
  const int side = static_cast<int>(std::lround(box / h)) + 1;
  const points<D> x = jittered_lattice<D>(side, h, 0.1, seed);
  search::neighbour_list<D> nl;
  nl.build(exec::seq{}, x, search::uniform_radius{3.1 * h});
  Eigen::VectorXd phi(x.cols());
  for (index_t i = 0; i < x.cols(); ++i) phi[i] = fval<D>(x.col(i));
  std::printf(
      "\n%dD, h = %g (%ld particles), RMS error of f = sin x cos y%s, particles >= 3.1 h from the edge\n", D,
      h, (long)x.cols(), D == 3 ? " cos z" : "");
  std::printf("| operator | grad RMS | Laplacian RMS |\n|---|---|---|\n");
  for (auto norm : {op::mps_normalisation::reference_lattice, op::mps_normalisation::per_particle}) {
    op::mps_params p{h};
    p.normalisation = norm;
    op::mps<D> M(p);
    const auto e = errors_on<D>(x, h, box, [&](index_t i) {
      return std::pair<vec<D>, double>(M.gradient(x, nl, i, phi), M.laplacian(x, nl, i, phi));
    });
    const auto ec = errors_on<D>(x, h, box, [&](index_t i) {
      return std::pair<vec<D>, double>(M.corrected_gradient(x, nl, i, phi), 0.0);
    });
    std::printf("| mps (%s n0/lambda) | %.3e | %.3e |\n",
                norm == op::mps_normalisation::per_particle ? "per-particle" : "lattice", e.grad, e.lap);
    if (norm == op::mps_normalisation::reference_lattice)
      std::printf("| mps corrected-matrix gradient | %.3e | - |\n", ec.grad);
  }
  auto lsmps = [&]<int P>() {
    op::lsmps_a<D, P> A;
    A.compute(exec::seq{}, x, nl, op::uniform_size{h});
    const auto e = errors_on<D>(x, h, box, [&](index_t i) { return A.gradient_laplacian(x, nl, i, phi); });
    if (P == 1)
      std::printf("| lsmps_a order 1 | %.3e | (none) |\n", e.grad);
    else
      std::printf("| lsmps_a order %d | %.3e | %.3e |\n", P, e.grad, e.lap);
  };
  lsmps.template operator()<1>();
  lsmps.template operator()<2>();
  lsmps.template operator()<3>();
}

/// Tanaka 2018 §5.1: diameter 1 for x < 0, s for x > 0 (12 × 24 block each side, cell-centred lattices);
/// the ten quadratics of Table 1; max over particles within 3.1 s of x = 0 (the "red" particles) and at
/// least 3.1 s from the block's top and bottom edges (so only the size jump is measured) of
/// |computed − exact| / max |exact| over the block, per operator, max over the ten functions.
void tanaka_table() {
  const auto& table1 = mpskit::cases::tanaka_table1;
  std::printf(
      "\nTanaka 2018 §5.1, two-size block: max normalised error at the interface particles (|x| < 3.1 s, 3.1 "
      "s < y < 24 - 3.1 s), max over the ten Table 1 functions\n");
  std::printf("| s | operator | df/dx | df/dy | Laplacian |\n|---|---|---|---|---|\n");
  for (double s : {1.0, 1.5, 2.0, 2.5, 3.0}) {
    std::vector<vec<2>> pts;
    std::vector<double> Lv;
    for (int b = 0; b < 24; ++b)
      for (int a = 0; a < 12; ++a) {
        pts.push_back(vec<2>(-12.0 + 0.5 + a, b + 0.5));
        Lv.push_back(1.0);
      }
    const int nx = static_cast<int>(std::floor(12.0 / s)), ny = static_cast<int>(std::floor(24.0 / s));
    for (int b = 0; b < ny; ++b)
      for (int a = 0; a < nx; ++a) {
        pts.push_back(vec<2>((a + 0.5) * s, (b + 0.5) * s));
        Lv.push_back(s);
      }
    points<2> x(2, static_cast<index_t>(pts.size()));
    Eigen::VectorXd L(static_cast<index_t>(pts.size()));
    for (std::size_t k = 0; k < pts.size(); ++k) {
      x.col(static_cast<index_t>(k)) = pts[k];
      L[static_cast<index_t>(k)] = Lv[k];
    }
    search::neighbour_list<2> nl;
    nl.build(exec::seq{}, x, search::per_particle_radius{&L, 3.1});
    auto run = [&](const char* name, auto&& gl) {
      double ex = 0, ey = 0, el = 0;
      for (int set = 0; set < 10; ++set) {
        const double* c = table1[set];
        Eigen::VectorXd phi(x.cols());
        double gx = 0, gy = 0;
        for (index_t i = 0; i < x.cols(); ++i) {
          const double X = x(0, i), Y = x(1, i);
          phi[i] = c[0] * X * X + c[1] * Y * Y + c[2] * X * Y + c[3] * X + c[4] * Y + c[5];
          gx = std::max(gx, std::abs(2 * c[0] * X + c[2] * Y + c[3]));
          gy = std::max(gy, std::abs(2 * c[1] * Y + c[2] * X + c[4]));
        }
        const double lap = 2 * c[0] + 2 * c[1];
        for (index_t i = 0; i < x.cols(); ++i) {
          const double X = x(0, i), Y = x(1, i);
          // interface, full support
          if (!(std::abs(X) < 3.1 * s && Y > 3.1 * s && Y < 24.0 - 3.1 * s)) continue;
          const auto [g, l] = gl(i, phi);
          ex = std::max(ex, std::abs(g[0] - (2 * c[0] * X + c[2] * Y + c[3])) / gx);
          ey = std::max(ey, std::abs(g[1] - (2 * c[1] * Y + c[2] * X + c[4])) / gy);
          el = std::max(el, std::abs(l - lap) / std::abs(lap));
        }
      }
      std::printf("| %.1f | %s | %.2e | %.2e | %.2e |\n", s, name, ex, ey, el);
    };
    for (auto rule : {search::radius_rule::own, search::radius_rule::pair_mean}) {
      op::mps_params p{1.0};
      p.rule = rule;
      op::mps<2> M(p);
      M.set_sizes(&L);
      run(rule == search::radius_rule::own ? "mps (own radius)" : "mps (pair-mean radius)",
          [&](index_t i, const Eigen::VectorXd& phi) {
            return std::pair<vec<2>, double>(M.gradient(x, nl, i, phi), M.laplacian(x, nl, i, phi));
          });
      if (rule == search::radius_rule::pair_mean) {
        p.normalisation = op::mps_normalisation::per_particle;
        op::mps<2> Mp(p);
        Mp.set_sizes(&L);
        run("mps (pair-mean, per-particle n/lambda)", [&](index_t i, const Eigen::VectorXd& phi) {
          return std::pair<vec<2>, double>(Mp.gradient(x, nl, i, phi), Mp.laplacian(x, nl, i, phi));
        });
        run("mps corrected gradient / mass-weighted Laplacian", [&](index_t i, const Eigen::VectorXd& phi) {
          return std::pair<vec<2>, double>(M.corrected_gradient(x, nl, i, phi),
                                           M.mass_weighted_laplacian(x, nl, i, phi));
        });
      }
    }
    op::lsmps_a<2, 2> A;
    A.compute(exec::seq{}, x, nl, op::per_particle_size{&L});
    run("lsmps_a order 2",
        [&](index_t i, const Eigen::VectorXd& phi) { return A.gradient_laplacian(x, nl, i, phi); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  for (int k = 1; k < argc; ++k)
    if (std::strcmp(argv[k], "--mpskit_accuracy") == 0) {
      std::printf("flags: %s\n", MPSKIT_BENCH_FLAGS);
      accuracy_table<2>(0.05);
      accuracy_table<3>(0.1);
      tanaka_table();
      return 0;
    }
  benchmark::Initialize(&argc, argv);
  benchmark::AddCustomContext("mpskit_flags", MPSKIT_BENCH_FLAGS);
  benchmark::AddCustomContext("mpskit_seed", std::to_string(seed));
  benchmark::AddCustomContext("mpskit_threads", std::to_string(mpskit::max_threads()));
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
