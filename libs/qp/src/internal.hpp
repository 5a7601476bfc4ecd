#pragma once
// Private to the QP library, shared by its source files: infinity for the absent bounds, and the
// per-bound and per-row activity a working set gives (what the solver reports after a solve).
#include <algorithm>
#include <limits>
#include <vector>

#include "hpr/qp/qp_solver.hpp"

namespace hpr::qp::detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// Marks `bounds` and `rows` with how each entry of the working set `active` holds it (n variables).
template <class Entries>
void mark(const Entries& active, int n, std::vector<Active>& bounds, std::vector<Active>& rows) {
  std::fill(bounds.begin(), bounds.end(), Active::kInactive);
  std::fill(rows.begin(), rows.end(), Active::kInactive);
  for (const auto& e : active) {
    const Active s = e.equality ? Active::kEquality : (e.sign > 0 ? Active::kLower : Active::kUpper);
    if (e.c < n) {
      bounds[static_cast<size_t>(e.c)] = s;
    } else {
      rows[static_cast<size_t>(e.c - n)] = s;
    }
  }
}

}  // namespace hpr::qp::detail
