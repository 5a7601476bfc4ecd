// The node runtime: its parts put together, the loop, and the main body every process shares.
#include "hpr/node/runtime.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <span>

#include <fmt/format.h>

#include "hpr/msg/lcm_section.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/udpm.hpp"

namespace hpr::node {
namespace {

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

Runtime::Runtime(const Ports& declared, std::string node_name, const std::string& lcm_url, RuntimeOptions options)
    : name_(std::move(node_name)),
      options_(std::move(options)),
      transport_(declared, name_, lcm_url, TransportOptions{options_.channel_prefix, options_.authenticate, options_.receive_direct},
                 scheduler_, options_, [this] { return stop_requested(); }),
      health_(name_, transport_, options_.deadline_s, options_.decode_fault_quiet_s),
      scheduler_(health_),
      parameters_(transport_, health_) {
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
  last_health_ = monotonic_s() - options_.health_period_s;  // first HEALTH at once
}

Runtime::~Runtime() = default;

bool Runtime::stop_requested() const { return stop_ || g_signalled.load(); }

void Runtime::publish_health_when_due(double now) {
  if (now - last_health_ >= options_.health_period_s) {
    publish_health();
    last_health_ = now;
  }
}

void Runtime::spin_once(double timeout_s) {
  if (!configuration_checked_) {
    configuration_checked_ = true;
    if (options_.configuration) options_.configuration->check_all_read();
  }
  double now = monotonic_s();
  transport_.follow_quiet_streams(now);
  parameters_.announce_once();
  scheduler_.run_timers(now);
  publish_health_when_due(now);
  scheduler_.check_triggers(now);
  const double next = std::min({last_health_ + options_.health_period_s, scheduler_.next_event(), transport_.next_follow_time()});
  double wake = std::min(std::max(next, now), now + std::max(0.0, timeout_s));
  // The typed inputs' descriptor; with the own socket, liblcm's too once something subscribed there.
  pollfd fds[3] = {{transport_.receive_fd(), POLLIN, 0}, {-1, POLLIN, 0}, {-1, POLLIN, 0}};
  std::size_t nfds = 1;
  const int extra = transport_.extra_fd();
  if (extra >= 0) fds[nfds++].fd = extra;
  if (g_signal_pipe[0] >= 0) fds[nfds++].fd = g_signal_pipe[0];
  const std::span<pollfd> watched(fds, nfds);
  bool spin = false;
  if (options_.spin_s > 0.0) {
    const double due = scheduler_.next_arrival();
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
  if (n > 0) {
    transport_.receive((fds[0].revents & POLLIN) != 0, extra >= 0 && (fds[1].revents & POLLIN) != 0);
  }
  now = monotonic_s();
  scheduler_.check_triggers(now);
  parameters_.announce_once();
  scheduler_.run_timers(now);
  publish_health_when_due(now);
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
  o.command_window_s = l.command_window_s;
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
