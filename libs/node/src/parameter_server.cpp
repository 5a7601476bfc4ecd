// A node's live parameters on the wire (hpr/node/parameter_server.hpp).
#include "hpr/node/parameter_server.hpp"

#include <algorithm>
#include <humanoid/operator_t.hpp>
#include <humanoid/params_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/node/health.hpp"
#include "hpr/node/transport.hpp"

namespace hpr::node {

ParameterSet& ParameterServer::parameters(const std::string& node) {
  for (auto& p : sets_) {
    if (p->node() == node) return *p;
  }
  const bool first = sets_.empty();
  sets_.push_back(std::make_unique<ParameterSet>(node));
  if (!first) return *sets_.back();
  transport_.make_input<humanoid::operator_t>(msg::channels::kOperator.name, msg::check_operator, [this](const humanoid::operator_t& m) {
    const bool set = m.command == humanoid::operator_t::COMMAND_SET_PARAMS;
    if (!set && m.command != humanoid::operator_t::COMMAND_GET_PARAMS) return;
    // Senders repeat a request (UDP may drop one); each is handled once.
    const std::string id = m.source + "@" + std::to_string(m.utime);
    if (id == last_request_) return;
    bool handled = false;
    for (auto& params : sets_) {
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
      publish(*params, &request);
    }
    if (handled) last_request_ = id;
  });
  return *sets_.back();
}

void ParameterServer::announce_once() {
  if (sets_.empty() || announced_) return;
  announced_ = true;
  for (const auto& p : sets_) publish(*p, nullptr);
}

void ParameterServer::publish(const ParameterSet& set, const ParameterRequest* request) {
  humanoid::params_t p;
  p.tick = health_.last_tick();
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
  transport_.publish_own(msg::channels::kParams.name, p);
}

}  // namespace hpr::node
