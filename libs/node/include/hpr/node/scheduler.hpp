#pragma once
/// \file
/// When a node's code runs: its steps on the ticks of an input (on_tick, with the inputs it waits
/// for), its resets when a source restarts, its timers, and what it does while an input is
/// silent. The Scheduler hears every typed input's events (InputEvents) and tells the node's
/// Health what each step did and how long it took. The loop that waits for messages is the
/// Runtime's (hpr/node/runtime.hpp).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "hpr/node/health.hpp"
#include "hpr/node/input.hpp"

namespace hpr::node {

/// An input that must reach the triggering tick (plus `tick_offset`) before the step runs.
struct Sync {
  InputBase* input;
  std::int64_t tick_offset = 0;
  /// Whether the step needs this input at the pending tick (empty: always). An input the step will
  /// not use (a wbc that damps has no use for the motion optimiser's command) is not waited for,
  /// so a lockstep chain runs on at full rate without it.
  std::function<bool()> needed;
  /// An optional input (from a component the step can do without) that misses the timeout once is
  /// marked absent: it is not waited for until its next message, and HEALTH says so. A lockstep
  /// chain whose optional component died thus runs on at full rate rather than one step per timeout.
  bool optional = false;
};

/// What the step is told about its tick.
struct TickInfo {
  std::int64_t tick = 0;        ///< tick of the primary input
  bool timed_out = false;       ///< a synced input did not arrive within the timeout
  std::vector<const InputBase*> late;  ///< the synced inputs that had not arrived
};

class Scheduler final : public InputEvents {
 public:
  using StepFn = std::function<void(const TickInfo&)>;

  explicit Scheduler(Health& health) : health_(health) {}

  /// Runs `step` for every new tick of `primary` once the `synced` inputs have caught up, or after
  /// `timeout_s` without them (TickInfo::timed_out), or at once when the next primary tick arrives
  /// first (real time: never fall behind the robot's clock). A tick older than the last stepped one
  /// is ignored.
  void on_tick(InputBase& primary, std::vector<Sync> synced, double timeout_s, StepFn step);
  /// Calls `reset` when `primary` follows a new tick stream.
  void on_restart(InputBase& primary, std::function<void()> reset);
  /// Calls `fn` every `period_s` of wall-clock time (monotonic) from the loop.
  void every(double period_s, std::function<void()> fn);
  /// While `input` (once heard) has been silent for more than `timeout_s`, calls `fn` every
  /// `timeout_s`, holds fault `fault` and logs once when the input went silent and once when it is back.
  void while_silent(const InputBase& input, double timeout_s, const std::string& fault, std::function<void()> fn);

  /// Runs the timers that are due at monotonic time `now`.
  void run_timers(double now);
  /// Runs the steps whose inputs are in, or whose timeout passed, at `now`.
  void check_triggers(double now);
  /// The earliest time a timer or a step's timeout is due (inf: none).
  [[nodiscard]] double next_event() const;
  /// When the next message of a stepping input is due: its last arrival plus the moving average of
  /// its arrival intervals (0 before two have arrived).
  [[nodiscard]] double next_arrival() const;
  /// Whether the node steps on an input (else it runs on its own clock).
  [[nodiscard]] bool steps_on_input() const { return !triggers_.empty(); }

  void on_input(InputBase& in) override;
  void on_reject(InputBase& in, std::size_t bytes, const std::string& why) override;
  void on_follow(InputBase& in, std::int64_t old_tick, std::int64_t new_tick) override;
  [[nodiscard]] bool step_waits_at(const InputBase& in, std::int64_t tick) const override;

 private:
  struct Trigger {
    InputBase* primary;
    std::vector<Sync> synced;
    double timeout_s;
    StepFn step;
    std::int64_t last_tick = -1;
    std::int64_t pending_tick = -1;
    double deadline = 0.0;
    std::vector<char> absent;  ///< per synced input: optional and not waited for
    double arrival = 0.0;      ///< when the newest primary tick arrived
    double period = 0.0;       ///< moving average of the primary's arrival intervals (0: unknown)
  };
  struct Timer {
    double period, next;
    std::function<void()> fn;
  };
  void mark_absent(Trigger& t, std::size_t i);
  /// Runs `t`'s step for its pending tick when its synced inputs are in (or late past the deadline).
  void check_trigger(Trigger& t, double now);

  Health& health_;
  std::vector<Trigger> triggers_;
  std::vector<Timer> timers_;
  std::vector<std::pair<InputBase*, std::function<void()>>> restarts_;
};

}  // namespace hpr::node
