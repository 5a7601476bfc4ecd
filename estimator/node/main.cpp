// estimator: floating-base state, CoM and measured CAM from the robot's sensors.
//
// Steps on every ROBOT_SENSORS sample and publishes ROBOT_STATE for the same tick. When the samples
// stop for longer than `estimator.sensor_timeout` (wall clock), it republishes the last state
// flagged STATUS_SENSOR_STALE at that period and reports the dropout in HEALTH: a dropout is never
// silently held.
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

namespace {

/// The contact hysteresis (on above off, as on load) and the CoP edge margin.
void add_parameters(hpr::node::ParameterSet& params, hpr::estimator::EstimatorConfig& c) {
  params.add({"contact_on", "N", 0.0, 1e4, [&c] { return c.contact_on; },
              [&c](double v) {
                if (v < c.contact_off) return fmt::format("below contact_off ({} N)", c.contact_off);
                c.contact_on = v;
                return std::string();
              }});
  params.add({"contact_off", "N", 0.0, 1e4, [&c] { return c.contact_off; },
              [&c](double v) {
                if (v > c.contact_on) return fmt::format("above contact_on ({} N)", c.contact_on);
                c.contact_off = v;
                return std::string();
              }});
  params.add("cop_edge_margin", c.cop_edge_margin, 0.0, 0.5, "m");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "estimator", "floating-base state estimator",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        const Config section = cfg.section("estimator");
        estimator::Estimator est(robot, estimator::EstimatorConfig::load(section));
        const double sensor_timeout = section.real_or("sensor_timeout", 0.02, 1e-3, 60.0);
        node::Runtime rt(cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
        msg::RobotNames names;
        names.joints = robot.model.joint_name;
        SensorSample sample;
        sample.resize(robot.model.nj);
        auto& sensors = rt.subscribe<humanoid::robot_sensors_t>(
            "ROBOT_SENSORS", [&](const humanoid::robot_sensors_t& m) { return msg::from_message(m, names, sample); });
        add_parameters(rt.parameters(), est.tunable_config());
        auto out = rt.advertise<humanoid::robot_state_t>("ROBOT_STATE");
        humanoid::robot_state_t state_msg{};
        bool stale = false;
        std::string last_kind;  // what a refusal is about (text before ':'), for the log
        double last_warn = -1e9;
        int unlogged = 0;
        rt.on_restart(sensors, [&] { est.reset(); });
        rt.on_tick(sensors, {}, 0.0, [&](const node::TickInfo&) {
          const EstimatedState& s = est.update(sample);
          if (stale) {
            log::info("ROBOT_SENSORS back at tick {}", sample.tick);
            stale = false;
            rt.clear_fault("sensors");
          }
          const std::string& reason = est.implausible_reason();
          const std::string kind = reason.substr(0, reason.find(':'));
          if (!reason.empty()) {
            // A new kind of refusal at once; the same kind at most once a second, with a count.
            const double now = monotonic_s();
            if (kind != last_kind || now - last_warn >= 1.0) {
              log::warn("sample {} refused: {}{}", sample.tick, reason,
                        unlogged > 0 ? fmt::format(" ({} more refused since the last message)", unlogged) : "");
              last_warn = now;
              unlogged = 0;
            } else {
              ++unlogged;
            }
            rt.set_fault("implausible", reason);
          } else {
            rt.clear_fault("implausible");
          }
          last_kind = kind;
          if ((s.status & estimator::kStatusCovariance) != 0) {
            rt.set_fault("covariance", fmt::format("position standard deviation {:.3f} m", est.position_std()));
          } else {
            rt.clear_fault("covariance");
          }
          if ((s.status & estimator::kStatusNoContact) != 0 && (s.status & estimator::kStatusInitialising) == 0) {
            rt.set_fault("contact", "no foot in contact");
          } else {
            rt.clear_fault("contact");
          }
          msg::to_message(s, names, state_msg);
          out.publish(state_msg);
          if ((s.status & estimator::kStatusInitialising) != 0) rt.report(node::StepOutcome::kNotReady);
        });
        rt.every(sensor_timeout, [&] {
          if (!sensors.has_value()) return;
          const double age = monotonic_s() - sensors.receive_time();
          if (age <= sensor_timeout) return;
          if (!stale) log::warn("ROBOT_SENSORS stale since tick {}", sensors.tick());
          stale = true;
          rt.set_fault("sensors", fmt::format("no ROBOT_SENSORS for {:.0f} ms", age * 1e3));
          EstimatedState s = est.state();
          s.status |= estimator::kStatusSensorStale;
          msg::to_message(s, names, state_msg);
          out.publish(state_msg);
        });
        return rt.run();
      });
}
