// Neighbour-search demo (the main example until a flow solver lands): a 2D jittered lattice, cell
// ordering through the state's resize path, one CSR list at 3.1 l0 × (1 + skin) read at 2.1 l0 and
// 3.1 l0, the particle number density against the lattice n0, and the classic MPS Laplacian of
// f = |x − x_i|² at each particle i (exactly 2d = 4 on an unjittered lattice, Koshizuka & Oka 1996;
// bmmr.md §2.3; on a jittered lattice it measures Σ w r² / (λ0 n0), the local inconsistency).
// Usage: neighbour_demo [--full] [--n SIDE] [--jitter J]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>

#include "cases/cli.hpp"
#include "mpskit/mpskit.hpp"

using namespace mpskit;
using clk = std::chrono::steady_clock;

static double seconds_since(clk::time_point t) {
  return std::chrono::duration<double>(clk::now() - t).count();
}

int main(int argc, char** argv) {
  int side = 200;
  double jitter = 0.1;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--full")) side = 1000;
    else {
      bool ok = true;
      try {  // the whole text a number (cases/cli.hpp)
        if (!std::strcmp(argv[a], "--n") && a + 1 < argc)
          side = cases::parse_integer("neighbour_demo: --n", argv[++a], 2);
        else if (!std::strcmp(argv[a], "--jitter") && a + 1 < argc)
          jitter = cases::parse_number("neighbour_demo: --jitter", argv[++a], 0.0);
        else ok = false;
      } catch (const mpskit::error& e) {
        std::fprintf(stderr, "%s\n", e.what());
        ok = false;
      }
      if (!ok) {
        std::fprintf(stderr, "usage: %s [--full] [--n SIDE] [--jitter J]\n", argv[0]);
        return 2;
      }
    }
  }
  const double l0 = 1e-3;
  const index_t n = static_cast<index_t>(side) * side;
  particle_state<2, field_list<field::number_density>> s(n);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> U(-jitter, jitter);
  for (index_t k = 0; k < n; ++k) s.x().col(k) << (k % side + U(rng)) * l0, (k / side + U(rng)) * l0;

  search::neighbour_list<2> list;
  const double skin = 0.1;
  auto t0 = clk::now();
  list.build(exec::par{}, s.x(), search::uniform_radius{3.1 * l0}, {skin, {}});
  const double t_first = seconds_since(t0);
  t0 = clk::now();
  const resize_report rep = s.reorder(list.cells().order());
  const double t_reorder = seconds_since(t0);
  t0 = clk::now();
  list.build(exec::par{}, s.x(), search::uniform_radius{3.1 * l0}, {skin, {}});
  const double t_build = seconds_since(t0);

  // Number density at 2.1 l0 and classic Laplacian at 3.1 l0 from the same list.
  const auto small = search::support{search::uniform_radius{2.1 * l0}, search::radius_rule::own};
  const auto large = search::support{search::uniform_radius{3.1 * l0}, search::radius_rule::own};
  const auto c21 = kernel::reference_lattice<kernel::classic, 2>(2.1);
  const auto c31 = kernel::reference_lattice<kernel::classic, 2>(3.1);
  auto& nd = s.get<field::number_density>();
  Eigen::VectorXd lap(n);
  t0 = clk::now();
  for_each_particle(exec::par{}, n, [&](index_t i) {
    double ni = 0.0, li = 0.0;
    list.for_each_neighbour(s.x(), i, small, [&](index_t, const vec<2>&, double r2) {
      ni += kernel::classic::w(std::sqrt(r2), 2.1 * l0);
    });
    list.for_each_neighbour(s.x(), i, large, [&](index_t, const vec<2>&, double r2) {
      li += r2 * kernel::classic::w(std::sqrt(r2), 3.1 * l0);  // f_j − f_i = |x_ij|² for f = |x − x_i|²
    });
    nd[i] = ni;
    lap[i] = 2.0 * 2 / (c31.lambda0(l0) * c31.n0) * li;
  });
  const double t_sweep = seconds_since(t0);

  // Interior particles (≥ 4 l0 from the edge): mean n/n0 and Laplacian error against 4.
  double sum_n = 0.0, max_err = 0.0, sum_err2 = 0.0;
  index_t interior = 0;
  const double lo = 4 * l0, hi = (side - 5) * l0;
  for (index_t i = 0; i < n; ++i) {
    const vec<2> x = s.x().col(i);
    if (x.minCoeff() < lo || x.maxCoeff() > hi) continue;
    ++interior;
    sum_n += nd[i] / c21.n0;
    max_err = std::max(max_err, std::abs(lap[i] - 4.0));
    sum_err2 += (lap[i] - 4.0) * (lap[i] - 4.0);
  }
  std::printf("mpskit neighbour demo: %ld particles (%d x %d, jitter %.2f l0), %d thread(s)\n",
              static_cast<long>(n), side, side, jitter, max_threads());
  std::printf("  list: %ld pairs (%.1f per particle) at 3.1 l0 x (1 + %.1f); cells %ld\n",
              static_cast<long>(list.pairs()), double(list.pairs()) / n, skin,
              static_cast<long>(list.cells().cells()));
  std::printf("  reorder to cell order: %ld particles moved slot (%.1f ms)\n",
              static_cast<long>(rep.reordered), 1e3 * t_reorder);
  std::printf("  build (cells + CSR): first %.1f ms, in cell order %.1f ms = %.1f ns/pair\n", 1e3 * t_first,
              1e3 * t_build, 1e9 * t_build / double(list.pairs()));
  std::printf("  sweep (n at 2.1 l0 + Laplacian at 3.1 l0): %.1f ms = %.2f ns/stored pair\n", 1e3 * t_sweep,
              1e9 * t_sweep / double(list.pairs()));
  std::printf("  interior particles: %ld; mean n/n0(2.1) = %.5f (1 on the exact lattice)\n",
              static_cast<long>(interior), sum_n / double(interior));
  std::printf("  classic MPS Laplacian of |x - x_i|^2 (exact 4 on the lattice): RMS error %.3e, max %.3e\n",
              std::sqrt(sum_err2 / double(interior)), max_err);
  return 0;
}
