// controllers: the estimator, planner, reference_gen, motion_opt and wbc composed in one process.
//
// Steps on every ROBOT_SENSORS (tick k) through hpr::graph::Controllers, the same components and
// conversions the five processes run, and publishes every channel they publish: JOINT_COMMAND of
// tick k first (the robot waits for it), then ROBOT_STATE, BALANCE_PLAN, CAM_REFERENCE,
// WHOLEBODY_COMMAND and BALANCE_STATUS of tick k. lcm-spy, recording and replay see the same
// messages as from the five processes, with the same contents.
// When the samples stop for longer than `estimator.sensor_timeout`, the last state goes on flagged
// stale at that period, and the wbc damps after `wbc.bad_state_ticks` of them, as with the processes.
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_sensors_t.hpp>

#include "hpr/estimator/node.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/graph/controllers.hpp"
#include "hpr/graph/data_flow.hpp"

namespace {

using namespace hpr;

/// HEALTH of the tick: each component's report, as the five processes apply theirs (with the
/// estimator's log of refused samples).
void report(node::Runtime& rt, const graph::Controllers& c, estimator::TickReport& estimator_report) {
  estimator_report(rt, *c.estimator, *c.reports().front(), c.state().tick);
  for (const StepReport* r : c.reports().subspan(1)) rt.report(*r);
}

/// Each component's live parameters, answered under its process's name ("wbc.com.stiffness.z"), as
/// the five processes answer them.
void add_parameters(node::Runtime& rt, graph::Controllers& c) {
  estimator::add_parameters(rt.parameters("estimator"), c.estimator->tunable_config());
  if (c.generator) reference_gen::add_parameters(rt.parameters("reference_gen"), *c.generator);
  if (c.optimizer) motion_opt::add_parameters(rt.parameters("motion_opt"), c.optimizer->optimizer().tunable_config());
  wbc::add_parameters(rt.parameters("wbc"), c.wbc.controller());
}

}  // namespace

int main(int argc, char** argv) {
  return node::run_main(
      argc, argv, "controllers", "estimator, planner, reference_gen, motion_opt and wbc in one process",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        // wbc.wait_for_wholebody false: the wbc follows the balance plan (the ankle strategy, as the
        // wbc process without motion_opt).
        const bool cam = cfg.section("wbc").boolean_or("wait_for_wholebody", true);
        const graph::ControllersOptions run{.cam = cam, .estimator = true, .messages = true};
        graph::check_exchange_options(cfg, run);
        graph::Controllers c(cfg, robot, run);
        const double sensor_timeout = cfg.section("estimator").real_or("sensor_timeout", 0.02, 1e-3, 60.0);
        node::Runtime rt(graph::controllers_ports(), cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
        SensorSample sample;
        sample.resize(robot.model.nj);
        auto& sensors = rt.subscribe(msg::channels::kRobotSensors,
            [&](const humanoid::robot_sensors_t& m) { return msg::from_message(m, c.names(), sample); });
        rt.subscribe(msg::channels::kOperator, msg::check_operator, [&](const humanoid::operator_t& m) { c.apply(m); });
        add_parameters(rt, c);
        estimator::TickReport estimator_report;
        auto state_out = rt.advertise(msg::channels::kRobotState);
        auto plan_out = rt.advertise(msg::channels::kBalancePlan);
        auto cam_out = rt.advertise(msg::channels::kCamReference);
        auto wholebody_out = rt.advertise(msg::channels::kWholebodyCommand);
        auto command_out = rt.advertise(msg::channels::kJointCommand);
        auto balance_out = rt.advertise(msg::channels::kBalanceStatus);
        // The joint command first (the drives wait for it), then what the five processes publish
        // on the way to it, in their order.
        auto publish = [&] {
          command_out.publish(c.message<humanoid::joint_command_t>());
          state_out.publish(c.message<humanoid::robot_state_t>());
          if (c.have_plan()) plan_out.publish(c.message<humanoid::balance_plan_t>());
          if (c.options().cam) cam_out.publish(c.message<humanoid::cam_reference_t>());
          if (c.have_wholebody()) wholebody_out.publish(c.message<humanoid::wholebody_command_t>());
          if (c.wbc_out().mode == wbc::WbcComponent::Mode::kBalance) balance_out.publish(c.message<humanoid::balance_status_t>());
        };
        rt.on_restart(sensors, [&] { c.reset(); });
        rt.on_tick(sensors, {}, 0.0, [&](const node::TickInfo&) {
          c.estimate(sample);
          c.control();
          publish();
          report(rt, c, estimator_report);
        });
        rt.while_silent(sensors, sensor_timeout, "sensors", [&] {
          c.control(EstimatedState::kSensorStale);
          publish();
          report(rt, c, estimator_report);
        });
        return rt.run();
      });
}
