#pragma once
// Private to the QP library: the per-bound and per-row activity a working set gives (what the
// solver reports after a solve), shared by the active-set iterations and the solver's finish.
#include <algorithm>
#include <vector>

#include "hpr/qp/qp_solver.hpp"

namespace hpr::qp::detail {

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
