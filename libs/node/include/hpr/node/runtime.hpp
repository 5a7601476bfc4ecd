#pragma once
/// \file
/// The node runtime shared by every process of the stack.
///
/// A Runtime owns the LCM handle, typed inputs and outputs, the event loop and HEALTH reporting:
///  - Inputs decode into a preallocated message; a message that fails to decode or to validate is
///    counted, reported in HEALTH and logged (rate limited), never a crash.
///  - A tick trigger runs the node's step when the primary input has a new tick and every synced
///    input has reached that tick (plus an offset), or when a timeout expires.
///  - Inputs that carry a tick stream (a trigger's primary and synced inputs, and those marked with
///    follow_ticks()) accept a tick from their last one up to `tick_window` ahead. A tick outside
///    that window (a forged or corrupted tick, or a source that restarted at 0) is held back and
///    counted as a rejected message; when the stream's tick has not advanced for `source_quiet_s`,
///    the input follows the held stream (a restarted source), the triggers it drives start again
///    from its tick and the node's on_restart() resets run. The message's time (`utime`) is held to
///    the same rule, jointly with its tick: from the last accepted message it may not go back, nor
///    advance by more than `tick_period_max_s` per tick plus the wall time since that message plus
///    `time_slack_s` (a real-time source's clock runs with the wall clock, a lockstep one by its
///    ticks; a last time of 0 is a clock that has not started). A message whose time is implausible
///    for its tick is held like one outside the window,
///    so one forged or corrupted sample never becomes the stream that the real one is judged by.
///  - Every process stamps the clocked messages it publishes with its identity (`source`, a random
///    64-bit number chosen when the Runtime starts). A tick stream follows one source: a message of
///    another (a second sender on the channel, a stray or forged publisher) is held like a tick
///    outside the window and counted (second_sources()), with a fault naming the channel and both
///    sources, so a second sender's in-window ticks are never followed; when the followed source has
///    been quiet for `source_quiet_s` (a restart: a new process has a new identity), the new one is
///    followed and the node's on_restart() resets run.
///  - A step uses the first message of its tick: a message that repeats the primary input's tick
///    while that tick's step waits for its synced inputs (a source republishing its last sample,
///    flagged stale, because the chain is slow) is counted (repeats()) and dropped. How long a
///    lockstep round takes thus never changes what a step computes.
///  - The commands and every clocked channel carry an authentication code (hpr/common/auth.hpp):
///    an input of such a type refuses, before decoding it, a message whose code is missing or was
///    not made with the deployment's key (counted: unauthenticated(), HEALTH.unauthenticated), and
///    an output signs what it publishes. lcm.authentication: off (a bench) turns both off.
///  - SIGINT and SIGTERM end run() (and spin_until()) promptly; the process then exits 0.
///  - HEALTH goes out at lcm.health_rate_hz (10 Hz), or faster when the environment variable
///    HPR_HEALTH_RATE_HZ asks (the supervisor does, for a node it watches for hangs): node, last
///    tick, step-time median/p99/max, deadline misses, decode errors, stale inputs and the current
///    faults.
///  - A node with live parameters (parameters()) applies OPERATOR sets addressed to it between two
///    steps and answers each set, and each OPERATOR get, on PARAMS. A process that runs several
///    components (the composed controllers) keeps one set per component under the component's
///    process name (parameters("wbc")), so an OPERATOR set addressed to "wbc.com.stiffness.z"
///    reaches the wbc wherever it runs, and PARAMS answers in that name.

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hpr/node/input.hpp"
#include "hpr/node/lifecycle.hpp"
#include "hpr/node/output.hpp"
#include "hpr/node/udpm.hpp"
#include "hpr/common/auth.hpp"
#include "hpr/common/channel.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/log.hpp"
#include "hpr/common/stats.hpp"
#include "hpr/common/time.hpp"
#include "hpr/common/parameters.hpp"
#include "hpr/common/ports.hpp"

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

struct RuntimeOptions {
  std::string channel_prefix;   ///< prepended to every channel name
  double health_period_s = 0.1; ///< HEALTH rate
  double deadline_s = 1e-3;     ///< a step longer than this counts as a deadline miss
  /// A channel's decode fault clears this long after its last rejected message (the count in
  /// HEALTH.decode_errors stays).
  double decode_fault_quiet_s = 2.0;
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
  /// Whether the signed types (the commands and every clocked channel) are authenticated
  /// (lcm.authentication): their inputs check the code with the key of auth::key_path(), their
  /// outputs sign.
  bool authenticate = true;
  /// [s] Busy-poll window: from this long before the next message of a stepping input is due (its
  /// period estimated from the arrivals) until this long after, the loop polls LCM without
  /// sleeping, so the step starts without the core's wake-up (tens of microseconds on a virtual
  /// machine). 0 (the default) always sleeps. Costs about 2 × spin_s / period of a core.
  double spin_s = 0.0;
  /// Whether the typed inputs of a udpm URL are read from a socket of the loop's own
  /// (hpr/node/udpm.hpp: one wake-up per message instead of liblcm's two) rather than through
  /// liblcm's receive thread (lcm.receive). The own socket is read only between steps, so it
  /// suits a process with a core of its own; on a machine where many processes share few cores,
  /// liblcm's thread keeps reading while the process waits for one. Other URLs (memq://) always
  /// go through liblcm.
  bool receive_direct = false;
  /// The node's configuration: when the loop first runs (the node has read all of it), a key it
  /// did not read in a section it entered, or an override it did not read, stops it with a
  /// ConfigError (Config::check_all_read).
  std::shared_ptr<const Config> configuration;
};

/// An OPERATOR request answered on PARAMS.
struct ParameterRequest {
  std::int64_t utime = 0;
  std::string source;
  bool accepted = false;
  std::string result;
};

class Runtime {
 public:
  using StepFn = std::function<void(const TickInfo&)>;

  /// Opens LCM on `lcm_url` (throws LcmError with the fix when multicast is not routable).
  Runtime(std::string node_name, const std::string& lcm_url, RuntimeOptions options = {});
  /// A process of the stack, which may read and write only what `declared` lists (its ports,
  /// hpr/common/ports.hpp): another channel throws std::logic_error naming both, so a node that
  /// drifts from its declaration fails at start.
  Runtime(const Ports& declared, std::string node_name, const std::string& lcm_url, RuntimeOptions options = {});
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  /// liblcm, for what the typed inputs and outputs do not cover (raw publishing, a recorder's
  /// subscriptions). From the first call on, the loop also serves liblcm's own subscriptions.
  [[nodiscard]] lcm::LCM& lcm() {
    raw_lcm_used_ = true;
    return *lcm_;
  }
  /// The descriptor that becomes readable when a message for a typed input is waiting (for a loop
  /// of the node's own that polls other descriptors too and then calls spin_once(0)).
  [[nodiscard]] int receive_fd() const;
  /// Whether the typed inputs are read from the Runtime's own socket (RuntimeOptions::receive_direct).
  [[nodiscard]] bool receives_directly() const { return receiver_ != nullptr; }
  [[nodiscard]] const std::string& name() const { return name_; }
  /// The full channel name with the configured prefix.
  [[nodiscard]] std::string channel(const std::string& name) const { return options_.channel_prefix + name; }

  /// Subscribes to `ch` (hpr/msg/channels.hpp); a process may read only what it declares.
  template <class Msg>
  Input<Msg>& subscribe(const Channel<Msg>& ch, typename Input<Msg>::Validator validate = {},
                        typename Input<Msg>::Callback on_message = {}) {
    return subscribe<Msg>(std::string(ch.name), std::move(validate), std::move(on_message));
  }
  /// Publishes on `ch`; a process may write only what it declares.
  template <class Msg>
  Output<Msg> advertise(const Channel<Msg>& ch) {
    return advertise<Msg>(std::string(ch.name));
  }
  /// The same by name (a test's or a tool's own channel).
  template <class Msg>
  Input<Msg>& subscribe(const std::string& name, typename Input<Msg>::Validator validate = {},
                        typename Input<Msg>::Callback on_message = {}) {
    check_declared(name, false);
    return make_input<Msg>(name, std::move(validate), std::move(on_message));
  }
  template <class Msg>
  Output<Msg> advertise(const std::string& name) {
    check_declared(name, true);
    const auth::Key* key = nullptr;
    if constexpr (auth::Signed<Msg>) key = deployment_key();
    return Output<Msg>(lcm_.get(), channel(name), key, source_id_);
  }
  /// This process's identity on the clocked channels it publishes (random, nonzero, chosen at start).
  [[nodiscard]] std::int64_t source_id() const { return source_id_; }

  /// The deployment's key (the code of every signed type: the commands and the clocked channels),
  /// read on first use (throws auth::AuthError when it cannot be); null when authentication is off
  /// (then logs once that anyone may command and feed the robot).
  const auth::Key* deployment_key();
  [[nodiscard]] bool authenticates() const { return options_.authenticate; }

  /// Runs `step` for every new tick of `primary` once the `synced` inputs have caught up, or after
  /// `timeout_s` without them (TickInfo::timed_out), or at once when the next primary tick arrives
  /// first (real time: never fall behind the robot's clock). A tick older than the last stepped one
  /// is ignored.
  void on_tick(InputBase& primary, std::vector<Sync> synced, double timeout_s, StepFn step);
  /// Calls `reset` when `primary` follows a new tick stream (its source restarted, or its clock
  /// jumped): the node's algorithm starts again from the new clock's first tick.
  void on_restart(InputBase& primary, std::function<void()> reset);
  /// Calls `fn` every `period_s` of wall-clock time (monotonic) from the loop.
  void every(double period_s, std::function<void()> fn);
  /// A dropout is never silently held: while `input` (once heard) has been silent for more than
  /// `timeout_s` of wall-clock time, calls `fn` every `timeout_s` (a node republishes its last
  /// output flagged stale), holds fault `fault` ("no ROBOT_SENSORS for 35 ms") and logs once when
  /// the input went silent and once when it is back.
  void while_silent(const InputBase& input, double timeout_s, const std::string& fault, std::function<void()> fn);

  /// Processes messages until stop is requested. Returns the process exit code (0).
  int run();
  /// Processes messages until `done()` holds, `timeout_s` passes or stop is requested.
  /// Returns done().
  bool spin_until(const std::function<bool()>& done, double timeout_s);
  /// Handles whatever is pending, waiting at most `timeout_s`.
  void spin_once(double timeout_s);
  void request_stop() { stop_ = true; }
  [[nodiscard]] bool stop_requested() const;

  /// What the step being run did, for the node's lifecycle (reported in HEALTH): an on_tick step
  /// that reports nothing was running. Outside an on_tick step (a node on its own clock), it
  /// applies at once.
  void report(StepOutcome outcome);
  /// A component's tick (hpr/common/component.hpp): the faults it raised are set and those it
  /// cleared cleared, under the component's keys, and an outcome other than running is reported as
  /// above (a running one leaves what an earlier component of the same step reported).
  void report(const StepReport& component);
  [[nodiscard]] Lifecycle lifecycle() const { return lifecycle_.state(); }

  /// Records one step's compute time (on_tick steps are timed automatically).
  void record_step(std::int64_t tick, double seconds);
  /// Counts a step that ran without a fresh input.
  void count_stale() { ++stale_inputs_; }
  /// Sets or clears a named fault shown in HEALTH; a fault makes the state DEGRADED (or FAULT). One
  /// set with `clear_after_s` clears by itself that long after its last set (monotonic time).
  void set_fault(const std::string& key, const std::string& text, bool fatal = false,
                 double clear_after_s = std::numeric_limits<double>::infinity());
  void clear_fault(const std::string& key);
  [[nodiscard]] bool has_fault(const std::string& key) const { return faults_.count(key) != 0; }
  /// The text of fault `key` ("" when it is not set).
  [[nodiscard]] std::string fault_text(const std::string& key) const {
    const auto it = faults_.find(key);
    return it == faults_.end() ? std::string() : it->second.text;
  }
  void publish_health();

  /// The node's live parameters. The first call subscribes to OPERATOR (sets and gets addressed to
  /// this node) and advertises PARAMS, published once the loop runs and in answer to each request.
  ParameterSet& parameters() { return parameters(name_); }
  /// The live parameters answered under the name `node` (a component this process runs).
  ParameterSet& parameters(const std::string& node);
  /// Publishes PARAMS of `set`: the current values, and the answer to the request `request` (may be null).
  void publish_parameters(const ParameterSet& set, const ParameterRequest* request);

  [[nodiscard]] std::int64_t decode_errors() const;
  /// When the next message of a stepping input is due on the monotonic clock: its last arrival plus
  /// the moving average of its arrival intervals (0 before two have arrived). The busy-poll window
  /// (RuntimeOptions::spin_s) is centred on it.
  [[nodiscard]] double next_arrival() const;
  [[nodiscard]] const RollingStats& cycle_stats() const { return cycle_; }
  [[nodiscard]] std::int64_t deadline_misses() const { return deadline_misses_; }

 private:
  /// Throws std::logic_error when this runtime is a process whose declaration does not list
  /// `channel` among its reads (or, `write`, its writes).
  void check_declared(const std::string& channel, bool write) const;
  /// An input on `name`, declared or not (the runtime's own OPERATOR input for live parameters is
  /// not the process's).
  template <class Msg>
  Input<Msg>& make_input(const std::string& name, typename Input<Msg>::Validator validate, typename Input<Msg>::Callback on_message) {
    const auth::Key* key = nullptr;
    if constexpr (auth::Signed<Msg>) key = deployment_key();
    auto in = std::make_unique<Input<Msg>>(*this, receiver_ ? nullptr : lcm_.get(), channel(name), std::move(validate),
                                           std::move(on_message), key);
    auto& ref = *in;
    if (receiver_) by_channel_[ref.channel()].push_back(&ref);
    inputs_.push_back(std::move(in));
    return ref;
  }
  friend class InputBase;
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
  void on_input(InputBase& in);
  void on_reject(InputBase& in, std::size_t bytes, const std::string& why);
  /// `in` follows a new tick stream: the triggers it drives start again from its next tick.
  void on_follow(InputBase& in, std::int64_t old_tick, std::int64_t new_tick);
  void follow_quiet_streams(double now);
  void mark_absent(Trigger& t, std::size_t i);
  void check_triggers(double now);
  void run_timers(double now);
  double next_wakeup(double now) const;
  /// Reads what is waiting on the own socket and hands each message to its channel's inputs.
  void receive_direct();

  std::string name_;
  std::optional<Ports> declared_;  ///< a process's ports (none: a tool or a test, unchecked)
  RuntimeOptions options_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::unique_ptr<UdpmReceiver> receiver_;  ///< the typed inputs' socket (null: through liblcm)
  std::map<std::string, std::vector<InputBase*>, std::less<>> by_channel_;  ///< with receiver_
  MessageSink deliver_;                     ///< receive_direct's sink, made once
  std::int64_t refused_reported_ = 0;
  bool raw_lcm_used_ = false;
  std::vector<std::unique_ptr<InputBase>> inputs_;
  std::vector<Trigger> triggers_;
  std::vector<Timer> timers_;
  std::vector<std::pair<InputBase*, std::function<void()>>> restarts_;
  bool stop_ = false;
  bool configuration_checked_ = false;

  RollingStats cycle_{1000};
  std::int64_t steps_ = 0, last_tick_ = -1, deadline_misses_ = 0, stale_inputs_ = 0;
  std::int64_t steps_at_rate_time_ = 0;
  double rate_time_ = 0.0, rate_hz_ = 0.0;
  double last_health_ = 0.0, start_time_ = 0.0, last_reject_log_ = -1e9;
  struct Fault {
    std::string text;
    bool fatal;
    double expires;  ///< monotonic time at which it clears by itself (inf: never)
  };
  std::map<std::string, Fault> faults_;
  /// Applies `changed` (an event's result) to the log.
  void log_lifecycle(bool changed, Lifecycle from);
  LifecycleMachine lifecycle_;
  bool in_step_ = false;
  StepOutcome step_outcome_ = StepOutcome::kRunning;
  std::vector<std::uint8_t> health_buffer_;
  std::vector<std::unique_ptr<ParameterSet>> parameters_;  ///< one per name answered
  bool parameters_announced_ = false;
  std::string last_request_;  // source and utime of the last OPERATOR request handled (copies repeat it)
  std::unique_ptr<auth::Key> key_;
  bool warned_unauthenticated_ = false;
  std::int64_t source_id_ = 0;
};

/// Exit codes shared by every process.
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitConfig = 2, kExitLcm = 3 };

/// Standard main body: parses the command line, loads the configuration, opens the runtime and
/// calls `body`. ConfigError exits 2 and LcmError exits 3, each with one message on stderr.
int run_main(int argc, char** argv, const std::string& process, const std::string& summary,
             const std::function<int(const struct CommandLine&, const Config&)>& body);

/// RuntimeOptions from the `lcm` section of a configuration (channel_prefix) and a deadline.
RuntimeOptions runtime_options(const Config& cfg, double deadline_s);
/// The LCM URL: --lcm-url, else lcm.url of the configuration, else $LCM_DEFAULT_URL, else LCM's default.
std::string lcm_url(const struct CommandLine& cl, const Config& cfg);

}  // namespace hpr::node
