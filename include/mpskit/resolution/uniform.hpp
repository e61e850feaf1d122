#pragma once
/// \file resolution/uniform.hpp
/// \brief resolution::uniform: no resolution stage (particles keep their sizes). The default of every scene
/// that names no `resolution` policy; it costs nothing (ARCHITECTURE.md §2).
#include "mpskit/core/fields.hpp"

namespace mpskit::resolution {

/// No splitting or merging.
struct uniform final {
  using fields = field_list<>;  ///< asks for no field
};

}  // namespace mpskit::resolution
