#pragma once
/// \file io/checkpoint.hpp
/// \brief Binary checkpoints: the whole particle state (order, ids, next id, real/ghost counts, every
/// field bitwise) plus named sections a scheme registers (time, step, time-step controller, counters),
/// versioned, checksummed (FNV-1a 64 over the payload) and written atomically. Layout: docs/io.md.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/io/concepts.hpp"
#include "mpskit/io/detail/bytes.hpp"
#include "mpskit/io/detail/type_names.hpp"

namespace mpskit::io {

/// The checkpoint format version this mpskit writes and reads.
inline constexpr std::uint32_t checkpoint_version = 1;
/// The 8 bytes every checkpoint starts with.
inline constexpr std::string_view checkpoint_magic{"MPSKITCP", 8};

/// What a section holds.
enum class section_type : std::uint8_t {
  bytes = 0,    ///< opaque bytes
  doubles = 1,  ///< IEEE-754 doubles (restored bitwise)
  int64 = 2     ///< signed 64-bit integers
};

/// \brief Named sections saved beside the particles: each scheme or policy adds its own (names must be
/// unique) and reads them back after load_checkpoint. Reading a missing section or the wrong type
/// throws mpskit::error naming the section and the checkpoint file.
class checkpoint_sections {
 public:
  /// Adds opaque bytes.
  void add_bytes(std::string name, std::string bytes) {
    insert(std::move(name), section_type::bytes, std::move(bytes), 1);
  }
  /// Adds doubles.
  void add_doubles(std::string name, const std::vector<double>& v) {
    insert_values(std::move(name), section_type::doubles, v);
  }
  /// Adds 64-bit integers.
  void add_int64s(std::string name, const std::vector<std::int64_t>& v) {
    insert_values(std::move(name), section_type::int64, v);
  }
  /// Adds one double.
  void add(std::string name, double v) { add_doubles(std::move(name), {v}); }
  /// Adds one 64-bit integer.
  void add(std::string name, std::int64_t v) { add_int64s(std::move(name), {v}); }

  /// The bytes of a section.
  const std::string& get_bytes(std::string_view name) const { return find(name, section_type::bytes).data; }
  /// The doubles of a section.
  std::vector<double> get_doubles(std::string_view name) const {
    return values<double>(name, section_type::doubles);
  }
  /// The integers of a section.
  std::vector<std::int64_t> get_int64s(std::string_view name) const {
    return values<std::int64_t>(name, section_type::int64);
  }
  /// The one double of a section.
  double get_double(std::string_view name) const { return one<double>(name, section_type::doubles); }
  /// The one integer of a section.
  std::int64_t get_int64(std::string_view name) const { return one<std::int64_t>(name, section_type::int64); }

  /// True when a section of this name exists.
  bool contains(std::string_view name) const {
    return std::any_of(s_.begin(), s_.end(), [&](const section& s) { return s.name == name; });
  }
  /// Section names in insertion order.
  std::vector<std::string> names() const {
    std::vector<std::string> v;
    for (const auto& s : s_) v.push_back(s.name);
    return v;
  }
  /// Number of sections.
  std::size_t size() const { return s_.size(); }
  /// Where the sections were read from ("" when built in memory); used in messages.
  const std::string& origin() const { return origin_; }

 private:
  struct section {
    std::string name;
    section_type type;
    std::uint64_t count;  // elements (bytes: byte count)
    std::string data;
  };
  friend struct checkpoint_access;

  std::string where() const {
    return origin_.empty() ? std::string("checkpoint sections") : "checkpoint '" + origin_ + "'";
  }
  void insert(std::string name, section_type t, std::string data, std::size_t elem) {
    if (name.empty()) fail("checkpoint_sections: empty section name");
    if (contains(name)) fail(where(), ": section '", name, "' added twice (section names must be unique)");
    const std::uint64_t count = data.size() / elem;
    s_.push_back({std::move(name), t, count, std::move(data)});
  }
  template <class T>
  void insert_values(std::string name, section_type t, const std::vector<T>& v) {
    std::string d;
    detail::append_raw(d, v.data(), v.size());
    insert(std::move(name), t, std::move(d), sizeof(T));
  }
  const section& find(std::string_view name, section_type t) const {
    for (const auto& s : s_) {
      if (s.name != name) continue;
      if (s.type != t)
        fail(where(), ": section '", name, "' holds ", type_name(s.type), ", not ", type_name(t));
      return s;
    }
    fail(where(), ": no section '", name, "' (sections: ", joined(), ")");
  }
  template <class T>
  std::vector<T> values(std::string_view name, section_type t) const {
    const section& s = find(name, t);
    std::vector<T> v(s.data.size() / sizeof(T));
    if (!v.empty()) std::memcpy(v.data(), s.data.data(), v.size() * sizeof(T));
    return v;
  }
  template <class T>
  T one(std::string_view name, section_type t) const {
    const std::vector<T> v = values<T>(name, t);
    if (v.size() != 1) fail(where(), ": section '", name, "' holds ", v.size(), " values, expected 1");
    return v.front();
  }
  static const char* type_name(section_type t) {
    return t == section_type::bytes ? "bytes" : t == section_type::doubles ? "doubles" : "int64";
  }
  std::string joined() const {
    std::string j;
    for (const auto& s : s_) j += (j.empty() ? "" : ", ") + s.name;
    return j.empty() ? std::string("none") : j;
  }

  std::vector<section> s_;
  std::string origin_;
};

namespace detail {

/// Bounds-checked reading of a checkpoint payload.
class byte_reader {
 public:
  byte_reader(std::string_view s, const std::string& file) : s_(s), file_(file) {}
  template <class T>
  T value(const char* what) {
    T v;
    std::memcpy(&v, take(sizeof(T), what), sizeof(T));
    return v;
  }
  const char* take(std::size_t n, const char* what) {
    if (n > s_.size() - p_)
      fail("load_checkpoint: '", file_, "': payload ends inside ", what, " (corrupted)");
    const char* r = s_.data() + p_;
    p_ += n;
    return r;
  }
  std::string string(const char* what) {
    const std::uint32_t n = value<std::uint32_t>(what);
    return std::string(take(n, what), n);
  }
  bool done() const { return p_ == s_.size(); }

 private:
  std::string_view s_;
  const std::string& file_;
  std::size_t p_ = 0;
};

inline void append_string(std::string& out, std::string_view s) {
  append_value(out, static_cast<std::uint32_t>(s.size()));
  out.append(s);
}

/// Element type code and components of field T in dimension D.
template <class T, int D>
struct field_layout {
  using V = std::conditional_t<T::shape == field_shape::scalar || T::shape == field_shape::vector, double,
                               underlying_t<typename T::value_type>>;
  static constexpr int components = T::shape == field_shape::vector ? D : 1;
  static constexpr std::string_view type = vtk_type_name<V>();
};

}  // namespace detail

/// Gives load/save access to the sections' storage.
struct checkpoint_access {
  static auto& list(checkpoint_sections& s) { return s.s_; }
  static const auto& list(const checkpoint_sections& s) { return s.s_; }
  static void set_origin(checkpoint_sections& s, std::string o) { s.origin_ = std::move(o); }
};

/// \brief Writes the state and the sections to `path` atomically (temporary file + rename): magic,
/// version, dimension, payload size, FNV-1a 64 checksum, then the payload (layout, every field in the
/// state's order with name, units, shape, type and raw values, then the sections). Throws mpskit::error
/// naming the path.
template <ParticleState State>
void save_checkpoint(const std::filesystem::path& path, const State& state,
                     const checkpoint_sections& sections = {}) {
  constexpr int D = State::dim;
  if (!detail::little_endian)
    fail("save_checkpoint: '", path.string(), "': big-endian machines are not supported");
  std::string payload;
  detail::append_value(payload, static_cast<std::uint64_t>(state.n_real()));
  detail::append_value(payload, static_cast<std::uint64_t>(state.n_ghost()));
  detail::append_value(payload, static_cast<std::uint64_t>(state.next_id()));
  detail::append_value(payload, static_cast<std::uint32_t>(State::fields::size));
  State::for_each_field([&](auto tag) {
    using T = decltype(tag);
    using L = detail::field_layout<T, D>;
    const auto& s = state.template get<T>();
    detail::append_string(payload, T::name);
    detail::append_string(payload, T::units);
    detail::append_value(payload, static_cast<std::uint8_t>(T::shape));
    detail::append_string(payload, L::type);
    detail::append_value(payload, static_cast<std::uint32_t>(L::components));
    const std::size_t n = static_cast<std::size_t>(state.size()) * L::components;
    detail::append_value(payload, static_cast<std::uint64_t>(n * sizeof(typename L::V)));
    detail::append_raw(payload, reinterpret_cast<const typename L::V*>(s.data()), n);
  });
  const auto& list = checkpoint_access::list(sections);
  detail::append_value(payload, static_cast<std::uint32_t>(list.size()));
  for (const auto& sec : list) {
    detail::append_string(payload, sec.name);
    detail::append_value(payload, static_cast<std::uint8_t>(sec.type));
    detail::append_value(payload, static_cast<std::uint64_t>(sec.data.size()));
    payload += sec.data;
  }
  std::string header(checkpoint_magic);
  detail::append_value(header, checkpoint_version);
  detail::append_value(header, static_cast<std::uint32_t>(D));
  detail::append_value(header, static_cast<std::uint64_t>(payload.size()));
  detail::append_value(header, detail::fnv1a64(payload));
  detail::write_file_atomic(path, {header, payload}, "save_checkpoint");
}

/// \brief Reads a checkpoint into `state` (every field, order, ids, counts, next id) and `sections`.
/// Refuses, with an mpskit::error naming the file and the problem: a wrong magic or version, another
/// dimension, a truncated or extended file, a checksum mismatch, a field list that differs from the
/// state's (name, order, shape, type). The state is validated after loading.
template <ParticleState State>
void load_checkpoint(const std::filesystem::path& path, State& state, checkpoint_sections& sections) {
  constexpr int D = State::dim;
  const std::string file = path.string();
  auto bad = [&](auto&&... m) { fail("load_checkpoint: '", file, "': ", m...); };
  if (!detail::little_endian) bad("big-endian machines are not supported");
  const std::string src = detail::read_file(path, "load_checkpoint");
  if (src.size() < 8 || std::string_view(src).substr(0, 8) != checkpoint_magic)
    bad("not an mpskit checkpoint (wrong magic; expected \"MPSKITCP\")");
  if (src.size() < 32) bad("truncated: ", src.size(), " bytes, shorter than the 32-byte header");
  std::uint32_t version = 0, dim = 0;
  std::uint64_t size = 0, sum = 0;
  std::memcpy(&version, src.data() + 8, 4);
  std::memcpy(&dim, src.data() + 12, 4);
  std::memcpy(&size, src.data() + 16, 8);
  std::memcpy(&sum, src.data() + 24, 8);
  if (version != checkpoint_version)
    bad("format version ", version, " is not supported (this mpskit reads version ", checkpoint_version, ")");
  if (dim != static_cast<std::uint32_t>(D)) bad("written by a ", dim, "D scene, read into a ", D, "D state");
  if (src.size() - 32 != size)
    bad(src.size() - 32 < size ? "truncated" : "has trailing bytes", ": payload is ", src.size() - 32,
        " bytes, the header says ", size);
  const std::string_view payload = std::string_view(src).substr(32);
  if (const std::uint64_t got = detail::fnv1a64(payload); got != sum)
    bad("checksum mismatch (file corrupted): stored ", std::hex, sum, ", computed ", got);

  detail::byte_reader r(payload, file);
  const auto n_real = r.value<std::uint64_t>("the particle counts");
  const auto n_ghost = r.value<std::uint64_t>("the particle counts");
  const auto next_id = r.value<std::uint64_t>("the next id");
  const auto n_fields = r.value<std::uint32_t>("the field count");
  if (n_real > (1ull << 40) || n_ghost > (1ull << 40))
    bad("particle counts ", n_real, " + ", n_ghost, " are not plausible");
  if (n_fields != State::fields::size) {
    std::string mine;
    State::for_each_field(
        [&](auto tag) { mine += (mine.empty() ? "" : ", ") + std::string(decltype(tag)::name); });
    bad("holds ", n_fields, " fields, the state has ", State::fields::size, " (", mine, ")");
  }
  State restored;
  restored.restore_layout(static_cast<index_t>(n_real), static_cast<index_t>(n_ghost), next_id);
  const std::size_t total = static_cast<std::size_t>(n_real + n_ghost);
  std::uint32_t k = 0;
  State::for_each_field([&](auto tag) {
    using T = decltype(tag);
    using L = detail::field_layout<T, D>;
    const std::string name = r.string("a field name");
    const std::string units = r.string("a field's units");
    const auto shape = r.value<std::uint8_t>("a field's shape");
    const std::string type = r.string("a field's type");
    const auto comps = r.value<std::uint32_t>("a field's components");
    const auto nbytes = r.value<std::uint64_t>("a field's size");
    if (name != T::name)
      bad("field ", k, " is '", name, "', the state's field ", k, " is '", T::name, "' (field lists differ)");
    if (shape != static_cast<std::uint8_t>(T::shape) || type != L::type || comps != L::components)
      bad("field '", name, "' is stored as ", type, " x ", comps, ", the state has ", L::type, " x ",
          L::components);
    if (units != T::units)
      bad("field '", name, "' has units '", units, "', the state's are '", T::units, "'");
    const std::size_t n = total * L::components;
    if (nbytes != n * sizeof(typename L::V))
      bad("field '", name, "' holds ", nbytes, " bytes, expected ", n * sizeof(typename L::V));
    const char* p = r.take(static_cast<std::size_t>(nbytes), "a field's values");
    auto& s = restored.template get<T>();
    if (n > 0) std::memcpy(reinterpret_cast<typename L::V*>(s.data()), p, static_cast<std::size_t>(nbytes));
    ++k;
  });
  checkpoint_sections secs;
  const auto n_sections = r.value<std::uint32_t>("the section count");
  auto& list = checkpoint_access::list(secs);
  for (std::uint32_t s = 0; s < n_sections; ++s) {
    std::string name = r.string("a section name");
    const auto type = r.value<std::uint8_t>("a section type");
    const auto nbytes = r.value<std::uint64_t>("a section size");
    if (type > 2) bad("section '", name, "' has unknown type ", int(type));
    const std::size_t elem = type == 0 ? 1 : 8;
    if (nbytes % elem != 0) bad("section '", name, "' size ", nbytes, " is not a multiple of ", elem);
    std::string data(r.take(static_cast<std::size_t>(nbytes), "a section's data"),
                     static_cast<std::size_t>(nbytes));
    list.push_back({std::move(name), static_cast<section_type>(type), nbytes / elem, std::move(data)});
  }
  if (!r.done()) bad("unread bytes after the last section");
  try {
    restored.validate();
  } catch (const error& e) {
    bad("the restored state is invalid: ", e.what());
  }
  for (index_t i = 0; i < restored.n_real(); ++i)
    if (restored.ids()[static_cast<std::size_t>(i)] >= next_id)
      bad("particle ", i, " has id ", restored.ids()[static_cast<std::size_t>(i)], " >= next id ", next_id);
  checkpoint_access::set_origin(secs, file);
  state = std::move(restored);
  sections = std::move(secs);
}

}  // namespace mpskit::io
