// planner: the balance planner process.
//
// Steps on every ROBOT_STATE (tick k) and publishes the BALANCE_PLAN of tick k: the task-space
// reference that motion_opt optimises around and the wbc tracks, with the planner's stage, the
// external force it resists, the capture point and the step under way. Nothing until a usable
// estimate has started the posture (the wbc damps meanwhile). OPERATOR support requests shift the
// support.
#include <humanoid/balance_plan_t.hpp>
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_state_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/msg/plan.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/planner/component.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "planner", "balance planner: posture, support changes, push compensation and steps",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        planner::BalancePlanner planner(robot, balance::PostureReferenceConfig::load(cfg.section("balance")));
        node::Runtime rt(planner::BalancePlanner::kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
        msg::RobotNames names;
        names.joints = robot.model.joint_name;
        std::vector<std::string> free_names;
        for (int j : robot.free_joints) free_names.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
        EstimatedState state;
        auto& state_in = rt.subscribe(msg::channels::kRobotState,
            [&](const humanoid::robot_state_t& m) { return msg::from_message(m, names, state); });
        rt.subscribe(msg::channels::kOperator, msg::check_operator, [&](const humanoid::operator_t& m) {
          if (m.command != humanoid::operator_t::COMMAND_SET_SUPPORT) return;
          const auto s = static_cast<balance::Support>(m.support);
          log::info("OPERATOR from {}: support {} requested", m.source, balance::to_string(s));
          planner.request_support(s, state.time);
        });
        auto out = rt.advertise(msg::channels::kBalancePlan);
        planner::BalancePlanner::Outputs plan;
        humanoid::balance_plan_t msg{};
        rt.on_restart(state_in, [&] { planner.reset(); });
        rt.on_tick(state_in, {}, 0.0, [&](const node::TickInfo&) {
          planner.step({state}, plan);
          rt.report(plan.report);
          if (!plan.valid) return;
          msg::to_message(plan.plan, free_names, names, msg);
          out.publish(msg);
        });
        return rt.run();
      });
}
