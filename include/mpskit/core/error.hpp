#pragma once
/// \file core/error.hpp
/// \brief mpskit::error (configuration, I/O and numerical failures) and MPSKIT_ASSERT.
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace mpskit {

/// \brief The one exception type of mpskit; messages name the parameter, file, line or particle and
/// the accepted range (ARCHITECTURE.md §6).
class error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {
/// Builds a message from stream-able pieces (g++ 12 has no <format>).
template <class... Args>
std::string concat(Args&&... args) {
  std::ostringstream os;
  os.precision(17);
  (os << ... << std::forward<Args>(args));
  return os.str();
}

[[noreturn]] inline void assert_fail(const char* expr, const char* file, int line) {
  std::fprintf(stderr, "mpskit: assertion failed: %s (%s:%d)\n", expr, file, line);
  std::abort();
}
}  // namespace detail

/// Throws mpskit::error with the pieces concatenated ("mpskit: " prefix added).
template <class... Args>
[[noreturn]] void fail(Args&&... args) {
  throw error(detail::concat("mpskit: ", std::forward<Args>(args)...));
}

}  // namespace mpskit

/// Precondition check, compiled out with NDEBUG like eigen_assert (STYLE.md "Runtime checks").
#ifdef NDEBUG
#define MPSKIT_ASSERT(cond) ((void)0)
#else
#define MPSKIT_ASSERT(cond) ((cond) ? (void)0 : ::mpskit::detail::assert_fail(#cond, __FILE__, __LINE__))
#endif
