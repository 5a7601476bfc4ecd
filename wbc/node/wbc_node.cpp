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
  o.plan_stale_ticks = static_cast<int>(c.integer_or("plan_stale_ticks", o.plan_stale_ticks, 1, 100000));
  o.bad_state_ticks = static_cast<int>(c.integer_or("bad_state_ticks", o.bad_state_ticks, 1, 100000));
  return o;
}

WbcNode::WbcNode(node::Runtime& rt, const model::RobotSpec& robot, WbcComponent& wbc, WbcNodeOptions options)
    : rt_(rt), wbc_(wbc), options_(options) {
  names_.joints = robot.model.joint_name;
  for (int j : robot.free_joints) free_names_.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
  out_.command.resize(robot.model.nj);
  command_out_ = rt.advertise(msg::channels::kJointCommand);
  status_out_ = rt.advertise(msg::channels::kBalanceStatus);
  wholebody_in_ = &rt.subscribe(msg::channels::kWholebodyCommand,
      [this](const humanoid::wholebody_command_t& m) { return msg::from_message(m, free_names_, wholebody_); },
      [this](const humanoid::wholebody_command_t&) { have_wholebody_ = true; });
  plan_in_ = &rt.subscribe(msg::channels::kBalancePlan,
      [this](const humanoid::balance_plan_t& m) { return msg::from_message(m, free_names_, plan_); },
      [this](const humanoid::balance_plan_t&) { have_plan_ = true; });
  // Support requests are the planner's.
  rt.subscribe(msg::channels::kOperator, msg::check_operator, [this](const humanoid::operator_t& m) { (void)apply_operator(wbc_, m); });
  add_parameters(rt.parameters(), wbc_.controller());
  std::vector<node::Sync> sync;
  state_in_ = &rt.subscribe(msg::channels::kRobotState,
      [this](const humanoid::robot_state_t& m) { return msg::from_message(m, names_, state_); });
  // The balance plan of the tick, once the planner plans (from the first usable state on), unless
  // this tick only damps (operator damp, an estimate unusable for bad_state_ticks): a damping wbc
  // answers at once, with the planner gone too.
  const Read& p = WbcComponent::kPorts.at(channel::kBalancePlan);
  sync.push_back({plan_in_, p.tick_offset, [this] { return wbc_.balances(state_, will_plan()); }, p.optional});
  // The motion optimiser's command of the tick, unless this tick only damps (operator damp, no
  // plan, or an estimate unusable for bad_state_ticks): whenever the controller balances it uses
  // the command of this tick, as in the composed pipeline.
  if (options_.wait_for_wholebody) {
    // Optional: with the motion optimiser gone, the wbc follows the balance plan (the ankle
    // strategy) at full rate.
    const Read& w = WbcComponent::kPorts.at(channel::kWholebodyCommand);
    sync.push_back({wholebody_in_, w.tick_offset, [this] { return wbc_.balances(state_, will_plan()); }, w.optional});
  }
  rt.on_restart(*state_in_, [this] {
    wbc_.reset();
    have_wholebody_ = false;
    have_plan_ = false;
  });
  rt.on_tick(*state_in_, sync, options_.wholebody_timeout,
             [this](const node::TickInfo& info) {
               const bool fresh = have_wholebody_ && wholebody_in_->tick() >= info.tick - options_.wholebody_stale_ticks;
               const bool planned = have_plan_ && plan_in_->tick() >= info.tick - options_.plan_stale_ticks;
               if (info.timed_out) rt_.count_stale();
               step(state_, planned, fresh);
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

void WbcNode::step(const EstimatedState& state, bool planned, bool wholebody_fresh) {
  wbc_.step({.state = state,
             .plan = OptionalRef<balance::TaskReference>::when(planned, plan_.reference),
             .wholebody = OptionalRef<balance::TaskReference>::when(wholebody_fresh, wholebody_.command)}, out_);
  rt_.report(out_.report);
  publish();
}

}  // namespace hpr::wbc
