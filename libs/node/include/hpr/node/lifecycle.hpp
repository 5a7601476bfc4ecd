#pragma once
/// \file
/// A node's lifecycle, one explicit state machine (reported in HEALTH, shown by `supervisor status`):
///
///   waiting ──input──▶ starting ──ready──▶ running ◀──resume── damping
///      ▲                  ▲  ▲                │ └─────damp──────▶ ▲
///      │                  │  └────not ready───┘                   │
///      └──────restart (a source's clock restarted) from any ──────┘
///   stopped: from any state, final
///
/// waiting: no message yet on the channel it steps on. starting: stepping, but not ready to act
/// (no usable estimate yet, the filter initialising). running: acting. damping: its output is a
/// damping command (operator damp or stop, an estimate unusable for too long).

#include <cstdint>

#include "hpr/common/component.hpp"

namespace hpr::node {

enum class Lifecycle : std::int8_t { kWaiting = 0, kStarting = 1, kRunning = 2, kDamping = 3, kStopped = 4 };
const char* to_string(Lifecycle s);

/// What a step did, as the node reports it (a component's, hpr/common/component.hpp).
using StepOutcome = hpr::StepOutcome;

class LifecycleMachine {
 public:
  [[nodiscard]] Lifecycle state() const { return state_; }
  /// Each event returns true when the state changed; an event that does not apply to the state is
  /// ignored (false).
  bool on_input();                 ///< waiting → starting
  bool on_step(StepOutcome o);     ///< starting/running/damping → starting, running or damping
  bool on_restart();               ///< any but stopped → waiting
  bool on_stop();                  ///< any → stopped
  /// Transitions so far (for a test, and the log).
  [[nodiscard]] int transitions() const { return transitions_; }

 private:
  bool go(Lifecycle to);
  Lifecycle state_ = Lifecycle::kWaiting;
  int transitions_ = 0;
};

}  // namespace hpr::node
