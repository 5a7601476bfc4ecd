// What a node says about itself (hpr/node/health.hpp).
#include "hpr/node/health.hpp"

#include <unistd.h>

#include <cmath>
#include <humanoid/health_t.hpp>

#include <fmt/format.h>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/node/transport.hpp"

namespace hpr::node {
namespace {

std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof(buf) - 1) != 0) return "?";
  return buf;
}

}  // namespace

Health::Health(std::string node, Transport& transport, double deadline_s, double fault_quiet_s)
    : node_(std::move(node)), transport_(transport), deadline_s_(deadline_s), fault_quiet_s_(fault_quiet_s), rate_time_(monotonic_s()) {}

void Health::set_fault(const std::string& key, const std::string& text, bool fatal, double clear_after_s) {
  const Fault f{text, fatal, std::isfinite(clear_after_s) ? monotonic_s() + clear_after_s : clear_after_s};
  auto it = faults_.find(key);
  if (it == faults_.end()) {
    faults_.emplace(key, f);
  } else {
    it->second = f;
  }
}

void Health::clear_fault(const std::string& key) {
  if (!faults_.empty()) faults_.erase(key);
}

std::string Health::fault_text(const std::string& key) const {
  const auto it = faults_.find(key);
  return it == faults_.end() ? std::string() : it->second.text;
}

void Health::log_lifecycle(bool changed, Lifecycle from) {
  if (changed) log::info("lifecycle: {} -> {}", to_string(from), to_string(lifecycle_.state()));
}

void Health::begin_step() {
  const Lifecycle before = lifecycle_.state();
  log_lifecycle(lifecycle_.on_input(), before);
  in_step_ = true;
  step_outcome_ = StepOutcome::kRunning;
}

void Health::end_step(std::int64_t tick, double seconds) {
  in_step_ = false;
  record_step(tick, seconds);
  const Lifecycle stepped_from = lifecycle_.state();
  log_lifecycle(lifecycle_.on_step(step_outcome_), stepped_from);
}

void Health::report(StepOutcome outcome) {
  if (in_step_) {
    step_outcome_ = outcome;
    return;
  }
  const Lifecycle before = lifecycle_.state();
  log_lifecycle(lifecycle_.on_input(), before);
  const Lifecycle stepped_from = lifecycle_.state();
  log_lifecycle(lifecycle_.on_step(outcome), stepped_from);
}

void Health::report(const StepReport& component) {
  for (const StepReport::Fault& f : component.faults()) {
    if (f.change == StepReport::Change::kRaised) {
      set_fault(std::string(f.key), std::string(f.message()));
    } else if (f.change == StepReport::Change::kCleared) {
      clear_fault(std::string(f.key));
    }
  }
  if (component.outcome != StepOutcome::kRunning) report(component.outcome);
}

void Health::refused(const InputBase& in, std::size_t bytes, const std::string& why) {
  const double now = monotonic_s();
  if (now - last_refusal_log_ > 1.0) {
    last_refusal_log_ = now;
    log::warn("{}: rejected a message of {} bytes: {} ({} rejected so far)", in.channel(), bytes, why, in.errors());
  }
  set_fault("decode:" + in.channel(), in.channel() + ": " + why, false, fault_quiet_s_);
}

void Health::followed(const InputBase& in, std::int64_t old_tick, std::int64_t new_tick) {
  const Lifecycle before = lifecycle_.state();
  log_lifecycle(lifecycle_.on_restart(), before);
  set_fault("follow:" + in.channel(), fmt::format("{} followed a new tick stream at tick {} (was {})", in.channel(), new_tick, old_tick),
            false, fault_quiet_s_);
}

void Health::record_step(std::int64_t tick, double seconds) {
  ++steps_;
  last_tick_ = tick;
  last_step_time_ = monotonic_s();
  cycle_.add(seconds * 1e6);
  if (seconds > deadline_s_) ++deadline_misses_;
}

void Health::publish(bool stopping, bool own_clock) {
  static const std::string host = host_name();
  humanoid::health_t h;
  const double now = monotonic_s();
  h.tick = last_tick_;
  h.utime = wall_us();
  h.node = node_;
  h.host = host;
  h.pid = static_cast<int32_t>(::getpid());
  // Faults that clear by themselves (a channel quiet again after malformed messages).
  for (auto it = faults_.begin(); it != faults_.end();) {
    if (now >= it->second.expires) {
      log::info("fault cleared after a quiet period: {}", it->second.text);
      it = faults_.erase(it);
    } else {
      ++it;
    }
  }
  bool fatal = false;
  for (const auto& [key, f] : faults_) {
    h.faults.push_back(f.text);
    fatal = fatal || f.fatal;
  }
  // A node its inputs step, which has stepped and then stopped (an upstream process killed): it
  // waits, and says so, rather than report the last step's "running" for as long as one looks.
  const bool stalled = !own_clock && !stopping && steps_ > 0 && now - last_step_time_ > kStalledAfterS;
  if (stalled) {
    h.faults.push_back(fmt::format("not stepping: the last step (tick {}) was {:.1f} s ago; its inputs are silent", last_tick_,
                                   now - last_step_time_));
    const Lifecycle before = lifecycle_.state();
    if (before != Lifecycle::kWaiting && before != Lifecycle::kStopped) log_lifecycle(lifecycle_.on_restart(), before);
  }
  h.num_faults = static_cast<int32_t>(h.faults.size());
  if (stopping) {
    const Lifecycle before = lifecycle_.state();
    log_lifecycle(lifecycle_.on_stop(), before);
    h.state = humanoid::health_t::STATE_STOPPING;
  } else if (fatal) {
    h.state = humanoid::health_t::STATE_FAULT;
  } else if (!faults_.empty() || stalled) {
    h.state = humanoid::health_t::STATE_DEGRADED;
  } else {
    h.state = steps_ > 0 || own_clock ? humanoid::health_t::STATE_OK : humanoid::health_t::STATE_STARTING;
  }
  if (own_clock && lifecycle_.state() == Lifecycle::kWaiting) report(StepOutcome::kRunning);
  h.lifecycle = static_cast<int8_t>(lifecycle_.state());
  h.steps = steps_;
  // The step rate over at least 0.1 s, however often HEALTH goes out.
  const double dt = now - rate_time_;
  if (dt >= 0.1) {
    rate_hz_ = static_cast<double>(steps_ - steps_at_rate_time_) / dt;
    steps_at_rate_time_ = steps_;
    rate_time_ = now;
  }
  h.rate_hz = rate_hz_;
  h.cycle_median_us = cycle_.median();
  h.cycle_p99_us = cycle_.percentile(0.99);
  h.cycle_max_us = cycle_.max();
  h.deadline_misses = deadline_misses_;
  h.decode_errors = transport_.decode_errors();
  h.stale_inputs = stale_inputs_;
  // Repeated log lines held back in a second that has ended are said now (all of them when stopping).
  log::flush_repeats(stopping);
  h.log_suppressed = log::suppressed();
  h.unauthenticated = transport_.unauthenticated();
  transport_.publish_own(msg::channels::kHealth.name, h);
}

}  // namespace hpr::node
