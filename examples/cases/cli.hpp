#pragma once
// Command-line numbers for the examples and the benchmarks: the whole text must be a finite number within its
// bound, else an mpskit::error names the option and the text. Never atof's silent 0 (`--collision abc` read
// as 0 would switch a stage off without a word).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "mpskit/core/error.hpp"

namespace mpskit::cases {

/// A number >= lo from a command-line value (any finite number with the default lo); mpskit::error naming
/// `what` otherwise (no silent atof zero).
inline double parse_number(const char* what, const std::string& s, double lo = -HUGE_VAL) {
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !(x >= lo) || !std::isfinite(x)) {
    if (lo == -HUGE_VAL) fail(what, " '", s, "': must be a finite number");
    char bound[32];
    std::snprintf(bound, sizeof bound, "%g", lo);
    fail(what, " '", s, "': must be a finite number >= ", bound);
  }
  return x;
}

/// A comma-separated list of numbers >= lo ("3,3.5,4"); mpskit::error naming `what` and the bad entry
/// otherwise.
inline std::vector<double> parse_numbers(const char* what, const std::string& s, double lo) {
  std::vector<double> v;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) v.push_back(parse_number(what, item, lo));
  if (v.empty()) fail(what, ": an empty list");
  return v;
}

/// x as an int; mpskit::error naming `what` when x is not a whole number.
inline int whole_number(const char* what, double x) {
  if (x != std::floor(x) || std::abs(x) > 1e9) fail(what, ": ", x, " is not a whole number");
  return static_cast<int>(x);
}

/// A whole number >= lo; mpskit::error naming `what` otherwise.
inline int parse_integer(const char* what, const std::string& s, int lo) {
  return whole_number(what, parse_number(what, s, lo));
}

/// A comma-separated list of whole numbers >= lo ("25,50"); mpskit::error naming `what` and the bad entry
/// otherwise.
inline std::vector<int> parse_integers(const char* what, const std::string& s, int lo) {
  std::vector<int> v;
  for (const double x : parse_numbers(what, s, lo)) v.push_back(whole_number(what, x));
  return v;
}

/// Walks a command line (argv[1 .. argc-1]) through `read(arg, value)`, which returns false for an option it
/// does not know and calls `value()` for the text after an option that takes one; mpskit::error naming `who`
/// and the option when it is unknown or its value is missing (no option silently ignored).
template <class Read>
void read_command_line(const char* who, int argc, const char* const* argv, Read read) {
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    const auto value = [&]() -> std::string {
      if (a + 1 >= argc) fail(who, ": ", arg, " needs a value");
      return argv[++a];
    };
    if (!read(arg, value)) fail(who, ": unknown option '", arg, "'");
  }
}

}  // namespace mpskit::cases
