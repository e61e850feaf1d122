#pragma once
/// \file mpskit.hpp
/// \brief Umbrella header: every area except optional back-ends (SuiteSparse) and the kd-tree
/// (include "mpskit/search/kdtree.hpp" for nanoflann).
#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/exec.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"
#include "mpskit/core/params.hpp"
#include "mpskit/core/state.hpp"
#include "mpskit/kernel/classic.hpp"
#include "mpskit/kernel/concepts.hpp"
#include "mpskit/kernel/cubic_spline.hpp"
#include "mpskit/kernel/quadratic.hpp"
#include "mpskit/kernel/reference_lattice.hpp"
#include "mpskit/kernel/wendland_c2.hpp"
#include "mpskit/kernel/zhang_wan.hpp"
#include "mpskit/search/cell_list.hpp"
#include "mpskit/search/concepts.hpp"
#include "mpskit/search/domain.hpp"
#include "mpskit/search/neighbour_list.hpp"
#include "mpskit/search/radius.hpp"
