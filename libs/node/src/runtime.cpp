#include "hpr/node/runtime.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <random>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>

#include "hpr/msg/lcm_section.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/lcm_url.hpp"

namespace hpr::node {
namespace {

/// Datagrams the own socket is drained of at a time: a few ticks' worth, so that timers (HEALTH)
/// and steps run between batches of a backlog.
constexpr std::size_t kDirectDrainBatch = 256;

std::atomic<bool> g_signalled{false};
int g_signal_pipe[2] = {-1, -1};

void on_signal(int /*sig*/) {
  g_signalled.store(true);
  const char c = 's';
  const ssize_t ignored = ::write(g_signal_pipe[1], &c, 1);
  (void)ignored;
}

void install_signal_handlers() {
  static bool installed = false;
  if (installed) return;
  installed = true;
  if (::pipe2(g_signal_pipe, O_NONBLOCK | O_CLOEXEC) != 0) g_signal_pipe[0] = g_signal_pipe[1] = -1;
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

}  // namespace

void Runtime::check_declared(const std::string& ch, bool write) const {
  if (!declared_) return;  // a tool or a test
  if (write ? declared_->writes_to(ch) : declared_->read(ch) != nullptr) return;
  throw std::logic_error(fmt::format("{} {} {}, which its declared ports ({}) do not list", name_, write ? "publishes" : "reads", ch,
                                     declared_->name));
}

Runtime::Runtime(const Ports& declared, std::string node_name, const std::string& lcm_url, RuntimeOptions options)
    : Runtime(std::move(node_name), lcm_url, std::move(options)) {
  declared_ = declared;
}

Runtime::Runtime(std::string node_name, const std::string& lcm_url, RuntimeOptions options)
    : name_(std::move(node_name)), options_(std::move(options)) {
  install_signal_handlers();
  // A supervisor that watches this node for hangs asks for HEALTH often enough to judge it.
  if (const char* env = std::getenv("HPR_HEALTH_RATE_HZ")) {
    char* end = nullptr;
    const double hz = std::strtod(env, &end);
    if (end != env && *end == '\0' && std::isfinite(hz) && hz >= 0.1 && hz <= 1000.0) {
      options_.health_period_s = std::min(options_.health_period_s, 1.0 / hz);
    } else {
      log::warn("HPR_HEALTH_RATE_HZ='{}' ignored: expected a rate in [0.1, 1000] Hz", env);
    }
  }
  lcm_ = open_lcm(lcm_url);
  if (options_.receive_direct && is_udpm_url(lcm_url)) {
    receiver_ = std::make_unique<UdpmReceiver>(parse_udpm_url(with_receive_buffer(lcm_url, kDirectReceiveBufferBytes)));
    deliver_ = [this](std::string_view channel, const std::uint8_t* payload, std::size_t size, std::int64_t /*utime*/) {
      const auto it = by_channel_.find(channel);
      if (it == by_channel_.end()) return;
      // By index: a callback may subscribe (a vector that grows moves, a map node does not).
      for (std::size_t i = 0; i < it->second.size(); ++i) it->second[i]->deliver(payload, size);
    };
  }
  std::random_device entropy;
  while (source_id_ == 0) source_id_ = static_cast<std::int64_t>((std::uint64_t{entropy()} << 32) | entropy());
  start_time_ = monotonic_s();
  rate_time_ = start_time_;
  last_health_ = start_time_ - options_.health_period_s;  // first HEALTH at once
}

Runtime::~Runtime() = default;

const auth::Key* Runtime::deployment_key() {
  if (!options_.authenticate) {
    if (!warned_unauthenticated_) {
      log::warn("lcm.authentication is off: commands (OPERATOR, JOINT_COMMAND, SUPERVISOR_COMMAND) and the control chain's "
                "samples are accepted from anyone on the LCM network, and sent unsigned");
      warned_unauthenticated_ = true;
    }
    return nullptr;
  }
  if (!key_) key_ = std::make_unique<auth::Key>(auth::load_key(auth::key_path()));
  return key_.get();
}

bool Runtime::stop_requested() const { return stop_ || g_signalled.load(); }

void Runtime::on_tick(InputBase& primary, std::vector<Sync> synced, double timeout_s, StepFn step) {
  primary.follow_ticks();
  for (auto& s : synced) s.input->follow_ticks();
  const std::size_t n = synced.size();
  Trigger t{&primary, std::move(synced), timeout_s, std::move(step), -1, -1, 0.0, std::vector<char>(n, 0)};
  triggers_.push_back(std::move(t));
}

void Runtime::on_restart(InputBase& primary, std::function<void()> reset) {
  primary.follow_ticks();
  restarts_.emplace_back(&primary, std::move(reset));
}

void Runtime::every(double period_s, std::function<void()> fn) {
  timers_.push_back(Timer{period_s, monotonic_s() + period_s, std::move(fn)});
}

void Runtime::while_silent(const InputBase& input, double timeout_s, const std::string& fault, std::function<void()> fn) {
  every(timeout_s, [this, &input, timeout_s, fault, fn = std::move(fn), silent = false]() mutable {
    if (!input.has_value()) return;
    const double age = monotonic_s() - input.receive_time();
    if (age <= timeout_s) {
      if (silent) {
        log::info("{} back at tick {}", input.channel(), input.tick());
        clear_fault(fault);
        silent = false;
      }
      return;
    }
    if (!silent) log::warn("{} stale since tick {}", input.channel(), input.tick());
    silent = true;
    set_fault(fault, fmt::format("no {} for {:.0f} ms", input.channel(), age * 1e3));
    fn();
  });
}

void Runtime::on_input(InputBase& in) {
  const double now = monotonic_s();
  for (auto& t : triggers_) {
    for (std::size_t i = 0; i < t.synced.size(); ++i) {
      if (t.synced[i].input == &in && t.absent[i] != 0) {
        t.absent[i] = 0;
        clear_fault("absent:" + in.channel());
        log::info("{} is back at tick {}: waited for again", in.channel(), in.tick());
      }
    }
    if (t.primary == &in && in.tick() > t.last_tick && in.tick() != t.pending_tick) {
      // A newer primary tick while one is still waiting for its synced inputs: the robot's clock has
      // moved on, so the newest tick is served at once with the inputs at hand (timed_out) rather
      // than waiting longer and falling behind. In lockstep the next tick cannot arrive before
      // this node has answered, so there every step sees its synced inputs.
      const bool waiting = t.pending_tick > t.last_tick;
      t.deadline = waiting ? now : now + t.timeout_s;
      t.pending_tick = in.tick();
      const double dt = now - t.arrival;
      if (t.arrival > 0.0 && dt > 1e-5 && dt < 1.0) t.period = t.period > 0.0 ? 0.9 * t.period + 0.1 * dt : dt;
      t.arrival = now;
    }
  }
  check_triggers(now);
}

void Runtime::on_reject(InputBase& in, std::size_t bytes, const std::string& why) {
  const double now = monotonic_s();
  if (now - last_reject_log_ > 1.0) {
    last_reject_log_ = now;
    log::warn("{}: rejected a message of {} bytes: {} ({} rejected so far)", in.channel(), bytes, why,
              in.errors());
  }
  set_fault("decode:" + in.channel(), in.channel() + ": " + why, false, options_.decode_fault_quiet_s);
}

void Runtime::on_follow(InputBase& in, std::int64_t old_tick, std::int64_t new_tick) {
  for (auto& t : triggers_) {
    if (t.primary != &in) continue;
    // The clock this trigger stepped on is gone: step the new one from its tick, and take the
    // synced inputs' next ticks as they come (their sources restarted too, or will).
    t.last_tick = -1;
    t.pending_tick = -1;
    for (auto& s : t.synced) {
      if (s.input->tick() > new_tick + s.tick_offset) s.input->restart_stream();
      s.input->follow_if_quiet(std::numeric_limits<double>::infinity());
    }
  }
  for (auto& [input, reset] : restarts_) {
    if (input == &in) reset();
  }
  const Lifecycle before = lifecycle_.state();
  log_lifecycle(lifecycle_.on_restart(), before);
  set_fault("follow:" + in.channel(), fmt::format("{} followed a new tick stream at tick {} (was {})", in.channel(), new_tick, old_tick),
            false, options_.decode_fault_quiet_s);
}

void Runtime::mark_absent(Trigger& t, std::size_t i) {
  t.absent[i] = 1;
  const InputBase& in = *t.synced[i].input;
  const std::string text = fmt::format("{} absent since tick {}: stepping without it", in.channel(), t.pending_tick);
  log::warn("{} (no message within {} s)", text, t.timeout_s);
  set_fault("absent:" + in.channel(), text);
}

void Runtime::follow_quiet_streams(double now) {
  for (auto& in : inputs_) in->follow_if_quiet(now);
}

void Runtime::check_triggers(double now) {
  for (auto& t : triggers_) {
    if (t.pending_tick < 0 || t.pending_tick <= t.last_tick) continue;
    TickInfo info;
    info.tick = t.pending_tick;
    bool waiting = false;
    for (std::size_t i = 0; i < t.synced.size(); ++i) {
      const Sync& s = t.synced[i];
      if (s.input->tick() < t.pending_tick + s.tick_offset && (!s.needed || s.needed())) {
        info.late.push_back(s.input);
        // An optional input silent for a whole timeout is absent, however the steps were released.
        if (s.optional && t.absent[i] == 0 && s.input->has_value() && now - s.input->receive_time() > t.timeout_s) mark_absent(t, i);
        waiting = waiting || t.absent[i] == 0;
      }
    }
    if (waiting && now < t.deadline) continue;
    if (!info.late.empty()) {
      info.timed_out = true;
      ++stale_inputs_;
    }
    for (std::size_t i = 0; i < t.synced.size() && waiting; ++i) {
      const Sync& s = t.synced[i];
      if (!s.optional || t.absent[i] != 0 || std::find(info.late.begin(), info.late.end(), s.input) == info.late.end()) continue;
      mark_absent(t, i);
    }
    t.last_tick = t.pending_tick;
    const Lifecycle before = lifecycle_.state();
    log_lifecycle(lifecycle_.on_input(), before);
    const double t0 = monotonic_s();
    in_step_ = true;
    step_outcome_ = StepOutcome::kRunning;
    try {
      t.step(info);
      clear_fault("step");
    } catch (const std::exception& e) {
      log::error("step of tick {} failed: {}", info.tick, e.what());
      set_fault("step", std::string("step failed: ") + e.what());
    }
    in_step_ = false;
    record_step(info.tick, monotonic_s() - t0);
    const Lifecycle stepped_from = lifecycle_.state();
    log_lifecycle(lifecycle_.on_step(step_outcome_), stepped_from);
  }
}

void Runtime::report(StepOutcome outcome) {
  if (in_step_) {
    step_outcome_ = outcome;
    return;
  }
  const Lifecycle before = lifecycle_.state();
  log_lifecycle(lifecycle_.on_input(), before);
  const Lifecycle stepped_from = lifecycle_.state();
  log_lifecycle(lifecycle_.on_step(outcome), stepped_from);
}

void Runtime::report(const StepReport& component) {
  for (const StepReport::Fault& f : component.faults()) {
    if (f.change == StepReport::Change::kRaised) {
      set_fault(std::string(f.key), std::string(f.message()));
    } else if (f.change == StepReport::Change::kCleared) {
      clear_fault(std::string(f.key));
    }
  }
  if (component.outcome != StepOutcome::kRunning) report(component.outcome);
}

void Runtime::log_lifecycle(bool changed, Lifecycle from) {
  if (changed) log::info("lifecycle: {} -> {}", to_string(from), to_string(lifecycle_.state()));
}

void Runtime::record_step(std::int64_t tick, double seconds) {
  ++steps_;
  last_tick_ = tick;
  cycle_.add(seconds * 1e6);
  if (seconds > options_.deadline_s) ++deadline_misses_;
}

void Runtime::run_timers(double now) {
  if (!parameters_.empty() && !parameters_announced_) {
    parameters_announced_ = true;
    for (const auto& p : parameters_) publish_parameters(*p, nullptr);
  }
  for (auto& t : timers_) {
    if (now >= t.next) {
      t.next += t.period;
      if (t.next < now) t.next = now + t.period;  // skip missed periods rather than bursting
      t.fn();
    }
  }
  if (now - last_health_ >= options_.health_period_s) {
    publish_health();
    last_health_ = now;
  }
}

double Runtime::next_arrival() const {
  double due = 0.0;
  for (const auto& t : triggers_) {
    if (t.period > 0.0 && (due == 0.0 || t.arrival + t.period < due)) due = t.arrival + t.period;
  }
  return due;
}

double Runtime::next_wakeup(double now) const {
  double next = last_health_ + options_.health_period_s;
  for (const auto& t : timers_) next = std::min(next, t.next);
  for (const auto& t : triggers_) {
    if (t.pending_tick > t.last_tick) next = std::min(next, t.deadline);
  }
  for (const auto& in : inputs_) next = std::min(next, in->follow_time());
  return std::max(next, now);
}

void Runtime::spin_once(double timeout_s) {
  if (!configuration_checked_) {
    configuration_checked_ = true;
    if (options_.configuration) options_.configuration->check_all_read();
  }
  double now = monotonic_s();
  follow_quiet_streams(now);
  run_timers(now);
  check_triggers(now);
  double wake = std::min(next_wakeup(now), now + std::max(0.0, timeout_s));
  // The typed inputs' descriptor; with the own socket, liblcm's too once something subscribed there.
  pollfd fds[3] = {{receive_fd(), POLLIN, 0}, {-1, POLLIN, 0}, {-1, POLLIN, 0}};
  std::size_t nfds = 1;
  const bool raw = receiver_ && raw_lcm_used_;
  if (raw) fds[nfds++].fd = lcm_->getFileno();
  if (g_signal_pipe[0] >= 0) fds[nfds++].fd = g_signal_pipe[0];
  const std::span<pollfd> watched(fds, nfds);
  bool spin = false;
  if (options_.spin_s > 0.0) {
    const double due = next_arrival();
    if (due > 0.0 && now >= due - options_.spin_s && now < due + options_.spin_s) {
      spin = true;
      wake = std::min(wake, due + options_.spin_s);
    } else if (due > 0.0 && now < due - options_.spin_s) {
      wake = std::min(wake, due - options_.spin_s);
    }
  }
  int n = 0;
  if (spin) {
    do {
      n = poll_for(watched, 0.0);
    } while (n == 0 && !stop_requested() && monotonic_s() < wake);
  } else {
    n = poll_for(watched, wake - now);
  }
  const auto handle_lcm = [&] {
    lcm_->handle();
    // Drain whatever else is already queued, without blocking.
    pollfd more{lcm_->getFileno(), POLLIN, 0};
    while (!stop_requested() && ::poll(&more, 1, 0) > 0 && (more.revents & POLLIN) != 0) lcm_->handle();
  };
  if (n > 0 && (fds[0].revents & POLLIN) != 0) {
    if (receiver_) {
      receive_direct();
    } else {
      handle_lcm();
    }
  }
  if (n > 0 && raw && (fds[1].revents & POLLIN) != 0) handle_lcm();
  now = monotonic_s();
  check_triggers(now);
  run_timers(now);
}

int Runtime::receive_fd() const { return receiver_ ? receiver_->fd() : lcm_->getFileno(); }

void Runtime::receive_direct() {
  receiver_->drain(deliver_, kDirectDrainBatch);
  if (receiver_->refused() != refused_reported_) {
    const double now = monotonic_s();
    if (now - last_reject_log_ > 1.0) {
      last_reject_log_ = now;
      log::warn("LCM: refused {} ({} datagrams refused so far)", receiver_->last_refusal(), receiver_->refused());
      refused_reported_ = receiver_->refused();
    }
  }
}

int Runtime::run() {
  while (!stop_requested()) spin_once(0.1);
  stop_ = true;
  publish_health();
  return kExitOk;
}

bool Runtime::spin_until(const std::function<bool()>& done, double timeout_s) {
  const double end = monotonic_s() + timeout_s;
  while (!done()) {
    const double now = monotonic_s();
    if (stop_requested() || now >= end) return done();
    spin_once(std::min(end - now, 0.1));
  }
  return true;
}

void Runtime::set_fault(const std::string& key, const std::string& text, bool fatal, double clear_after_s) {
  const Fault f{text, fatal, std::isfinite(clear_after_s) ? monotonic_s() + clear_after_s : clear_after_s};
  auto it = faults_.find(key);
  if (it == faults_.end()) {
    faults_.emplace(key, f);
  } else {
    it->second = f;
  }
}

void Runtime::clear_fault(const std::string& key) {
  if (!faults_.empty()) faults_.erase(key);
}

RuntimeOptions runtime_options(const Config& cfg, double deadline_s) {
  const msg::LcmSection l = msg::LcmSection::load(cfg);
  RuntimeOptions o;
  o.deadline_s = deadline_s;
  o.configuration = std::make_shared<const Config>(cfg);
  o.channel_prefix = l.channel_prefix;
  o.health_period_s = 1.0 / l.health_rate_hz;
  o.decode_fault_quiet_s = l.decode_fault_quiet_s;
  o.tick_window = l.tick_window;
  o.source_quiet_s = l.source_quiet_s;
  o.tick_period_max_s = l.tick_period_max_s;
  o.time_slack_s = l.time_slack_s;
  o.spin_s = l.spin_s;
  o.receive_direct = l.receive_direct;
  o.authenticate = l.authenticate;
  return o;
}

std::string lcm_url(const CommandLine& cl, const Config& cfg) { return resolve_lcm_url(cl.lcm_url, msg::LcmSection::load(cfg).url); }

int run_main(int argc, char** argv, const std::string& process, const std::string& summary,
             const std::function<int(const CommandLine&, const Config&)>& body) {
  const CommandLine cl = CommandLine::parse(argc, argv, process, summary);
  log::init_from_env(cl.name);
  try {
    const Config cfg = Config::load(cl.config_path, cl.overrides);
    return body(cl, cfg);
  } catch (const ConfigError& e) {
    log::error("configuration error: {}", e.what());
    return kExitConfig;
  } catch (const LcmError& e) {
    log::error("{}", e.what());
    return kExitLcm;
  } catch (const auth::AuthError& e) {
    log::error("{}", e.what());
    return kExitConfig;
  } catch (const std::exception& e) {
    log::error("{}", e.what());
    return kExitFailure;
  }
}

}  // namespace hpr::node
