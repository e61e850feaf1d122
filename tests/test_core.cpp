// core/: fields, particle state and its one resize path, loops and reductions, params validation.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <random>
#include <vector>

#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/core/union_find.hpp"
#include "mpskit/ppe/solve.hpp"
#include "mpskit/scheme/time_step.hpp"

using namespace mpskit;

// Field lists: the union keeps first appearance and drops duplicates.
using lp = field_list<field::pressure, field::volume>;
using lq = field_list<field::volume, field::partner>;
static_assert(std::same_as<field_union<lp, lq>, field_list<field::pressure, field::volume, field::partner>>);
static_assert(FieldTag<field::pressure> && !FieldTag<int>);
// A state holds exactly what is asked: a wall-less single-resolution state has no volume array.
using bare_state = particle_state<2>;
using rich_state = particle_state<2, field_list<field::pressure, field::partner>>;
static_assert(!bare_state::has<field::volume> && !bare_state::has<field::pressure>);
static_assert(rich_state::has<field::pressure> && rich_state::has<field::partner> &&
              rich_state::has<field::id>);
static_assert(std::same_as<field_storage_t<field::pressure, 3>, Eigen::VectorXd>);
static_assert(std::same_as<field_storage_t<field::velocity, 3>, points<3>>);
static_assert(std::same_as<field_storage_t<field::partner, 3>, std::vector<index_t>>);

namespace {
std::uint64_t seed_from_env() {
  const std::uint64_t seed = 20261122;
  MESSAGE("RNG seed " << seed);
  return seed;
}

// A state where every field is a known function of the id, and partner(i) = particle with id+3 (mod n).
rich_state make_state(index_t n) {
  rich_state s(n);
  auto& p = s.get<field::pressure>();
  auto& partner = s.get<field::partner>();
  for (index_t i = 0; i < n; ++i) {
    const double id = static_cast<double>(s.ids()[static_cast<std::size_t>(i)]);
    s.x().col(i) << id, -id;
    s.u().col(i) << 2 * id, 0.5;
    p[i] = 1.5 * id;
    partner[static_cast<std::size_t>(i)] = (i + 3) % n;
    s.kinds()[static_cast<std::size_t>(i)] = (i % 4 == 0) ? kind::wall : kind::fluid;
  }
  return s;
}

// Every field still matches its particle's id; partner references resolve to the right ids.
void check_consistent(const rich_state& s, const std::map<particle_id, particle_id>& partner_of) {
  const auto& p = s.get<field::pressure>();
  const auto& partner = s.get<field::partner>();
  for (index_t i = 0; i < s.n_real(); ++i) {
    const particle_id id = s.ids()[static_cast<std::size_t>(i)];
    const double d = static_cast<double>(id);
    CHECK(s.x()(0, i) == d);
    CHECK(s.x()(1, i) == -d);
    CHECK(s.u()(0, i) == 2 * d);
    CHECK(p[i] == 1.5 * d);
    const index_t q = partner[static_cast<std::size_t>(i)];
    const auto it = partner_of.find(id);
    if (it == partner_of.end()) {
      CHECK(q == npos);
    } else {
      REQUIRE(q != npos);
      CHECK(s.ids()[static_cast<std::size_t>(q)] == it->second);
    }
  }
}
}  // namespace

TEST_SUITE("core") {
  TEST_CASE("core: reorder, remove and append keep every field and index consistent") {
    const index_t n = 200;
    rich_state s = make_state(n);
    std::map<particle_id, particle_id> partner_of;
    for (index_t i = 0; i < n; ++i)
      partner_of[static_cast<particle_id>(i)] = static_cast<particle_id>((i + 3) % n);
    check_consistent(s, partner_of);

    std::mt19937_64 rng(seed_from_env());
    std::vector<index_t> perm(static_cast<std::size_t>(n));
    std::iota(perm.begin(), perm.end(), 0);
    std::shuffle(perm.begin(), perm.end(), rng);
    const resize_report r1 = s.reorder(perm);
    CHECK(r1.removed == 0);
    CHECK(r1.appended == 0);
    CHECK(r1.reordered > n / 2);
    CHECK(r1.remap(perm[7]) == 7);
    check_consistent(s, partner_of);

    // Remove every particle whose id is a multiple of 5: references to them become npos and are counted.
    std::vector<char> mask(static_cast<std::size_t>(n));
    index_t lost = 0;
    for (index_t i = 0; i < n; ++i)
      mask[static_cast<std::size_t>(i)] = s.ids()[static_cast<std::size_t>(i)] % 5 == 0;
    for (auto& [id, pid] : partner_of)
      if (id % 5 != 0 && pid % 5 == 0) ++lost;
    std::erase_if(partner_of, [](const auto& kv) { return kv.first % 5 == 0 || kv.second % 5 == 0; });
    const resize_report r2 = s.remove(mask);
    CHECK(r2.removed == n / 5);
    CHECK(s.n_real() == n - n / 5);
    CHECK(r2.references_lost == lost);
    check_consistent(s, partner_of);

    // Append: fresh ids never reused, zero fields, the requested kind, others untouched.
    const particle_id next = s.next_id();
    CHECK(next == static_cast<particle_id>(n));
    const index_t first = s.append(3, kind::dummy);
    CHECK(first == n - n / 5);
    for (index_t i = first; i < s.n_real(); ++i) {
      CHECK(s.ids()[static_cast<std::size_t>(i)] == next + static_cast<particle_id>(i - first));
      CHECK(s.kinds()[static_cast<std::size_t>(i)] == kind::dummy);
      CHECK(s.get<field::partner>()[static_cast<std::size_t>(i)] == npos);
      CHECK(s.get<field::pressure>()[i] == 0.0);
    }
    s.validate();
  }

  TEST_CASE("core: ghosts live after the real range, carry role and parent, and are promoted or cleared") {
    rich_state s = make_state(10);
    const index_t g = s.add_ghosts(4, ghost_role::fictitious);
    CHECK(g == 10);
    CHECK(s.n_real() == 10);
    CHECK(s.n_ghost() == 4);
    auto& parent = s.get<field::parent>();
    for (index_t k = 0; k < 4; ++k) {
      parent[static_cast<std::size_t>(g + k)] = 2 * k;
      s.x().col(g + k) << 100.0 + k, 0.0;
      CHECK(s.ids()[static_cast<std::size_t>(g + k)] == no_id);
    }
    s.validate();
    CHECK_THROWS_AS(s.append(1, kind::fluid), mpskit::error);  // the ghost range must be empty first
    const resize_report r = s.promote_ghosts({13, 11});
    CHECK(r.promoted == 2);
    CHECK(r.ghosts_cleared == 2);
    CHECK(s.n_real() == 12);
    CHECK(s.n_ghost() == 0);
    CHECK(s.x()(0, 10) == 103.0);  // list order
    CHECK(s.x()(0, 11) == 101.0);
    CHECK(s.ids()[10] == 10);      // fresh ids
    CHECK(s.ids()[11] == 11);
    CHECK(s.get<field::role>()[10] == ghost_role::none);
    CHECK(s.get<field::parent>()[10] == npos);
    s.add_ghosts(2, ghost_role::imaginary);
    s.get<field::parent>()[12] = 5;
    CHECK_THROWS_AS(s.reorder(std::vector<index_t>(12)), mpskit::error);  // ghosts present
    const resize_report rc = s.clear_ghosts();
    CHECK(rc.ghosts_cleared == 2);
    CHECK(s.size() == 12);
  }

  TEST_CASE("core: union_find's sets are the graph's components, each rooted at its lowest index") {
    // 200 random edges on 300 nodes, united in a shuffled order: the sets equal the components of a
    // flood fill over the same edges, and every root is its set's smallest member whatever the order.
    std::mt19937 rng(20261204);
    const index_t n = 300;
    std::vector<std::pair<index_t, index_t>> edges;
    std::uniform_int_distribution<index_t> node(0, n - 1);
    for (int k = 0; k < 200; ++k) edges.emplace_back(node(rng), node(rng));
    std::vector<index_t> smallest(static_cast<std::size_t>(n),
                                  -1);  // flood fill: the lowest index per component
    for (index_t s = 0; s < n; ++s) {
      if (smallest[static_cast<std::size_t>(s)] >= 0) continue;
      std::vector<index_t> todo{s};
      smallest[static_cast<std::size_t>(s)] = s;
      while (!todo.empty()) {
        const index_t i = todo.back();
        todo.pop_back();
        for (const auto& [a, b] : edges)
          for (const auto& [u, v] : {std::pair{a, b}, std::pair{b, a}})
            if (u == i && smallest[static_cast<std::size_t>(v)] < 0) {
              smallest[static_cast<std::size_t>(v)] = s;
              todo.push_back(v);
            }
      }
    }
    for (int order = 0; order < 3; ++order) {
      std::shuffle(edges.begin(), edges.end(), rng);
      union_find sets(n);
      for (const auto& [a, b] : edges) {
        const index_t r = sets.unite(a, b);
        CHECK(r == std::min(sets.find(a), sets.find(b)));
        CHECK(r == sets.find(a));
      }
      int wrong = 0;
      for (index_t i = 0; i < n; ++i) wrong += sets.find(i) != smallest[static_cast<std::size_t>(i)];
      CHECK(wrong == 0);
    }
    union_find one(1);
    CHECK(one.find(0) == 0);
    CHECK(one.unite(0, 0) == 0);
  }

  TEST_CASE("core: for_each_particle writes each slot once; reductions are blocked and ordered") {
    const index_t n = 3 * reduction_block + 17;
    std::vector<double> v(static_cast<std::size_t>(n));
    for_each_particle(exec::par{}, n, [&](index_t i) { v[static_cast<std::size_t>(i)] = 1.0 / (1.0 + i); });
    // Reference: the same fixed-block order spelt out by hand.
    double ref = 0.0;
    for (index_t b = 0; b < n; b += reduction_block) {
      double part = 0.0;
      for (index_t i = b; i < std::min(n, b + reduction_block); ++i) part += v[static_cast<std::size_t>(i)];
      ref += part;
    }
    const double s = reduce_sum(exec::seq{}, n, [&](index_t i) { return v[static_cast<std::size_t>(i)]; });
    CHECK(s == ref);  // bitwise: same association
  }
}

// The Δt controller (scheme/time_step.hpp) driven by a given limit: L = 1, ν = 0, u = α_C / limit.
namespace {
double step_to(scheme::time_step_controller& c, double limit, long step = 0) {
  return c.next(1.0, c.params().courant / limit, 0.0, step, 0);
}
}  // namespace

TEST_SUITE("core") {
  TEST_CASE(
      "scheme: the Δt ladder takes the largest rung under the limit and climbs one rung with hysteresis") {
    for (const double r : {2.0, std::pow(2.0, 0.25), 1.1}) {
      CAPTURE(r);
      scheme::time_step_params p;
      p.dt_max = 1e-3;
      p.ratio = r;
      scheme::time_step_controller c(p);
      // Down: every limit in [dt_max 2^-12, dt_max] gives the largest rung dt_max / r^k ≤ limit, i.e.
      // limit / r < Δt ≤ limit (the ladder's whole point: with r = 2 up to half the allowed Δt is lost).
      std::mt19937 rng(7);
      std::uniform_real_distribution<double> e(-12.0, 0.0);
      double lim = p.dt_max;
      for (int n = 0; n < 200; ++n) {
        // non-increasing: the controller never climbs
        lim = std::min(lim, p.dt_max * std::exp2(e(rng)) * 4.0);
        const double dt = step_to(c, lim);
        const int k = c.state().halvings;
        CHECK(dt <= lim);
        if (k > 0) CHECK(dt * r > lim * (1.0 - 1e-12));
        CHECK(dt == doctest::Approx(p.dt_max * std::pow(r, -k)).epsilon(1e-14));
        if (r == 2.0) CHECK(dt == std::ldexp(p.dt_max, -k));  // bitwise the Δt_max / 2^k of before the ratio
      }
      // Up: under a constant large limit Δt climbs one rung per hold_steps + 1 calls while r Δt
      // hysteresis ≤ limit, and stops at the first rung above limit / (r hysteresis).
      const int k0 = c.state().halvings;
      const double big = c.dt() * std::pow(r, 4) * p.hysteresis * 0.999;  // three rungs up, not four
      REQUIRE(big < p.dt_max);
      long changes = c.state().changes;
      int climbs = 0;
      for (int n = 0; n < 20 * (p.hold_steps + 1); ++n) {
        step_to(c, big);
        if (c.state().changes != changes) {
          ++climbs;
          changes = c.state().changes;
          CHECK(c.state().held == 0);
        }
      }
      const double dt = c.dt();
      CHECK(dt <= big);
      CHECK(r * dt * p.hysteresis > big);
      CHECK(climbs == k0 - c.state().halvings);
      CHECK(climbs == 3);
    }
  }

  TEST_CASE(
      "scheme: the Δt limit takes the Courant pair and the viscous spacing apart (eq. 64 per particle)") {
    scheme::time_step_params p;  // α_C = α_ν = 0.1, dt_max = 1e-3 s
    const scheme::time_step_controller c(p);
    // Courant of the limiting particle (L 2 mm, 1 m/s): 2e-4 s; viscous at the smallest L (1 mm): 0.1 L²/ν.
    CHECK(c.limit(2e-3, 1.0, 1e-3, 1e-6) == doctest::Approx(2e-4).epsilon(1e-15));
    // not 0.1 (2 mm)²/ν = 4e-4
    CHECK(c.limit(2e-3, 1.0, 1e-3, 1e-3) == doctest::Approx(1e-4).epsilon(1e-15));
    CHECK(c.limit(1e-3, 1.0, 1e-6) == c.limit(1e-3, 1.0, 1e-3, 1e-6));            // one spacing: the old form
    CHECK(c.limit(2e-3, 0.0, 1e-3, 0.0) == p.dt_max);                             // at rest, inviscid
  }

  TEST_CASE("scheme: the Δt ladder collapses at dt_max / 2^max_halvings whatever its ratio") {
    for (const double r : {2.0, std::pow(2.0, 0.25), 1.05}) {
      CAPTURE(r);
      scheme::time_step_params p;
      p.ratio = r;
      p.max_halvings = 20;
      scheme::time_step_controller above(p), below(p);
      // The deepest rung is the last one at or above dt_max / 2^20 (what a checkpoint's rung is checked
      // against).
      CHECK(std::pow(r, -above.max_rungs()) <= std::exp2(-20.0) * (1.0 + 1e-12));
      CHECK(std::pow(r, -(above.max_rungs() - 1)) > std::exp2(-20.0));
      if (r == 2.0) CHECK(above.max_rungs() == 20);
      CHECK_NOTHROW(step_to(above, p.dt_max * std::exp2(-19.9)));
      CHECK_THROWS_WITH_AS(step_to(below, p.dt_max * std::exp2(-20.0 - std::log2(r) - 1e-3), 42),
                           doctest::Contains("time step collapsed at step 42"), mpskit::error);
    }
  }

  TEST_CASE("scheme: max_speed is a blow-up bound, off by default, refused when not > 0") {
    scheme::time_step_params p;
    CHECK(std::isinf(p.max_speed));  // default: no bound
    CHECK_NOTHROW(scheme::time_step_controller(p).check_speed(1e300, 1, 2));
    p.max_speed = 10.0;
    const scheme::time_step_controller c(p);
    CHECK_NOTHROW(c.check_speed(10.0, 7, 3));  // at the bound: allowed
    CHECK_THROWS_WITH_AS(c.check_speed(std::nextafter(10.0, 11.0), 7, 3),
                         doctest::Contains("blow-up at step 7: particle 3 moves at |u| = 10"), mpskit::error);
    for (const double bad : {0.0, -1.0, std::nan("")}) {
      CAPTURE(bad);
      p.max_speed = bad;
      CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("max_speed"), mpskit::error);
    }
  }
}

namespace {
// A solver recording Eigen::nbThreads() inside its compute and solve (Eigen's sparse × dense product reads it
// at every call).
struct recording_solver {
  static constexpr bool requires_symmetric = false;
  int in_compute = 0, in_solve = 0;
  Eigen::ComputationInfo compute(const ppe::matrix&) {
    in_compute = Eigen::nbThreads();
    return Eigen::Success;
  }
  ppe::solve_report solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    in_solve = Eigen::nbThreads();
    x = b;
    return {};
  }
};
}  // namespace

TEST_SUITE("threads") {
  TEST_CASE("core: reductions are bitwise identical for 1 and 2 threads") {
#ifdef _OPENMP
    const index_t n = 10 * reduction_block + 123;
    std::mt19937_64 rng(seed_from_env());
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    std::vector<double> v(static_cast<std::size_t>(n));
    for (auto& x : v) x = U(rng) * std::exp(20.0 * U(rng));  // wide range: association matters
    auto map = [&](index_t i) { return v[static_cast<std::size_t>(i)]; };
    omp_set_num_threads(1);
    const double s1 = reduce_sum(exec::par{}, n, map);
    omp_set_num_threads(2);
    const double s2 = reduce_sum(exec::par{}, n, map);
    CHECK(s1 == s2);
#else
    MESSAGE("built without OpenMP: exec::par is sequential, nothing to compare");
#endif
  }

  TEST_CASE("core: Eigen's own threads are held to one for systems below parallel_min_items, then restored") {
#ifdef _OPENMP
    // ppe::solve_checked must hold Eigen to 1 thread for a small system and leave a large one alone.
    static_assert(ppe::LinearSolver<recording_solver>);
    omp_set_num_threads(2);
    Eigen::setNbThreads(0);  // follow OpenMP (Eigen's default)
    REQUIRE(Eigen::nbThreads() == 2);
    const auto identity = [](index_t n) {
      ppe::matrix A(n, n);
      A.setIdentity();
      return A;
    };
    const auto describe = [](index_t r) { return std::to_string(r); };
    for (const index_t n : {index_t{100}, parallel_min_items - 1, parallel_min_items}) {
      CAPTURE(n);
      const ppe::matrix A = identity(n);
      const Eigen::VectorXd b = Eigen::VectorXd::Ones(n);
      Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
      recording_solver s;
      ppe::solve_checked(s, A, b, x, ppe::solver_params{}, 0, 0.0, describe);
      const int expected = n < parallel_min_items ? 1 : 2;
      CHECK(s.in_compute == expected);
      CHECK(s.in_solve == expected);
      CHECK(Eigen::nbThreads() == 2);  // restored
    }
    // parallel_min_rows = 0 (solver_params): Eigen threads every system.
    {
      const ppe::matrix A = identity(100);
      const Eigen::VectorXd b = Eigen::VectorXd::Ones(100);
      Eigen::VectorXd x = Eigen::VectorXd::Zero(100);
      recording_solver s;
      ppe::solver_params sp;
      sp.parallel_min_rows = 0;
      ppe::solve_checked(s, A, b, x, sp, 0, 0.0, describe);
      CHECK(s.in_solve == 2);
    }
    // Following OpenMP is restored as such: a later omp_set_num_threads still reaches Eigen.
    { const eigen_threads_scope hold(10); CHECK(hold.held()); CHECK(Eigen::nbThreads() == 1); }
    omp_set_num_threads(1);
    CHECK(Eigen::nbThreads() == 1);
    omp_set_num_threads(2);
    CHECK(Eigen::nbThreads() == 2);
    // A value the caller pinned (other than OpenMP's) comes back pinned; with one thread nothing is held.
    Eigen::setNbThreads(3);
    { const eigen_threads_scope hold(10); CHECK(Eigen::nbThreads() == 1); }
    CHECK(Eigen::nbThreads() == 3);
    Eigen::setNbThreads(1);
    { const eigen_threads_scope hold(10); CHECK_FALSE(hold.held()); }
    CHECK(Eigen::nbThreads() == 1);
    Eigen::setNbThreads(0);
#else
    MESSAGE("built without OpenMP: Eigen runs on one thread, nothing to hold");
#endif
  }
}

TEST_SUITE("bad_input") {
  TEST_CASE("core: validate names non-finite fields, size mismatches, ghost roles and duplicate ids") {
    rich_state s = make_state(5);
    s.validate();
    s.x()(1, 3) = std::nan("");
    CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("'position' of particle 3"), mpskit::error);
    s.x()(1, 3) = 0.0;
    s.get<field::pressure>()[2] = INFINITY;
    CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("'pressure' of particle 2"), mpskit::error);
    s.get<field::pressure>().resize(4);
    CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("'pressure' has 4 entries"), mpskit::error);
  }

  TEST_CASE("core: the resize path refuses bad permutations, masks and ghost misuse") {
    rich_state s = make_state(4);
    CHECK_THROWS_WITH_AS(s.reorder({0, 1, 2}), doctest::Contains("3 entries"), mpskit::error);
    CHECK_THROWS_WITH_AS(s.reorder({0, 1, 1, 3}), doctest::Contains("not a permutation"), mpskit::error);
    CHECK_THROWS_WITH_AS(s.reorder({0, 1, 2, 4}), doctest::Contains("not a permutation"), mpskit::error);
    CHECK_THROWS_AS(s.remove(std::vector<char>(3, 0)), mpskit::error);
    CHECK_THROWS_AS(s.append(-1, kind::fluid), mpskit::error);
    CHECK_THROWS_AS(s.add_ghosts(1, ghost_role::none), mpskit::error);
    s.add_ghosts(2, ghost_role::imaginary);
    CHECK_THROWS_WITH_AS(s.reorder({0, 1, 2, 3}), doctest::Contains("ghosts"), mpskit::error);
    CHECK_THROWS_AS(s.promote_ghosts({1}), mpskit::error);  // not a ghost
    s.clear_ghosts();
    CHECK(s.size() == 4);
  }

  TEST_CASE("scheme: the Δt ladder refuses a ratio outside [1.001, 2]") {
    for (const double r : {1.0, 1.0005, 0.5, 2.5, std::nan("")}) {
      CAPTURE(r);
      scheme::time_step_params p;
      p.ratio = r;
      CHECK_THROWS_WITH_AS(scheme::time_step_controller{p}, doctest::Contains("time_step_params.ratio"),
                           mpskit::error);
    }
  }

  TEST_CASE("core: validator lists every bad value with its accepted range") {
    validator v("test_params");
    v.positive("l0", 0.0).positive("rho", 1000.0).in_range("alpha", 2.0, 0.0, 1.0).finite("g", std::nan(""));
    CHECK(v.problems().size() == 3);
    try {
      v.throw_if_any();
      FAIL("no throw");
    } catch (const mpskit::error& e) {
      const std::string m = e.what();
      CHECK(m.find("test_params.l0 = 0: must be a finite number > 0") != std::string::npos);
      CHECK(m.find("test_params.alpha = 2: must be in [0, 1]") != std::string::npos);
      CHECK(m.find("test_params.g = nan") != std::string::npos);
      CHECK(m.find("rho") == std::string::npos);
    }
  }
}
