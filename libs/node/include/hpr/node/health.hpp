#pragma once
/// \file
/// What a node says about itself: its faults, its lifecycle (hpr/node/lifecycle.hpp), its step
/// times and counters, and HEALTH, which carries them (the supervisor, `supervisor status` and the
/// viewer read it; no process acts on it).

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "hpr/common/component.hpp"
#include "hpr/common/stats.hpp"
#include "hpr/node/input.hpp"
#include "hpr/node/lifecycle.hpp"

namespace hpr::node {

class Transport;

class Health {
 public:
  /// Node `node` publishing through `transport`; a step longer than `deadline_s` is a deadline
  /// miss; a channel's decode fault clears `fault_quiet_s` after its last refused message.
  Health(std::string node, Transport& transport, double deadline_s, double fault_quiet_s);

  /// Sets or clears a named fault shown in HEALTH; a fault makes the state DEGRADED (or FAULT). One
  /// set with `clear_after_s` clears by itself that long after its last set (monotonic time).
  void set_fault(const std::string& key, const std::string& text, bool fatal = false,
                 double clear_after_s = std::numeric_limits<double>::infinity());
  void clear_fault(const std::string& key);
  [[nodiscard]] bool has_fault(const std::string& key) const { return faults_.count(key) != 0; }
  /// The text of fault `key` ("" when it is not set).
  [[nodiscard]] std::string fault_text(const std::string& key) const;

  /// A step starts (the first input moves the lifecycle from waiting to starting) and ends, taking
  /// `seconds`; between the two, report() sets what the step did.
  void begin_step();
  void end_step(std::int64_t tick, double seconds);
  /// What the step being run did: an on_tick step that reports nothing was running. Outside a
  /// step (a node on its own clock), it applies at once.
  void report(StepOutcome outcome);
  /// A component's tick (hpr/common/component.hpp): the faults it raised are set and those it
  /// cleared cleared, under the component's keys, and an outcome other than running is reported as
  /// above.
  void report(const StepReport& component);
  [[nodiscard]] Lifecycle lifecycle() const { return lifecycle_.state(); }

  /// `in` refused a message of `bytes` for `why`: logged (at most once a second) and held as the
  /// channel's decode fault until the channel is quiet.
  void refused(const InputBase& in, std::size_t bytes, const std::string& why);
  /// `in` followed a new tick stream: the lifecycle starts again from waiting.
  void followed(const InputBase& in, std::int64_t old_tick, std::int64_t new_tick);

  /// Records one step's compute time (begin_step/end_step do for the scheduled steps).
  void record_step(std::int64_t tick, double seconds);
  /// Counts a step that ran without a fresh input.
  void count_stale() { ++stale_inputs_; }
  [[nodiscard]] std::int64_t last_tick() const { return last_tick_; }
  [[nodiscard]] const RollingStats& cycle_stats() const { return cycle_; }
  [[nodiscard]] std::int64_t deadline_misses() const { return deadline_misses_; }

  /// Publishes HEALTH. `stopping`: the node is stopping (its lifecycle ends); `own_clock`: the node
  /// steps on its own clock, not on an input (it is running once it reports HEALTH).
  void publish(bool stopping, bool own_clock);

 private:
  void log_lifecycle(bool changed, Lifecycle from);

  std::string node_;
  Transport& transport_;
  double deadline_s_, fault_quiet_s_;
  struct Fault {
    std::string text;
    bool fatal;
    double expires;  ///< monotonic time at which it clears by itself (inf: never)
  };
  std::map<std::string, Fault> faults_;
  LifecycleMachine lifecycle_;
  bool in_step_ = false;
  StepOutcome step_outcome_ = StepOutcome::kRunning;
  RollingStats cycle_{1000};
  std::int64_t steps_ = 0, last_tick_ = -1, deadline_misses_ = 0, stale_inputs_ = 0;
  std::int64_t steps_at_rate_time_ = 0;
  double rate_time_ = 0.0, rate_hz_ = 0.0, last_refusal_log_ = -1e9;
  double last_step_time_ = 0.0;  ///< [s, monotonic] of the latest step
  /// [s] A node stepped by its inputs that has not stepped for this long says so in HEALTH (not
  /// stepping, waiting): what it does, not what it did.
  static constexpr double kStalledAfterS = 1.0;
};

}  // namespace hpr::node
