// motion_opt: the CAM-based whole-body motion optimisation process.
//
// Steps on every ROBOT_STATE (tick k) with the BALANCE_PLAN and the CAM_REFERENCE of the same tick,
// and publishes the WHOLEBODY_COMMAND of tick k: the balance plan with the optimised adjusted DoF.
#include <humanoid/balance_plan_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include "hpr/motion_opt/component.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/balance.hpp"
#include "hpr/msg/plan.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "motion_opt", "CAM-based whole-body motion optimisation",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        const Config section = cfg.section("motion_opt");
        motion_opt::MotionOptComponent opt(robot, motion_opt::MotionOptConfig::load(section, robot));
        const bool wait = section.boolean_or("wait_for_reference", true);
        const double timeout = section.real_or("reference_timeout", 0.5, 0.0, 60.0);
        const long stale_ticks = section.integer_or("reference_stale_ticks", 20, 1, 100000);
        const long plan_stale_ticks = section.integer_or("plan_stale_ticks", 20, 1, 100000);
        node::Runtime rt(motion_opt::MotionOptComponent::kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, opt.optimizer().config().dt));
        msg::RobotNames names;
        names.joints = robot.model.joint_name;
        std::vector<std::string> free_names;
        for (int j : robot.free_joints) free_names.push_back(robot.model.joint_name[static_cast<size_t>(j)]);
        EstimatedState state;
        balance::BalancePlan plan;
        balance::CamReference cam;
        bool have_plan = false;  // since the state's clock started
        auto& state_in = rt.subscribe(msg::channels::kRobotState,
            [&](const humanoid::robot_state_t& m) { return msg::from_message(m, names, state); });
        auto& cam_in = rt.subscribe(msg::channels::kCamReference,
            [&](const humanoid::cam_reference_t& m) { return msg::from_message(m, cam); });
        auto& plan_in = rt.subscribe(msg::channels::kBalancePlan,
            [&](const humanoid::balance_plan_t& m) { return msg::from_message(m, free_names, plan); },
            [&](const humanoid::balance_plan_t&) { have_plan = true; });
        motion_opt::add_parameters(rt.parameters(), opt.optimizer().tunable_config());
        auto out = rt.advertise(msg::channels::kWholebodyCommand);
        motion_opt::MotionOptComponent::Outputs command;
        humanoid::wholebody_command_t msg{};
        std::vector<node::Sync> sync;
        // BALANCE_PLAN of the same tick, once the planner plans (it starts on the first usable
        // state): without a plan there is nothing to optimise around.
        const Read& p = motion_opt::MotionOptComponent::kPorts.at(channel::kBalancePlan);
        sync.push_back({&plan_in, p.tick_offset, [&] { return have_plan || state.usable(); }, p.optional});
        // CAM_REFERENCE of the same tick, optional: without it, the posture task only.
        const Read& r = motion_opt::MotionOptComponent::kPorts.at(channel::kCamReference);
        if (wait) sync.push_back({&cam_in, r.tick_offset, {}, r.optional});
        rt.on_restart(state_in, [&] {
          opt.reset();
          have_plan = false;
        });
        rt.on_tick(state_in, sync, timeout, [&](const node::TickInfo& info) {
          const bool fresh = cam_in.has_value() && cam_in.tick() >= info.tick - stale_ticks;
          const bool planned = have_plan && plan_in.tick() >= info.tick - plan_stale_ticks;
          opt.step({.state = state,
                    .plan = OptionalRef<balance::TaskReference>::when(planned, plan.reference),
                    .cam = OptionalRef<balance::CamReference>::when(fresh, cam)},
                   command);
          rt.report(command.report);
          if (!command.valid) return;
          command.wholebody.tick = info.tick;
          msg::to_message(command.wholebody, free_names, names, msg);
          out.publish(msg);
        });
        return rt.run();
      });
}
