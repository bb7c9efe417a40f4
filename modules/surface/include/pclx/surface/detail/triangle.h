#pragma once
// The triangle type of the surface module's mesh helpers.
#include <array>
#include <cstdint>

namespace pclx {
namespace surface {
namespace detail {

/** \brief A triangle as three vertex indices, without the allocation of a pcl::Vertices. */
using Triangle = std::array<std::uint32_t, 3>;

}  // namespace detail
}  // namespace surface
}  // namespace pclx
