#pragma once
/// \file The wbc process's node keys and OPERATOR requests (library hpr::wbc_node, shared by the wbc
/// process's binding, hpr/graph/bindings.hpp, and the composed controllers).

#include <humanoid/operator_t.hpp>

#include "hpr/common/config.hpp"
#include "hpr/wbc/component.hpp"

namespace hpr::wbc {

struct WbcNodeOptions {
  bool wait_for_wholebody = true;    ///< step only with the WHOLEBODY_COMMAND of the same tick
  double wholebody_timeout = 0.5;    ///< [s] wall time to wait for it
  int wholebody_stale_ticks = 50;    ///< older commands are ignored (the balance plan)
  int plan_stale_ticks = 20;         ///< older plans are ignored (damps)
  int bad_state_ticks = 20;          ///< damp after this many ticks of a state flagged stale, implausible or diverged
  static WbcNodeOptions load(const Config& wbc_section);
};

/// What an OPERATOR message asks of the wbc: damp and stop damp it, enable ends the damping (each
/// logged when it changes something). Support requests are the planner's.
void apply_operator(WbcComponent& wbc, const humanoid::operator_t& m);

}  // namespace hpr::wbc
