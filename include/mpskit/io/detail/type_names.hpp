#pragma once
/// \file io/detail/type_names.hpp
/// \brief VTK type names of the value types of fields, and units with the dimension filled in.
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>

namespace mpskit::io::detail {

template <class V>
struct underlying {
  using type = V;
};
template <class V>
  requires std::is_enum_v<V>
struct underlying<V> {
  using type = std::underlying_type_t<V>;
};
/// The arithmetic type a value is stored as (enums: their underlying type).
template <class V>
using underlying_t = typename underlying<V>::type;

/// The VTK XML type name of V ("Float64", "Int64", "UInt8", ...).
template <class V>
constexpr std::string_view vtk_type_name() {
  using U = underlying_t<V>;
  if constexpr (std::is_same_v<U, double>) return "Float64";
  else if constexpr (std::is_same_v<U, float>) return "Float32";
  else if constexpr (std::is_same_v<U, bool>) return "UInt8";
  else if constexpr (std::is_integral_v<U> && std::is_signed_v<U>) {
    if constexpr (sizeof(U) == 1) return "Int8";
    else if constexpr (sizeof(U) == 2) return "Int16";
    else if constexpr (sizeof(U) == 4) return "Int32";
    else return "Int64";
  } else if constexpr (std::is_integral_v<U>) {
    if constexpr (sizeof(U) == 1) return "UInt8";
    else if constexpr (sizeof(U) == 2) return "UInt16";
    else if constexpr (sizeof(U) == 4) return "UInt32";
    else return "UInt64";
  } else {
    static_assert(sizeof(U) == 0, "mpskit: io: a field value type must be arithmetic or an enum");
  }
}

/// Size in bytes of a VTK XML type name, 0 when unknown.
inline int vtk_type_size(std::string_view t) {
  if (t == "Float64" || t == "Int64" || t == "UInt64") return 8;
  if (t == "Float32" || t == "Int32" || t == "UInt32") return 4;
  if (t == "Int16" || t == "UInt16") return 2;
  if (t == "Int8" || t == "UInt8") return 1;
  return 0;
}

/// Field units with the dimension filled in: "m^D" becomes "m^2" or "m^3".
inline std::string resolve_units(std::string_view units, int dim) {
  std::string s(units);
  for (std::size_t p = s.find("^D"); p != std::string::npos; p = s.find("^D", p + 2))
    s[p + 1] = char('0' + dim);
  return s;
}

}  // namespace mpskit::io::detail
