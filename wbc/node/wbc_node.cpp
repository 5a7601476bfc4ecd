#include "hpr/wbc/node.hpp"

#include <cmath>

#include "hpr/common/log.hpp"
#include "hpr/msg/channels.hpp"

namespace hpr::wbc {

WbcNodeOptions WbcNodeOptions::load(const Config& c) {
  WbcNodeOptions o;
  o.wait_for_wholebody = c.boolean_or("wait_for_wholebody", o.wait_for_wholebody);
  o.wholebody_timeout = c.real_or("wholebody_timeout", o.wholebody_timeout, 0.0, 60.0);
  o.wholebody_stale_ticks = static_cast<int>(c.integer_or("wholebody_stale_ticks", o.wholebody_stale_ticks, 1, 100000));
  o.bad_state_ticks = static_cast<int>(c.integer_or("bad_state_ticks", o.bad_state_ticks, 1, 100000));
  return o;
}

WbcNode::WbcNode(node::Runtime& rt, const model::RobotSpec& robot, WbcComponent& wbc, planner::BalancePlanner& planner,
                 WbcNodeOptions options)
    : rt_(rt), wbc_(wbc), planner_(planner), options_(options) {
  names_.joints = robot.model.joint_name;
  for (int j : robot.free_joints) free_names_.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
  out_.command.resize(robot.model.nj);
  command_out_ = rt.advertise(msg::channels::kJointCommand);
  status_out_ = rt.advertise(msg::channels::kBalanceStatus);
  wholebody_in_ = &rt.subscribe(msg::channels::kWholebodyCommand,
      [this](const humanoid::wholebody_command_t& m) { return msg::from_message(m, free_names_, wholebody_); },
      [this](const humanoid::wholebody_command_t&) { have_wholebody_ = true; });
  rt.subscribe(msg::channels::kOperator, msg::check_operator, [this](const humanoid::operator_t& m) {
    if (const auto s = apply_operator(wbc_, m)) planner_.request_support(*s, state_.time);
  });
  add_parameters(rt.parameters(), wbc_.controller());
  std::vector<node::Sync> sync;
  state_in_ = &rt.subscribe(msg::channels::kRobotState,
      [this](const humanoid::robot_state_t& m) { return msg::from_message(m, names_, state_); });
  // The motion optimiser's command of the tick, unless this tick only damps (operator damp, no
  // estimate yet to start from, or one unusable for bad_state_ticks): whenever the controller
  // balances it uses the command of this tick, as in the composed pipeline.
  if (options_.wait_for_wholebody) {
    // Optional: with the motion optimiser gone, the wbc follows the balance plan (the ankle
    // strategy) at full rate.
    const Read& w = WbcComponent::kPorts.at(channel::kWholebodyCommand);
    sync.push_back({wholebody_in_, w.tick_offset, [this] { return wbc_.uses_wholebody(state_, planner_.will_plan(state_)); }, w.optional});
  }
  rt.on_restart(*state_in_, [this] {
    planner_.reset();
    wbc_.reset();
    have_wholebody_ = false;
  });
  rt.on_tick(*state_in_, sync, options_.wholebody_timeout,
             [this](const node::TickInfo& info) {
               const bool fresh = have_wholebody_ && wholebody_in_->tick() >= info.tick - options_.wholebody_stale_ticks;
               if (info.timed_out) rt_.count_stale();
               step(state_, fresh);
             });
}

std::optional<balance::Support> apply_operator(WbcComponent& wbc, const humanoid::operator_t& m) {
  if (m.command == humanoid::operator_t::COMMAND_DAMP || m.command == humanoid::operator_t::COMMAND_STOP) {
    if (!wbc.damping()) {
      log::warn("OPERATOR {} from {}: damping ({})", m.command == humanoid::operator_t::COMMAND_STOP ? "stop" : "damp", m.source,
                m.reason);
    }
    wbc.set_damping(true);
  } else if (m.command == humanoid::operator_t::COMMAND_ENABLE) {
    if (wbc.damping()) log::info("OPERATOR enable from {}", m.source);
    wbc.set_damping(false);
  } else if (m.command == humanoid::operator_t::COMMAND_SET_SUPPORT && m.support >= 0 && m.support <= 2) {
    const auto s = static_cast<balance::Support>(m.support);
    log::info("OPERATOR: support {} requested", balance::to_string(s));
    return s;
  }
  return std::nullopt;
}

void WbcNode::publish() {
  msg::to_message(out_.command, names_, command_msg_);
  command_out_.publish(command_msg_);
  if (out_.mode != WbcComponent::Mode::kBalance) return;
  msg::to_message(out_.status, names_, status_msg_);
  status_out_.publish(status_msg_);
}

void WbcNode::step(const EstimatedState& state, bool wholebody_fresh) {
  planner_.step({state}, plan_);
  wbc_.step({.state = state,
             .plan = OptionalRef<balance::TaskReference>::when(plan_.valid, plan_.plan),
             .wholebody = OptionalRef<balance::TaskReference>::when(wholebody_fresh, wholebody_.command)}, out_);
  rt_.report(out_.report);
  publish();
}

}  // namespace hpr::wbc
