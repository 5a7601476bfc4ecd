#include "hpr/wbc/node.hpp"

#include <cmath>

#include "hpr/common/log.hpp"

namespace hpr::wbc {

WbcNodeOptions WbcNodeOptions::load(const Config& c) {
  WbcNodeOptions o;
  o.wait_for_wholebody = c.boolean_or("wait_for_wholebody", o.wait_for_wholebody);
  o.wholebody_timeout = c.real_or("wholebody_timeout", o.wholebody_timeout, 0.0, 60.0);
  o.wholebody_stale_ticks = static_cast<int>(c.integer_or("wholebody_stale_ticks", o.wholebody_stale_ticks, 1, 100000));
  o.plan_stale_ticks = static_cast<int>(c.integer_or("plan_stale_ticks", o.plan_stale_ticks, 1, 100000));
  o.bad_state_ticks = static_cast<int>(c.integer_or("bad_state_ticks", o.bad_state_ticks, 1, 100000));
  return o;
}

void apply_operator(WbcComponent& wbc, const humanoid::operator_t& m) {
  if (m.command == humanoid::operator_t::COMMAND_DAMP || m.command == humanoid::operator_t::COMMAND_STOP) {
    if (!wbc.damping()) {
      log::warn("OPERATOR {} from {}: damping ({})", m.command == humanoid::operator_t::COMMAND_STOP ? "stop" : "damp", m.source,
                m.reason);
    }
    wbc.set_damping(true);
  } else if (m.command == humanoid::operator_t::COMMAND_ENABLE) {
    if (wbc.damping()) log::info("OPERATOR enable from {}", m.source);
    wbc.set_damping(false);
  }
}

}  // namespace hpr::wbc
