#pragma once
// Private to the model library: a body, joint or frame index as a container index.
#include <cstddef>

namespace hpr::model::detail {

inline std::size_t u(int i) { return static_cast<std::size_t>(i); }

}  // namespace hpr::model::detail
