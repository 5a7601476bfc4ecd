// What a node reports: HEALTH (its state, rates, counters and faults) and PARAMS (its live
// parameters, and the OPERATOR sets and gets addressed to it).
#include <unistd.h>

#include <algorithm>
#include <humanoid/health_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/params_t.hpp>

#include <fmt/format.h>

#include "hpr/msg/channels.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/node/runtime.hpp"

namespace hpr::node {
namespace {

std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof(buf) - 1) != 0) return "?";
  return buf;
}

}  // namespace

std::int64_t Runtime::decode_errors() const {
  std::int64_t n = 0;
  for (const auto& in : inputs_) n += in->errors();
  return n;
}

void Runtime::publish_health() {
  static const std::string host = host_name();
  humanoid::health_t h;
  const double now = monotonic_s();
  h.tick = last_tick_;
  h.utime = wall_us();
  h.node = name_;
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
  h.num_faults = static_cast<int32_t>(h.faults.size());
  if (stop_requested()) {
    const Lifecycle before = lifecycle_.state();
    log_lifecycle(lifecycle_.on_stop(), before);
    h.state = humanoid::health_t::STATE_STOPPING;
  } else if (fatal) {
    h.state = humanoid::health_t::STATE_FAULT;
  } else if (!faults_.empty()) {
    h.state = humanoid::health_t::STATE_DEGRADED;
  } else {
    h.state = steps_ > 0 || triggers_.empty() ? humanoid::health_t::STATE_OK : humanoid::health_t::STATE_STARTING;
  }
  if (triggers_.empty() && lifecycle_.state() == Lifecycle::kWaiting) report(StepOutcome::kRunning);  // on its own clock
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
  h.decode_errors = decode_errors();
  h.stale_inputs = stale_inputs_;
  // Repeated log lines held back in a second that has ended are said now (all of them when stopping).
  log::flush_repeats(stop_requested());
  h.log_suppressed = log::suppressed();
  h.unauthenticated = 0;
  for (const auto& in : inputs_) h.unauthenticated += in->unauthenticated();
  const int n = h.getEncodedSize();
  health_buffer_.resize(static_cast<std::size_t>(n));
  if (h.encode(health_buffer_.data(), 0, n) >= 0) {
    lcm_->publish(channel(msg::channels::kHealth.name), health_buffer_.data(), static_cast<unsigned>(n));
  }
}

ParameterSet& Runtime::parameters(const std::string& node) {
  for (auto& p : parameters_) {
    if (p->node() == node) return *p;
  }
  const bool first = parameters_.empty();
  parameters_.push_back(std::make_unique<ParameterSet>(node));
  if (!first) return *parameters_.back();
  make_input<humanoid::operator_t>(msg::channels::kOperator.name, msg::check_operator, [this](const humanoid::operator_t& m) {
    const bool set = m.command == humanoid::operator_t::COMMAND_SET_PARAMS;
    if (!set && m.command != humanoid::operator_t::COMMAND_GET_PARAMS) return;
    // Senders repeat a request (UDP may drop one); each is handled once.
    const std::string id = m.source + "@" + std::to_string(m.utime);
    if (id == last_request_) return;
    bool handled = false;
    for (auto& params : parameters_) {
      ParameterRequest request;
      request.utime = m.utime;
      request.source = m.source;
      if (set) {
        const ParameterSetResult r = params->apply(m.param_name, m.param_value);
        if (!r.addressed) continue;
        request.accepted = r.applied;
        request.result = r.text;
        if (r.applied) {
          log::info("{} parameters set by {}: {}", params->node(), m.source, r.text);
        } else {
          log::warn("{} parameters from {} refused, {}", params->node(), m.source, r.text);
        }
      } else {
        const bool mine = m.param_name.empty() ||
                          std::find(m.param_name.begin(), m.param_name.end(), params->node()) != m.param_name.end();
        if (!mine) continue;
        request.accepted = true;
        request.result = "current values";
      }
      handled = true;
      publish_parameters(*params, &request);
    }
    if (handled) last_request_ = id;
  });
  return *parameters_.back();
}

void Runtime::publish_parameters(const ParameterSet& set, const ParameterRequest* request) {
  humanoid::params_t p;
  p.tick = last_tick_;
  p.utime = wall_us();
  p.node = set.node();
  p.version = set.version();
  p.request_utime = request != nullptr ? request->utime : 0;
  p.request_source = request != nullptr ? request->source : "";
  p.accepted = request == nullptr || request->accepted;
  p.result = request != nullptr ? request->result : "started";
  for (const auto& q : set.parameters()) {
    p.name.push_back(q.key);
    p.value.push_back(q.get());
    p.min_value.push_back(q.min_value);
    p.max_value.push_back(q.max_value);
    p.unit.push_back(q.unit);
  }
  p.num_params = static_cast<int32_t>(p.name.size());
  lcm_->publish(channel(msg::channels::kParams.name), &p);
}

}  // namespace hpr::node
