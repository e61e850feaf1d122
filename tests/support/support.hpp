#pragma once
// Shared test helpers: point sets, scratch directories and bitwise comparisons (one definition for every
// suite).
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <system_error>
#include <vector>

#if __has_include(<unistd.h>)
#include <unistd.h>
#endif

#include "mpskit/core/dimension.hpp"

namespace mpskit::test {

/// m^D lattice of spacing h (m^2 in 2D), each coordinate jittered uniformly by ±jitter·h.
template <int D>
points<D> jittered_lattice(int m, double h, double jitter, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-jitter, jitter);
  const int mz = D == 3 ? m : 1;
  points<D> x(D, static_cast<index_t>(m) * m * mz);
  index_t k = 0;
  for (int c = 0; c < mz; ++c)
    for (int b = 0; b < m; ++b)
      for (int a = 0; a < m; ++a, ++k) {
        x(0, k) = (a + U(rng)) * h;
        x(1, k) = (b + U(rng)) * h;
        if constexpr (D == 3) x(2, k) = (c + U(rng)) * h;
      }
  return x;
}

/// The same bits (restart tests: a resumed run against the uninterrupted one; −0.0 ≠ 0.0, a NaN equals the
/// same NaN): two doubles, two std::vectors, or two Eigen matrices or arrays that own their storage (the same
/// shape; expressions and strided views are not accepted: copy them into a plain object).
inline bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}
template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), sizeof(T) * a.size()) == 0);
}
template <class Derived>
bool same_bits(const Eigen::PlainObjectBase<Derived>& a, const Eigen::PlainObjectBase<Derived>& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 ||
          std::memcmp(a.data(), b.data(), sizeof(*a.data()) * static_cast<std::size_t>(a.size())) == 0);
}

/// A scratch directory (temp dir / "<prefix>_<pid>_<name>") removed at the end of the test.
struct scratch {
  std::filesystem::path dir;  ///< the directory
  scratch(const std::string& prefix, const std::string& name) {
#if __has_include(<unistd.h>)
    const long pid = static_cast<long>(::getpid());
#else
    const long pid = 0;
#endif
    dir = std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(pid) + "_" + name);
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  ~scratch() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  scratch(const scratch&) = delete;
  scratch& operator=(const scratch&) = delete;
  /// A path inside the directory.
  std::filesystem::path operator/(const std::string& f) const { return dir / f; }
};

}  // namespace mpskit::test
