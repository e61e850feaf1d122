// 2D dam break (Koshizuka & Oka 1996 set-up) with the default classic scene: prints the surge front
// Z(T) against the Martin & Moyce and Koshizuka & Oka data. Usage: dam_break [--full] [--data DIR]
#include <cstdio>
#include <cstring>
#include <string>

#include "cases/dam_break.hpp"

int main(int argc, char** argv) {
  mpskit::cases::dam_break_config cfg;
  std::string data = MPSKIT_DATA_DIR;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--full")) cfg.l0 = cfg.a / 40;
    else if (!std::strcmp(argv[a], "--data") && a + 1 < argc) data = argv[++a];
    else { std::fprintf(stderr, "usage: %s [--full] [--data DIR]\n", argv[0]); return 2; }
  }
  std::vector<mpskit::cases::front_series> ref;
  for (const char* f : {"martin_moyce_1952_a1.125in.csv", "martin_moyce_1952_a2.25in.csv", "koshizuka_oka_1996.csv"})
    ref.push_back(mpskit::cases::read_front_series(data + "/" + f));
  const auto r = mpskit::cases::run_dam_break<mpskit::defaults<2>>(cfg);
  std::printf("dam break: a = %.3f m, l0 = %.4f m, %ld particles (%ld fluid), %ld steps, %.1f s, %.0f particle-steps/s, %.2f PPE it/step\n",
              cfg.a, cfg.l0, long(r.particles), long(r.fluid), r.steps, r.wall_seconds,
              double(r.particles) * double(r.steps) / r.wall_seconds, double(r.ppe_iterations) / double(r.steps));
  std::printf("     T      Z   band(data +-10%%)\n");
  for (std::size_t k = 0; k < r.T.size(); k += 4) {
    const auto [lo, hi] = mpskit::cases::front_band(ref, r.T[k]);
    std::printf("  %5.2f  %5.3f  [%5.3f, %5.3f]%s\n", r.T[k], r.Z[k], lo, hi,
                (r.Z[k] < lo || r.Z[k] > hi) ? "  outside" : "");
  }
  std::printf("  min pressure %.1f Pa; fluid inside the tank: %s\n", r.min_pressure, r.inside_tank ? "yes" : "NO");
  return 0;
}
