#include "hpr/node/lifecycle.hpp"

namespace hpr::node {

const char* to_string(Lifecycle s) {
  switch (s) {
    case Lifecycle::kWaiting: return "waiting";
    case Lifecycle::kStarting: return "starting";
    case Lifecycle::kRunning: return "running";
    case Lifecycle::kDamping: return "damping";
    case Lifecycle::kStopped: return "stopped";
  }
  return "?";
}

bool LifecycleMachine::go(Lifecycle to) {
  if (to == state_) return false;
  state_ = to;
  ++transitions_;
  return true;
}

bool LifecycleMachine::on_input() { return state_ == Lifecycle::kWaiting && go(Lifecycle::kStarting); }

bool LifecycleMachine::on_step(StepOutcome o) {
  if (state_ == Lifecycle::kStopped) return false;
  switch (o) {
    case StepOutcome::kNotReady: return go(Lifecycle::kStarting);
    case StepOutcome::kRunning: return go(Lifecycle::kRunning);
    case StepOutcome::kDamping: return go(Lifecycle::kDamping);
  }
  return false;
}

bool LifecycleMachine::on_restart() { return state_ != Lifecycle::kStopped && go(Lifecycle::kWaiting); }

bool LifecycleMachine::on_stop() { return go(Lifecycle::kStopped); }

}  // namespace hpr::node
