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
#include <initializer_list>
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

/// Base64 encoding (RFC 4648 §4, with '=' padding, no line breaks), appended to `out`.
inline void base64_encode(std::string_view in, std::string& out) {
  static constexpr char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = reinterpret_cast<const unsigned char*>(in.data());
  const std::size_t n = in.size();
  const std::size_t base = out.size();
  out.resize(base + 4 * ((n + 2) / 3));
  char* o = out.data() + base;
  std::size_t i = 0;
  for (; i + 3 <= n; i += 3) {
    const std::uint32_t v = (std::uint32_t{p[i]} << 16) | (std::uint32_t{p[i + 1]} << 8) | p[i + 2];
    *o++ = table[(v >> 18) & 63];
    *o++ = table[(v >> 12) & 63];
    *o++ = table[(v >> 6) & 63];
    *o++ = table[v & 63];
  }
  if (i < n) {
    const bool two = i + 1 < n;
    const std::uint32_t v = (std::uint32_t{p[i]} << 16) | (two ? std::uint32_t{p[i + 1]} << 8 : 0u);
    *o++ = table[(v >> 18) & 63];
    *o++ = table[(v >> 12) & 63];
    *o++ = two ? table[(v >> 6) & 63] : '=';
    *o++ = '=';
  }
}

/// Base64 decoding. Whitespace is skipped; a padded quartet may be followed by another base64 stream
/// (VTK readers and writers sometimes encode a block's header and its data separately). Returns false
/// on a character outside the alphabet or a dangling partial quartet.
inline bool base64_decode(std::string_view in, std::string& out) {
  // Table: 0..63 alphabet, 64 '=', 65 whitespace, 255 invalid.
  static constexpr auto table = [] {
    std::array<unsigned char, 256> t{};
    t.fill(255);
    const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int k = 0; k < 64; ++k) t[static_cast<unsigned char>(a[k])] = static_cast<unsigned char>(k);
    t['='] = 64;
    for (const char c : {' ', '\n', '\r', '\t'}) t[static_cast<unsigned char>(c)] = 65;
    return t;
  }();
  const std::size_t base = out.size();
  out.resize(base + in.size() / 4 * 3 + 3);
  char* o = out.data() + base;
  const auto* p = reinterpret_cast<const unsigned char*>(in.data());
  const auto* e = p + in.size();
  unsigned quad[4];
  int nq = 0, pad = 0;
  while (p < e) {
    // Fast path: four alphabet characters in a row at a quartet boundary.
    if (nq == 0 && e - p >= 4) {
      const unsigned a = table[p[0]], b = table[p[1]], c = table[p[2]], d = table[p[3]];
      if ((a | b | c | d) < 64) {
        const std::uint32_t v = (a << 18) | (b << 12) | (c << 6) | d;
        *o++ = static_cast<char>(v >> 16);
        *o++ = static_cast<char>((v >> 8) & 0xff);
        *o++ = static_cast<char>(v & 0xff);
        p += 4;
        continue;
      }
    }
    const unsigned v = table[*p++];
    if (v == 65) continue;
    if (v == 255) return false;
    if (v == 64) {
      if (nq < 2) return false;
      ++pad;
      quad[nq++] = 0;
    } else {
      if (pad > 0) return false;
      quad[nq++] = v;
    }
    if (nq == 4) {
      const std::uint32_t w = (quad[0] << 18) | (quad[1] << 12) | (quad[2] << 6) | quad[3];
      *o++ = static_cast<char>((w >> 16) & 0xff);
      if (pad < 2) *o++ = static_cast<char>((w >> 8) & 0xff);
      if (pad < 1) *o++ = static_cast<char>(w & 0xff);
      nq = 0;
      pad = 0;
    }
  }
  out.resize(static_cast<std::size_t>(o - out.data()));
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
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) fail(what, ": cannot open '", path.string(), "' for reading");
  const std::streamoff size = in.tellg();
  if (size < 0) fail(what, ": cannot determine the size of '", path.string(), "'");
  std::string s(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  if (size > 0 && !in.read(s.data(), size)) fail(what, ": error while reading '", path.string(), "'");
  return s;
}

/// Writes the concatenation of `parts` to `path` atomically: a temporary file beside it ("<name>.tmp-<pid>")
/// is written, flushed (and fsync'ed on POSIX), then renamed over `path`. Readers see the old file or the new
/// one, never a part. Throws mpskit::error naming the path and the reason.
inline void write_file_atomic(const std::filesystem::path& path,
                              std::initializer_list<std::string_view> parts, std::string_view what) {
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
  if (!f)
    fail(what, ": cannot write '", path.string(), "': cannot create '", tmp.string(), "' (",
         std::strerror(errno), ")");
  bool ok = true;
  for (const std::string_view content : parts)
    ok = ok && (content.empty() || std::fwrite(content.data(), 1, content.size(), f) == content.size());
  ok = std::fflush(f) == 0 && ok;
#if MPSKIT_IO_HAS_POSIX
  ok = ::fsync(::fileno(f)) == 0 && ok;
#endif
  ok = std::fclose(f) == 0 && ok;
  if (!ok) {
    std::filesystem::remove(tmp, ec);
    fail(what, ": writing '", tmp.string(), "' failed (disk full or I/O error); '", path.string(),
         "' is unchanged");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ec2;
    std::filesystem::remove(tmp, ec2);
    fail(what, ": cannot rename '", tmp.string(), "' to '", path.string(), "': ", ec.message());
  }
}

}  // namespace mpskit::io::detail
