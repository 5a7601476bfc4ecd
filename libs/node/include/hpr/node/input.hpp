#pragma once
/// \file
/// A node's typed inputs: the state of one subscribed channel (InputBase) and its decoded message
/// (Input<Msg>), held to the rules of a clocked input (hpr/node/runtime.hpp has them in full,
/// docs/SAFETY.md the reasons). A Transport creates them (Transport::subscribe) and tells the
/// node's scheduler what they accept, refuse and follow (InputEvents).

#include <lcm/lcm-cpp.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>

#include "hpr/common/auth.hpp"
#include "hpr/common/time.hpp"
#include "hpr/node/freshness.hpp"
#include "hpr/node/output.hpp"

namespace hpr::node {

class InputBase;

/// The limits of a tick stream (RuntimeOptions holds them, from the configuration's lcm section).
struct StreamRules {
  /// [ticks] How far ahead of its last tick a tick stream's next tick may be.
  std::int64_t tick_window = 1000;
  /// [s] How long a tick stream must be quiet before its input follows a new one (a restarted
  /// source, or ticks that jumped beyond the window).
  double source_quiet_s = 0.1;
  /// [s] The longest clock period per tick of a tick stream's source: its time may advance by this
  /// much per tick beyond the wall time elapsed (a lockstep source runs faster than the wall clock).
  double tick_period_max_s = 0.01;
  /// [s] Beyond that, how far a message's time may run ahead (delivery jitter).
  double time_slack_s = 0.05;
  /// [s] How far a command's time may be from this host's wall clock (hpr/node/freshness.hpp; 0:
  /// not checked, for re-running a recording).
  double command_window_s = 2.0;
};

/// What an input tells the node about its messages (the node's Scheduler answers).
class InputEvents {
 public:
  /// A message was accepted (after the subscriber's callback ran).
  virtual void on_input(InputBase& in) = 0;
  /// A message of `bytes` was refused (or held) for `why`.
  virtual void on_reject(InputBase& in, std::size_t bytes, const std::string& why) = 0;
  /// `in` follows a new tick stream (its source restarted, or its clock jumped).
  virtual void on_follow(InputBase& in, std::int64_t old_tick, std::int64_t new_tick) = 0;
  /// Whether a step on `in` waits at `tick` for its synced inputs (a repeat of that tick is dropped).
  [[nodiscard]] virtual bool step_waits_at(const InputBase& in, std::int64_t tick) const = 0;

 protected:
  ~InputEvents() = default;
};

/// Type-independent state of one subscribed channel.
class InputBase {
 public:
  virtual ~InputBase() = default;
  InputBase(const InputBase&) = delete;
  InputBase& operator=(const InputBase&) = delete;

  [[nodiscard]] const std::string& channel() const { return channel_; }
  [[nodiscard]] bool has_value() const { return count_ > 0; }
  /// Tick of the latest valid message, -1 before the first.
  [[nodiscard]] std::int64_t tick() const { return tick_; }
  /// Monotonic time [s] at which the latest valid message arrived.
  [[nodiscard]] double receive_time() const { return receive_time_; }
  [[nodiscard]] std::int64_t count() const { return count_; }
  [[nodiscard]] std::int64_t errors() const { return errors_; }
  [[nodiscard]] const std::string& last_error() const { return last_error_; }
  /// Treats the channel as one tick stream (see the file comment); a trigger's inputs are.
  void follow_ticks() { stream_ = true; }
  [[nodiscard]] bool follows_ticks() const { return stream_; }
  /// Messages held back because their tick was outside the window, or their time implausible for
  /// their tick (included in errors()).
  [[nodiscard]] std::int64_t out_of_window() const { return out_of_window_; }
  /// Of those, the messages held for their time.
  [[nodiscard]] std::int64_t implausible_times() const { return implausible_times_; }
  /// Times the input followed a new tick stream (a restarted source).
  [[nodiscard]] std::int64_t follows() const { return follows_; }
  /// Messages dropped because they repeated the tick of a step still waiting (see the file comment).
  [[nodiscard]] std::int64_t repeats() const { return repeats_; }
  /// Messages held because another source than the stream's sent them (included in out_of_window()).
  [[nodiscard]] std::int64_t second_sources() const { return second_sources_; }
  /// The source the stream follows (0 before the first message of a sourced type).
  [[nodiscard]] std::int64_t source() const { return source_; }
  /// Messages refused for a missing or wrong authentication code (included in errors()).
  [[nodiscard]] std::int64_t unauthenticated() const { return unauthenticated_; }
  /// Stream messages refused as replays (included in errors()), never followed: of a source the
  /// input left, or of the followed source with a counter not after the latest taken.
  [[nodiscard]] std::int64_t replays() const { return replays_; }
  /// Commands refused as stale or replayed (included in errors()); stops taken although stale.
  [[nodiscard]] std::int64_t stale_commands() const { return stale_commands_; }
  [[nodiscard]] std::int64_t stale_stops() const { return stale_stops_; }
  /// Copies of a command already taken, dropped (not errors).
  [[nodiscard]] std::int64_t copies() const { return copies_; }

 protected:
  InputBase(InputEvents& events, const StreamRules& rules, std::string channel)
      : events_(events), rules_(rules), channel_(std::move(channel)), freshness_(rules.command_window_s) {}
  /// Records an accepted message of `tick`; then the subscriber's callback runs, then notify()
  /// releases the steps waiting for it (so a step sees what the callback did with the message).
  void accept(std::int64_t tick, std::int64_t utime, std::int64_t source);
  void notify();
  void reject(std::size_t bytes, const std::string& why);
  /// Whether `tick` continues the stream: from the last accepted tick up to the window ahead.
  [[nodiscard]] bool in_window(std::int64_t tick) const;
  /// Why a message of `tick` (in the window) and time `utime` [us] does not continue the stream's
  /// clock at monotonic time `now` (empty: it does). See the file comment.
  [[nodiscard]] std::string implausible_time(std::int64_t tick, std::int64_t utime, double now) const;
  /// Why a message of `source` is not the stream's (empty: it is, or the stream follows none yet).
  [[nodiscard]] std::string second_source(std::int64_t source) const;
  /// Counts and reports a message of `source` held back for its tick or its time (only the newest
  /// is kept).
  void hold(std::size_t bytes, std::int64_t tick, std::int64_t source, const std::string& why);
  /// Whether the input followed `source`'s identity once and left it.
  [[nodiscard]] bool retired(std::int64_t source) const;
  /// Why a stream message of `source` at `tick` is a replay (empty: it is not): its sender is one
  /// the input left, or it is the followed sender's and its counter is not after the latest taken.
  [[nodiscard]] std::string replay(std::int64_t source, std::int64_t tick) const;
  /// When a stream is held and the accepted one has been quiet long enough: follows it.
  void follow_if_quiet(double now);
  /// Monotonic time at which follow_if_quiet() may follow the held stream (inf: nothing held).
  [[nodiscard]] double follow_time() const;
  /// Forgets the accepted stream, so that the next tick (or the one held) is taken as it is.
  void restart_stream();
  /// Makes the held message the latest one (validating it first); false when it is refused.
  virtual bool adopt_held() = 0;
  /// Takes one message's bytes as they came off the channel (the Transport's own receive path, or
  /// liblcm's).
  virtual void deliver(const void* data, std::size_t size) = 0;
  /// Whether a message of `tick` repeats the tick of a step that waits for its synced inputs; if
  /// so it is counted, and the caller drops it.
  bool repeats_waiting_step(std::int64_t tick);

  InputEvents& events_;
  const StreamRules& rules_;
  std::string channel_;
  std::int64_t tick_ = -1, count_ = 0, errors_ = 0;
  std::int64_t utime_ = 0;  ///< time [us] of the latest valid message
  double receive_time_ = 0.0;
  double advance_time_ = 0.0;  ///< monotonic time of the last accepted tick above the one before
  std::string last_error_;
  bool stream_ = false;
  bool held_ = false;
  std::int64_t held_tick_ = -1, out_of_window_ = 0, implausible_times_ = 0, follows_ = 0, repeats_ = 0;
  std::int64_t unauthenticated_ = 0, second_sources_ = 0;
  std::int64_t source_ = 0;
  std::int64_t stale_commands_ = 0, stale_stops_ = 0, copies_ = 0, replays_ = 0;
  std::array<std::uint32_t, 16> retired_{};  ///< identities followed once and left, newest at retired_next_ - 1
  std::size_t retired_next_ = 0;
  std::int64_t held_source_ = 0;
  CommandFreshness freshness_;
  /// Whether a command of `source` at `utime` is to be taken (hpr/node/freshness.hpp): a copy is
  /// dropped, a stale or replayed one refused (counted) unless `stop` (taken, and logged).
  bool fresh(const std::string& source, std::int64_t utime, bool stop, std::size_t bytes);
  /// Whether `bytes` carry the code of `key` (null: authentication off); if not, counts and rejects.
  bool authentic(const void* bytes, std::size_t n, const auth::Key* key);
  friend class Transport;
  friend class Scheduler;
};

/// A typed input. `Msg` is an lcm-gen type with an int64 `tick` field.
template <class Msg>
class Input final : public InputBase {
 public:
  /// Returns an empty string when the message is acceptable, else the reason to reject it.
  using Validator = std::function<std::string(const Msg&)>;
  using Callback = std::function<void(const Msg&)>;

  /// `key`: the key a signed type's code is checked with (null: not checked). `lcm`: subscribes
  /// there; null: the Transport delivers the channel's messages itself.
  Input(InputEvents& events, const StreamRules& rules, lcm::LCM* lcm, std::string channel, Validator validate, Callback on_message,
        const auth::Key* key = nullptr)
      : InputBase(events, rules, std::move(channel)), validate_(std::move(validate)), on_message_(std::move(on_message)), key_(key) {
    if (lcm != nullptr) lcm->subscribe(channel_, &Input::on_lcm, this);
  }

  /// The latest valid message (default-constructed before the first).
  [[nodiscard]] const Msg& latest() const { return latest_; }

 private:
  void on_lcm(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) { deliver(rbuf->data, rbuf->data_size); }

  void deliver(const void* data, std::size_t size) override {
    if constexpr (auth::Signed<Msg>) {
      if (!authentic(data, size, key_)) return;
    }
    std::string why;
    try {
      const int used = spare_.decode(data, 0, static_cast<int>(size));
      if (used < 0) why = "not a valid " + std::string(Msg::getTypeName());
    } catch (const std::exception& e) {
      why = "not a valid " + std::string(Msg::getTypeName()) + " (" + e.what() + ")";
    }
    if constexpr (Command<Msg>) {
      if (why.empty() && !fresh(spare_.source, spare_.utime, acted_on_when_stale(spare_), size)) return;
    }
    if (why.empty() && stream_) {
      std::string held_why;
      if constexpr (Sourced<Msg>) {
        if (const std::string replayed = replay(spare_.source, spare_.tick); !replayed.empty()) {
          ++replays_;
          reject(size, replayed);
          return;
        }
        held_why = second_source(spare_.source);
        if (!held_why.empty()) ++second_sources_;
      }
      if (held_why.empty() && !in_window(spare_.tick)) {
        held_why = "tick";
      } else if (held_why.empty()) {
        held_why = implausible_time(spare_.tick, spare_.utime, monotonic_s());
        if (!held_why.empty()) ++implausible_times_;
      }
      if (!held_why.empty()) {
        // Not validated yet: a validator may act on what it accepts (the simulator applies a command).
        std::swap(held_msg_, spare_);
        held_bytes_ = size;
        hold(size, held_msg_.tick, source_of(held_msg_), held_why);
        return;
      }
    }
    // Before validation: a validator decodes into the node's own state, which the step reads.
    if (why.empty() && stream_ && repeats_waiting_step(spare_.tick)) return;
    if (why.empty()) why = validated(spare_);
    if (!why.empty()) {
      reject(size, why);
      return;
    }
    held_ = false;
    std::swap(latest_, spare_);
    accept(latest_.tick, latest_.utime, source_of(latest_));
    if (on_message_) on_message_(latest_);
    notify();
  }

  std::string validated(const Msg& m) {
    if (!validate_) return {};
    try {
      return validate_(m);
    } catch (const std::exception& e) {
      return "not a valid " + std::string(Msg::getTypeName()) + " (" + e.what() + ")";
    }
  }

  bool adopt_held() override {
    held_ = false;
    const std::string why = validated(held_msg_);
    if (!why.empty()) {
      reject(held_bytes_, why);
      return false;
    }
    std::swap(latest_, held_msg_);
    accept(latest_.tick, latest_.utime, source_of(latest_));
    if (on_message_) on_message_(latest_);
    notify();
    return true;
  }

  Validator validate_;
  Callback on_message_;
  const auth::Key* key_ = nullptr;
  Msg latest_{}, spare_{}, held_msg_{};
  std::size_t held_bytes_ = 0;
};

}  // namespace hpr::node
