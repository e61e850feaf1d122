// The line-length rule of ../shared/STYLE.md "Formatting" (ColumnLimit: 110), checked in CTest (label
// style): `mpskit_line_length MAX PATH...` prints every line of the C++ sources (.hpp, .cpp) under each
// directory PATH, or of each file PATH whatever its name, that is longer than MAX columns, and exits 1 if
// there is one (2 on bad arguments or an unreadable path).
// Columns are UTF-8 code points (the sources use −, ≤, √, ...; bytes would count them 2–3 times). Not a
// formatter: `git clang-format` (clang-format 14, the project's .clang-format) formats changed lines.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

std::size_t code_points(const std::string& line) {
  std::size_t n = 0;
  // every byte that is not a UTF-8 continuation byte starts a code point
  for (const unsigned char c : line) if ((c & 0xC0u) != 0x80u) ++n;
  return n;
}

// Prints the file's lines over `max` columns; returns how many.
std::size_t check(const std::filesystem::path& file, std::size_t max) {
  std::ifstream in(file);
  if (!in) {
    std::fprintf(stderr, "mpskit_line_length: cannot read '%s'\n", file.c_str());
    std::exit(2);
  }
  std::size_t bad = 0, number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (const std::size_t n = code_points(line); n > max) {
      std::printf("%s:%zu: %zu columns (limit %zu)\n", file.c_str(), number, n, max);
      ++bad;
    }
  }
  return bad;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: mpskit_line_length MAX PATH...\n");
    return 2;
  }
  char* end = nullptr;
  const long max = std::strtol(argv[1], &end, 10);
  if (end == argv[1] || *end != '\0' || max <= 0) {
    std::fprintf(stderr, "mpskit_line_length: MAX must be a positive whole number, got '%s'\n", argv[1]);
    return 2;
  }
  std::size_t bad = 0, files = 0;
  for (int a = 2; a < argc; ++a) {
    const std::filesystem::path p(argv[a]);
    if (std::filesystem::is_regular_file(p)) {
      bad += check(p, static_cast<std::size_t>(max));
      ++files;
    } else if (std::filesystem::is_directory(p)) {
      for (const auto& e : std::filesystem::recursive_directory_iterator(p)) {
        const auto ext = e.path().extension();
        if (!e.is_regular_file() || (ext != ".hpp" && ext != ".cpp")) continue;
        bad += check(e.path(), static_cast<std::size_t>(max));
        ++files;
      }
    } else {
      std::fprintf(stderr, "mpskit_line_length: no such file or directory '%s'\n", argv[a]);
      return 2;
    }
  }
  std::printf("mpskit_line_length: %zu files, %zu lines over %ld columns\n", files, bad, max);
  return bad == 0 ? 0 : 1;
}
