// estimator: floating-base state, CoM and measured CAM from the robot's sensors.
//
// Steps on every ROBOT_SENSORS sample and publishes ROBOT_STATE for the same tick. When the samples
// stop for longer than `estimator.sensor_timeout` (wall clock), it republishes the last state
// flagged STATUS_SENSOR_STALE at that period and reports the dropout in HEALTH: a dropout is never
// silently held.
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>

#include "hpr/estimator/node.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "estimator", "floating-base state estimator",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        const Config section = cfg.section("estimator");
        estimator::Estimator est(robot, estimator::EstimatorConfig::load(section));
        const double sensor_timeout = section.real_or("sensor_timeout", 0.02, 1e-3, 60.0);
        node::Runtime rt(estimator::Estimator::kPorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
        msg::RobotNames names;
        names.joints = robot.model.joint_name;
        SensorSample sample;
        sample.resize(robot.model.nj);
        auto& sensors = rt.subscribe(msg::channels::kRobotSensors,
            [&](const humanoid::robot_sensors_t& m) { return msg::from_message(m, names, sample); });
        estimator::add_parameters(rt.parameters(), est.tunable_config());
        auto out = rt.advertise(msg::channels::kRobotState);
        humanoid::robot_state_t state_msg{};
        estimator::TickReport report;
        estimator::Estimator::Outputs estimate;
        rt.on_restart(sensors, [&] { est.reset(); });
        rt.on_tick(sensors, {}, 0.0, [&](const node::TickInfo&) {
          est.step({sample}, estimate);
          report(rt, est, estimate.report, sample.tick);
          msg::to_message(estimate.state, names, state_msg);
          out.publish(state_msg);
        });
        rt.while_silent(sensors, sensor_timeout, "sensors", [&] {
          EstimatedState s = est.state();
          s.status |= estimator::kStatusSensorStale;
          msg::to_message(s, names, state_msg);
          out.publish(state_msg);
        });
        return rt.run();
      });
}
