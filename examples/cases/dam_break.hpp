#pragma once
// 2D dam break of Koshizuka & Oka (1996): water column a × 2a (a = 0.146 m) at the left wall of a tank
// 4a = 0.584 m wide; surge front Z = z/a against T = t sqrt(2g/a) (validation-cases.md D5), compared
// with Martin & Moyce (1952, two scales) and Koshizuka & Oka (1996) data (tests/data/dam_break_front,
// copied from shared/data/dam_break_front).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cases/tank.hpp"

namespace mpskit::cases {

/// A digitised (T, Z) series.
struct front_series {
  std::string name;                        ///< file name
  std::vector<std::pair<double, double>> points;  ///< (T, Z) in increasing T
  /// Linear interpolation inside [T_first, T_last]; NaN outside.
  double at(double T) const {
    if (points.empty() || T < points.front().first || T > points.back().first) return std::nan("");
    for (std::size_t k = 1; k < points.size(); ++k)
      if (T <= points[k].first) {
        const auto [t0, z0] = points[k - 1];
        const auto [t1, z1] = points[k];
        return z0 + (z1 - z0) * (T - t0) / (t1 - t0);
      }
    return points.back().second;
  }
};

/// Reads a CSV with '#' comments, a header line and T,Z rows; throws mpskit::error naming file and line.
inline front_series read_front_series(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail("dam break data: cannot open '", path, "'");
  front_series s;
  s.name = path.substr(path.find_last_of('/') + 1);
  std::string line;
  int lineno = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      continue;
    }
    std::istringstream ls(line);
    double T, Z;
    char comma;
    if (!(ls >> T >> comma >> Z) || comma != ',')
      fail("dam break data: '", path, "' line ", lineno, ": expected 'T,Z'");
    s.points.emplace_back(T, Z);
  }
  if (s.points.size() < 2) fail("dam break data: '", path, "' has fewer than two points");
  return s;
}

/// Set-up of the dam break.
struct dam_break_config {
  double a = 0.146;          ///< column width (m); height 2a; tank 4a wide
  double l0 = 0.146 / 20;    ///< spacing (m)
  double T_end = 3.0;        ///< run end in T = t sqrt(2g/a)
  double sample_dT = 0.05;   ///< front sampling interval in T
  scheme::semi_implicit_params<2> params{};  ///< scheme numbers (l0 set from above)
};

/// What the run measured.
struct dam_break_result {
  std::vector<double> T, Z;    ///< front history
  index_t particles = 0, fluid = 0, fluid_end = 0;
  long steps = 0, ppe_iterations = 0, isolated = 0;
  double wall_seconds = 0.0;
  double min_pressure = 0.0;   ///< lowest pressure of any particle during the run (Pa)
  bool inside_tank = true;     ///< no fluid particle left the tank through a wall
};

/// Front = max x of non-isolated fluid particles with at least 3 neighbours within re_small, plus l0/2
/// (a particle's half extent), measured from the inner face of the left wall.
template <class Sim>
double front_position(const Sim& sim) {
  const auto& st = sim.state();
  const auto& nl = sim.neighbours();
  const auto small = sim.op().small_support();
  double front = 0.0;
  for (index_t i = 0; i < st.n_real(); ++i) {
    if (st.kinds()[static_cast<std::size_t>(i)] != kind::fluid ||
        (st.flags()[static_cast<std::size_t>(i)] & flag::isolated))
      continue;
    int n = 0;
    nl.for_each_neighbour(st.x(), i, small, [&](index_t j, const vec<2>&, double) {
      n += st.kinds()[static_cast<std::size_t>(j)] == kind::fluid;
    });
    if (n >= 3) front = std::max(front, st.x()(0, i) + 0.5 * sim.params().l0);
  }
  return front;
}

/// Does nothing after a step.
struct no_observer {
  template <class Sim>
  void operator()(const Sim&) const {}
};

/// Runs the dam break with Scene (2D); observer(sim) is called after every step.
template <class Scene, class Observer = no_observer>
dam_break_result run_dam_break(dam_break_config cfg, Observer&& observer = {}) {
  static_assert(Scene::dim == 2, "mpskit: the Koshizuka & Oka dam break is 2D");
  cfg.params.l0 = cfg.l0;
  const double g = -cfg.params.g[1];
  simulation<Scene> sim(cfg.params,
                        tank_state<2>(vec<2>(cfg.a, 2 * cfg.a), vec<2>(4 * cfg.a, 2.5 * cfg.a), cfg.l0));
  dam_break_result r;
  r.particles = sim.state().n_real();
  r.fluid = count_kind(sim.state(), kind::fluid);
  const double tscale = std::sqrt(2.0 * g / cfg.a);
  double next = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  r.T.push_back(0.0);
  r.Z.push_back(1.0);
  next = cfg.sample_dT;
  sim.run_until(cfg.T_end / tscale, [&](const auto& s) {
    const auto& p = s.state().template get<field::pressure>();
    r.min_pressure = std::min(r.min_pressure, p.minCoeff());
    const double T = s.time() * tscale;
    if (T + 1e-12 >= next) {
      r.T.push_back(T);
      r.Z.push_back(front_position(s) / cfg.a);
      next += cfg.sample_dT;
    }
    observer(s);
  });
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& st = sim.state();
  for (index_t i = 0; i < st.n_real(); ++i) {
    if (st.kinds()[static_cast<std::size_t>(i)] != kind::fluid) continue;
    ++r.fluid_end;
    const double x = st.x()(0, i), y = st.x()(1, i);
    if (x < 0.0 || x > 4 * cfg.a || y < 0.0) r.inside_tank = false;
  }
  r.steps = sim.counters().steps;
  r.ppe_iterations = sim.counters().ppe_iterations;
  r.isolated = sim.counters().isolated;
  return r;
}

/// The three surge-front series of tests/data/dam_break_front in `dir`: Martin & Moyce (1952) for a = 1.125
/// in and 2.25 in, Koshizuka & Oka (1996). Throws (through read_front_series) naming a missing or bad file.
inline std::vector<front_series> read_front_data(const std::string& dir) {
  std::vector<front_series> v;
  for (const char* f :
       {"martin_moyce_1952_a1.125in.csv", "martin_moyce_1952_a2.25in.csv", "koshizuka_oka_1996.csv"})
    v.push_back(read_front_series(dir + "/" + f));
  return v;
}

/// The band of the reference data at T: [0.9 min, 1.1 max] over the series defined at T (NaN, NaN
/// when none is).
inline std::pair<double, double> front_band(const std::vector<front_series>& data, double T,
                                            double rel = 0.10) {
  double lo = 1e300, hi = -1e300;
  for (const auto& s : data) {
    const double z = s.at(T);
    if (std::isnan(z)) continue;
    lo = std::min(lo, z);
    hi = std::max(hi, z);
  }
  if (lo > hi) return {std::nan(""), std::nan("")};
  return {(1.0 - rel) * lo, (1.0 + rel) * hi};
}

}  // namespace mpskit::cases
