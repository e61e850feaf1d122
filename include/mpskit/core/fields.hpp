#pragma once
/// \file core/fields.hpp
/// \brief Field tags and compile-time field lists (ARCHITECTURE.md §2–3). Each policy declares
/// `using fields = field_list<...>`; a scene's state holds exactly the union of what its policies ask.
#include <concepts>
#include <cstdint>
#include <string_view>
#include <type_traits>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/kinds.hpp"

namespace mpskit {

/// Storage shapes of a field.
enum class field_shape : std::uint8_t {
  scalar,  ///< one double per particle: Eigen::VectorXd
  vector,  ///< D doubles per particle: points<D> (column i)
  index,   ///< a particle index (remapped on every reorder/resize): std::vector<index_t>
  integer  ///< an integral value of type `value_type`: std::vector<value_type>
};

/// A field tag: a type with a name, units, a shape and a value type.
template <class T>
concept FieldTag = requires {
  typename T::value_type;
  { T::name } -> std::convertible_to<std::string_view>;
  { T::units } -> std::convertible_to<std::string_view>;
  { T::shape } -> std::convertible_to<field_shape>;
};

namespace field {
// Helpers to declare tags in one line each.
struct scalar_base {
  using value_type = double;
  static constexpr field_shape shape = field_shape::scalar;
};
struct vector_base {
  using value_type = double;
  static constexpr field_shape shape = field_shape::vector;
};
struct index_base {
  using value_type = index_t;
  static constexpr field_shape shape = field_shape::index;
};
template <class T>
struct integer_base {
  using value_type = T;
  static constexpr field_shape shape = field_shape::integer;
};

// Core fields: every state has them.
struct position : vector_base { static constexpr std::string_view name = "position", units = "m"; };
struct velocity : vector_base { static constexpr std::string_view name = "velocity", units = "m/s"; };
struct id : integer_base<particle_id> { static constexpr std::string_view name = "id", units = "1"; };
struct kind : integer_base<mpskit::kind> { static constexpr std::string_view name = "kind", units = "1"; };
struct flags : integer_base<flag::type> { static constexpr std::string_view name = "flags", units = "1"; };
struct role : integer_base<ghost_role> {
  static constexpr std::string_view name = "ghost_role", units = "1";
};
/// The real particle a ghost was made from (npos for real particles).
struct parent : index_base { static constexpr std::string_view name = "parent", units = "1"; };

// Fields policies ask for.
struct pressure : scalar_base { static constexpr std::string_view name = "pressure", units = "Pa"; };
/// Particle volume; the diameter is derived (L = V^(1/D) on the reference lattice, ARCHITECTURE.md §3).
struct volume : scalar_base { static constexpr std::string_view name = "volume", units = "m^D"; };
struct number_density : scalar_base {
  static constexpr std::string_view name = "number_density", units = "1";
};
struct temporary_velocity : vector_base {
  static constexpr std::string_view name = "temporary_velocity", units = "m/s";
};
struct normal : vector_base { static constexpr std::string_view name = "normal", units = "1"; };
/// A partner particle (merge pairs, BMMR mapping): an index, remapped on resize.
struct partner : index_base { static constexpr std::string_view name = "partner", units = "1"; };
}  // namespace field

/// A compile-time list of field tags (no duplicates).
template <FieldTag... Ts>
struct field_list {
  static constexpr std::size_t size = sizeof...(Ts);
};

/// True when tag T is in list L.
template <class L, class T>
struct contains;
template <class... Ts, class T>
struct contains<field_list<Ts...>, T> : std::bool_constant<(std::same_as<Ts, T> || ...)> {};
template <class L, class T>
inline constexpr bool contains_v = contains<L, T>::value;

namespace detail {
template <class Acc, class... Rest>
struct union_impl {
  using type = Acc;
};
template <class... As, class T, class... Rest>
struct union_impl<field_list<As...>, T, Rest...> {
  using type = typename union_impl<
      std::conditional_t<contains_v<field_list<As...>, T>, field_list<As...>, field_list<As..., T>>,
      Rest...>::type;
};
template <class... Ls>
struct union_lists;
template <>
struct union_lists<> {
  using type = field_list<>;
};
template <class... As, class... Ls>
struct union_lists<field_list<As...>, Ls...> {
  using rest = typename union_lists<Ls...>::type;
  template <class R>
  struct join;
  template <class... Bs>
  struct join<field_list<Bs...>> {
    using type = typename union_impl<field_list<>, As..., Bs...>::type;
  };
  using type = typename join<rest>::type;
};
}  // namespace detail

/// The union of field lists, in first-appearance order, duplicates removed.
template <class... Ls>
using field_union = typename detail::union_lists<Ls...>::type;

/// Fields every state holds.
using core_fields = field_list<field::position, field::velocity, field::id, field::kind, field::flags,
                               field::role, field::parent>;

/// The storage of one field in a D-dimensional state.
template <class T, int D>
using field_storage_t = std::conditional_t<
    T::shape == field_shape::scalar, Eigen::VectorXd,
    std::conditional_t<T::shape == field_shape::vector, points<D>, std::vector<typename T::value_type>>>;

}  // namespace mpskit
