#pragma once
/// \file
/// The node runtime shared by every process of the stack.
///
/// A Runtime is a process's node: its Transport (hpr/node/transport.hpp: LCM, the typed inputs and
/// outputs, held to the process's declared ports), its Scheduler (hpr/node/scheduler.hpp: steps,
/// resets and timers), its Health (hpr/node/health.hpp: faults, lifecycle, step times, HEALTH), its
/// ParameterServer (hpr/node/parameter_server.hpp: OPERATOR and PARAMS) and the loop that waits
/// for messages and runs them. What a node sees:
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

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "hpr/common/auth.hpp"
#include "hpr/common/channel.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/parameters.hpp"
#include "hpr/common/ports.hpp"
#include "hpr/node/health.hpp"
#include "hpr/node/input.hpp"
#include "hpr/node/lifecycle.hpp"
#include "hpr/node/output.hpp"
#include "hpr/node/parameter_server.hpp"
#include "hpr/node/scheduler.hpp"
#include "hpr/node/transport.hpp"

namespace hpr::node {

/// The node's options (the configuration's lcm section: runtime_options()); the tick streams'
/// limits are the StreamRules it derives from.
struct RuntimeOptions : StreamRules {
  std::string channel_prefix;   ///< prepended to every channel name
  double health_period_s = 0.1; ///< HEALTH rate
  double deadline_s = 1e-3;     ///< a step longer than this counts as a deadline miss
  /// A channel's decode fault clears this long after its last rejected message (the count in
  /// HEALTH.decode_errors stays).
  double decode_fault_quiet_s = 2.0;
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

class Runtime {
 public:
  using StepFn = Scheduler::StepFn;

  /// Process `declared` (its ports, hpr/common/ports.hpp) as node `node_name` on `lcm_url`; it may
  /// read and write only what `declared` lists (Transport). Throws LcmError with the fix when
  /// multicast is not routable.
  Runtime(const Ports& declared, std::string node_name, const std::string& lcm_url, RuntimeOptions options = {});
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  // The parts.
  [[nodiscard]] Transport& transport() { return transport_; }
  [[nodiscard]] Scheduler& scheduler() { return scheduler_; }
  [[nodiscard]] Health& health() { return health_; }
  [[nodiscard]] const Health& health() const { return health_; }
  [[nodiscard]] const std::string& name() const { return name_; }

  // Transport.
  template <class Msg>
  Input<Msg>& subscribe(const Channel<Msg>& ch, typename Input<Msg>::Validator validate = {},
                        typename Input<Msg>::Callback on_message = {}) {
    return transport_.subscribe(ch, std::move(validate), std::move(on_message));
  }
  template <class Msg>
  Output<Msg> advertise(const Channel<Msg>& ch) {
    return transport_.advertise(ch);
  }
  [[nodiscard]] std::string channel(std::string_view name) const { return transport_.channel(name); }
  [[nodiscard]] std::int64_t source_id() const { return transport_.source_id(); }
  const auth::Key* deployment_key() { return transport_.deployment_key(); }
  [[nodiscard]] bool authenticates() const { return transport_.authenticates(); }
  /// The descriptor that becomes readable when a message for a typed input is waiting (for a loop
  /// of the node's own that polls other descriptors too and then calls spin_once(0)).
  [[nodiscard]] int receive_fd() const { return transport_.receive_fd(); }
  [[nodiscard]] bool receives_directly() const { return transport_.receives_directly(); }
  [[nodiscard]] std::int64_t decode_errors() const { return transport_.decode_errors(); }

  // Scheduler.
  void on_tick(InputBase& primary, std::vector<Sync> synced, double timeout_s, StepFn step) {
    scheduler_.on_tick(primary, std::move(synced), timeout_s, std::move(step));
  }
  /// Calls `reset` when `primary` follows a new tick stream (its source restarted, or its clock
  /// jumped): the node's algorithm starts again from the new clock's first tick.
  void on_restart(InputBase& primary, std::function<void()> reset) { scheduler_.on_restart(primary, std::move(reset)); }
  void every(double period_s, std::function<void()> fn) { scheduler_.every(period_s, std::move(fn)); }
  /// A dropout is never silently held (Scheduler::while_silent).
  void while_silent(const InputBase& input, double timeout_s, const std::string& fault, std::function<void()> fn) {
    scheduler_.while_silent(input, timeout_s, fault, std::move(fn));
  }
  [[nodiscard]] double next_arrival() const { return scheduler_.next_arrival(); }

  // Health.
  void report(StepOutcome outcome) { health_.report(outcome); }
  void report(const StepReport& component) { health_.report(component); }
  [[nodiscard]] Lifecycle lifecycle() const { return health_.lifecycle(); }
  void record_step(std::int64_t tick, double seconds) { health_.record_step(tick, seconds); }
  void count_stale() { health_.count_stale(); }
  void set_fault(const std::string& key, const std::string& text, bool fatal = false,
                 double clear_after_s = std::numeric_limits<double>::infinity()) {
    health_.set_fault(key, text, fatal, clear_after_s);
  }
  void clear_fault(const std::string& key) { health_.clear_fault(key); }
  [[nodiscard]] bool has_fault(const std::string& key) const { return health_.has_fault(key); }
  [[nodiscard]] std::string fault_text(const std::string& key) const { return health_.fault_text(key); }
  void publish_health() { health_.publish(stop_requested(), !scheduler_.steps_on_input()); }
  [[nodiscard]] const RollingStats& cycle_stats() const { return health_.cycle_stats(); }
  [[nodiscard]] std::int64_t deadline_misses() const { return health_.deadline_misses(); }

  // Parameters.
  /// The node's live parameters (the first call subscribes to OPERATOR; PARAMS announces them once
  /// the loop runs).
  ParameterSet& parameters() { return parameters_.parameters(name_); }
  /// The live parameters answered under the name `node` (a component this process runs).
  ParameterSet& parameters(const std::string& node) { return parameters_.parameters(node); }
  void publish_parameters(const ParameterSet& set, const ParameterRequest* request) { parameters_.publish(set, request); }

  // The loop.
  /// Processes messages until stop is requested. Returns the process exit code (0).
  int run();
  /// Processes messages until `done()` holds, `timeout_s` passes or stop is requested.
  /// Returns done().
  bool spin_until(const std::function<bool()>& done, double timeout_s);
  /// Handles whatever is pending, waiting at most `timeout_s`.
  void spin_once(double timeout_s);
  void request_stop() { stop_ = true; }
  [[nodiscard]] bool stop_requested() const;

 private:
  /// Publishes HEALTH when its period has passed.
  void publish_health_when_due(double now);

  std::string name_;
  RuntimeOptions options_;
  // Each part is given the ones it reports to before they are built; none calls another while
  // being built.
  Transport transport_;
  Health health_;
  Scheduler scheduler_;
  ParameterServer parameters_;
  bool stop_ = false;
  bool configuration_checked_ = false;
  double last_health_ = 0.0;
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
