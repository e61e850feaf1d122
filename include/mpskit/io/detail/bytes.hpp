#pragma once
/// \file io/detail/bytes.hpp
/// \brief Byte buffers, base64 (RFC 4648 §4), the FNV-1a 64-bit checksum and atomic file writes
/// (temporary file in the target's directory, then std::filesystem::rename) shared by io/.
#include <array>
#include <bit>
#include <cstddef>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#if __has_include(<unistd.h>)
#include <unistd.h>
#define MPSKIT_IO_HAS_POSIX 1
#else
#define MPSKIT_IO_HAS_POSIX 0
#endif

#include "mpskit/core/error.hpp"

namespace mpskit::io::detail {

/// True on the machines mpskit's binary formats are written for (little-endian, IEEE-754 doubles).
inline constexpr bool little_endian = std::endian::native == std::endian::little;
static_assert(std::numeric_limits<double>::is_iec559, "mpskit: io needs IEEE-754 doubles");

/// Appends the object representation of trivially copyable values to a byte buffer.
template <class T>
void append_raw(std::string& out, const T* data, std::size_t count) {
  static_assert(std::is_trivially_copyable_v<T>);
  if (count == 0) return;
  out.append(reinterpret_cast<const char*>(data), count * sizeof(T));
}
template <class T>
void append_value(std::string& out, const T& v) {
  append_raw(out, &v, 1);
}

/// Base64 encoding (RFC 4648 §4, with '=' padding, no line breaks).
inline void base64_encode(std::string_view in, std::string& out) {
  static constexpr char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = reinterpret_cast<const unsigned char*>(in.data());
  const std::size_t n = in.size();
  out.reserve(out.size() + 4 * ((n + 2) / 3));
  std::size_t i = 0;
  for (; i + 3 <= n; i += 3) {
    const std::uint32_t v = (std::uint32_t{p[i]} << 16) | (std::uint32_t{p[i + 1]} << 8) | p[i + 2];
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += table[(v >> 6) & 63];
    out += table[v & 63];
  }
  if (i < n) {
    const bool two = i + 1 < n;
    const std::uint32_t v = (std::uint32_t{p[i]} << 16) | (two ? std::uint32_t{p[i + 1]} << 8 : 0u);
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += two ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
}

/// Base64 decoding. Whitespace is skipped; a padded quartet may be followed by another base64 stream
/// (VTK readers and writers sometimes encode a block's header and its data separately). Returns false
/// on a character outside the alphabet or a dangling partial quartet.
inline bool base64_decode(std::string_view in, std::string& out) {
  static constexpr auto table = [] {
    std::array<signed char, 256> t{};
    t.fill(-1);
    const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int k = 0; k < 64; ++k) t[static_cast<unsigned char>(a[k])] = static_cast<signed char>(k);
    return t;
  }();
  out.reserve(out.size() + in.size() / 4 * 3);
  int quad[4];
  int nq = 0, pad = 0;
  for (const char c : in) {
    if (c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
    if (c == '=') {
      if (nq < 2) return false;
      ++pad;
      quad[nq++] = 0;
    } else {
      const int v = table[static_cast<unsigned char>(c)];
      if (v < 0 || pad > 0) return false;
      quad[nq++] = v;
    }
    if (nq == 4) {
      const std::uint32_t v = (std::uint32_t(quad[0]) << 18) | (std::uint32_t(quad[1]) << 12) |
                              (std::uint32_t(quad[2]) << 6) | std::uint32_t(quad[3]);
      out += static_cast<char>((v >> 16) & 0xff);
      if (pad < 2) out += static_cast<char>((v >> 8) & 0xff);
      if (pad < 1) out += static_cast<char>(v & 0xff);
      nq = 0;
      pad = 0;
    }
  }
  return nq == 0;
}

/// FNV-1a, 64-bit (Fowler, Noll & Vo; offset basis 14695981039346656037, prime 1099511628211).
inline std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t h = 14695981039346656037ull) {
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  return h;
}

/// Reads a whole file; throws mpskit::error naming `what` and the path when it cannot be opened or read.
inline std::string read_file(const std::filesystem::path& path, std::string_view what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(what, ": cannot open '", path.string(), "' for reading");
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) fail(what, ": error while reading '", path.string(), "'");
  return s;
}

/// Writes `content` to `path` atomically: a temporary file beside it ("<name>.tmp-<pid>") is written,
/// flushed (and fsync'ed on POSIX), then renamed over `path`. Readers see the old file or the new one,
/// never a part. Throws mpskit::error naming the path and the reason.
inline void write_file_atomic(const std::filesystem::path& path, std::string_view content, std::string_view what) {
  if (path.empty()) fail(what, ": empty output path");
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    fail(what, ": cannot write '", path.string(), "': directory '", dir.string(), "' does not exist");
#if MPSKIT_IO_HAS_POSIX
  const long pid = static_cast<long>(::getpid());
#else
  const long pid = 0;
#endif
  std::filesystem::path tmp = path;
  tmp += ".tmp-" + std::to_string(pid);
  std::FILE* f = std::fopen(tmp.string().c_str(), "wb");
  if (!f) fail(what, ": cannot write '", path.string(), "': cannot create '", tmp.string(), "' (", std::strerror(errno), ")");
  bool ok = content.empty() || std::fwrite(content.data(), 1, content.size(), f) == content.size();
  ok = std::fflush(f) == 0 && ok;
#if MPSKIT_IO_HAS_POSIX
  ok = ::fsync(::fileno(f)) == 0 && ok;
#endif
  ok = std::fclose(f) == 0 && ok;
  if (!ok) {
    std::filesystem::remove(tmp, ec);
    fail(what, ": writing '", tmp.string(), "' failed (disk full or I/O error); '", path.string(), "' is unchanged");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ec2;
    std::filesystem::remove(tmp, ec2);
    fail(what, ": cannot rename '", tmp.string(), "' to '", path.string(), "': ", ec.message());
  }
}

}  // namespace mpskit::io::detail
