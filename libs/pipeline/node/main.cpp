// controllers: the estimator, reference_gen, motion_opt and wbc composed in one process.
//
// Steps on every ROBOT_SENSORS (tick k) through hpr::pipeline::Controllers, the same components and
// conversions the four processes run, and publishes every channel they publish: JOINT_COMMAND of
// tick k first (the robot waits for it), then ROBOT_STATE, CAM_REFERENCE, WHOLEBODY_COMMAND and
// BALANCE_STATUS of tick k. lcm-spy, recording and replay see the same messages as from the four
// processes, with the same contents.
// When the samples stop for longer than `estimator.sensor_timeout`, the last state goes on flagged
// stale at that period, and the wbc damps after `wbc.bad_state_ticks` of them, as with the processes.
#include <humanoid/operator_t.hpp>
#include <humanoid/robot_sensors_t.hpp>

#include "hpr/common/log.hpp"
#include "hpr/common/time.hpp"
#include "hpr/msg/commands.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"
#include "hpr/pipeline/controllers.hpp"

namespace {

using namespace hpr;

/// HEALTH faults of the tick, as the four processes would report them.
void report(node::Runtime& rt, const pipeline::Controllers& c, const EstimatedState& state) {
  using Mode = wbc::WbcComponent::Mode;
  const std::string& implausible = c.estimator->implausible_reason();
  if (implausible.empty()) {
    rt.clear_fault("implausible");
  } else {
    rt.set_fault("implausible", implausible);
  }
  switch (c.wbc_out.mode) {
    case Mode::kBalance:
      rt.clear_fault("damping");
      break;
    case Mode::kDampNoState:
      rt.report(node::StepOutcome::kNotReady);
      rt.set_fault("damping", "no usable ROBOT_STATE yet (status " + std::to_string(state.status) + ")");
      break;
    case Mode::kDampOperator:
      rt.report(node::StepOutcome::kDamping);
      rt.set_fault("damping", "operator damp");
      break;
    case Mode::kDampBadState:
      rt.report(node::StepOutcome::kDamping);
      rt.set_fault("damping", "ROBOT_STATE flagged (status " + std::to_string(state.status) + ") for " +
                                  std::to_string(c.wbc.bad_state_count()) + " ticks");
      break;
  }
  if (c.have_wholebody && c.wholebody.qp_failed) {
    rt.set_fault("motion_qp", "motion QP failed: posture task within the limits");
  } else {
    rt.clear_fault("motion_qp");
  }
  if (c.wbc_out.mode == Mode::kBalance && c.wbc_out.status.qp_fallback) {
    rt.set_fault("contact_qp", "contact QP failed: last valid wrenches kept");
  } else {
    rt.clear_fault("contact_qp");
  }
}

/// The options of the four processes that concern their exchange over LCM (waits, timeouts,
/// staleness): composed, every input of a tick is there when it steps, so they do not apply; they
/// are still validated, with the processes' ranges, so that one configuration serves both.
void check_exchange_options(const Config& cfg) {
  const Config rg = cfg.section("reference_gen"), mo = cfg.section("motion_opt"), wb = cfg.section("wbc");
  (void)rg.boolean_or("wait_for_balance", true);
  (void)rg.real_or("balance_timeout", 0.5, 0.0, 60.0);
  (void)mo.boolean_or("wait_for_reference", true);
  (void)mo.real_or("reference_timeout", 0.5, 0.0, 60.0);
  (void)mo.integer_or("reference_stale_ticks", 20, 1, 100000);
  if (wb.choice_or("state_source", "estimator", {"estimator", "sim_truth"}) != "estimator") {
    wb.fail("state_source", "the composed controllers run their own estimator (sim_truth needs the wbc process)");
  }
  (void)wb.real_or("wholebody_timeout", 0.5, 0.0, 60.0);
  (void)wb.integer_or("wholebody_stale_ticks", 50, 1, 100000);
  (void)wb.real_or("state_timeout", 0.05, 0.0, 60.0);
}

}  // namespace

int main(int argc, char** argv) {
  return node::run_main(
      argc, argv, "controllers", "estimator, reference_gen, motion_opt and wbc in one process",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        check_exchange_options(cfg);
        // wbc.wait_for_wholebody false: the wbc holds its own posture (the ankle strategy, as the
        // wbc process without motion_opt).
        const bool cam = cfg.section("wbc").boolean_or("wait_for_wholebody", true);
        pipeline::Controllers c(cfg, robot, {.cam = cam, .estimator = true, .messages = true});
        const double sensor_timeout = cfg.section("estimator").real_or("sensor_timeout", 0.02, 1e-3, 60.0);
        node::Runtime rt(cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
        SensorSample sample;
        sample.resize(robot.model.nj);
        auto& sensors = rt.subscribe<humanoid::robot_sensors_t>(
            "ROBOT_SENSORS", [&](const humanoid::robot_sensors_t& m) { return msg::from_message(m, c.names(), sample); });
        rt.subscribe<humanoid::operator_t>("OPERATOR", msg::check_operator, [&](const humanoid::operator_t& m) {
          if (m.command == humanoid::operator_t::COMMAND_DAMP || m.command == humanoid::operator_t::COMMAND_STOP) {
            if (!c.wbc.damping()) log::warn("OPERATOR {} from {}: damping ({})", m.command == humanoid::operator_t::COMMAND_STOP ? "stop" : "damp", m.source, m.reason);
            c.wbc.set_damping(true);
          } else if (m.command == humanoid::operator_t::COMMAND_ENABLE) {
            if (c.wbc.damping()) log::info("OPERATOR enable from {}", m.source);
            c.wbc.set_damping(false);
          } else if (m.command == humanoid::operator_t::COMMAND_SET_SUPPORT && m.support >= 0 && m.support <= 2) {
            c.request_support(static_cast<balance::Support>(m.support), c.state().time);
          }
        });
        auto state_out = rt.advertise<humanoid::robot_state_t>("ROBOT_STATE");
        auto cam_out = rt.advertise<humanoid::cam_reference_t>("CAM_REFERENCE");
        auto wholebody_out = rt.advertise<humanoid::wholebody_command_t>("WHOLEBODY_COMMAND");
        auto command_out = rt.advertise<humanoid::joint_command_t>("JOINT_COMMAND");
        auto balance_out = rt.advertise<humanoid::balance_status_t>("BALANCE_STATUS");
        // The joint command first (the drives wait for it), then what the four processes publish
        // on the way to it, in their order.
        auto publish = [&] {
          command_out.publish(c.command_msg);
          state_out.publish(c.state_msg);
          if (c.options.cam) cam_out.publish(c.cam_msg);
          if (c.have_wholebody) wholebody_out.publish(c.wholebody_msg);
          if (c.wbc_out.mode == wbc::WbcComponent::Mode::kBalance) balance_out.publish(c.balance_msg);
        };
        bool stale = false;
        rt.on_restart(sensors, [&] { c.reset(); });
        rt.on_tick(sensors, {}, 0.0, [&](const node::TickInfo&) {
          if (stale) {
            log::info("ROBOT_SENSORS back at tick {}", sample.tick);
            stale = false;
            rt.clear_fault("sensors");
          }
          c.estimate(sample);
          c.control();
          publish();
          report(rt, c, c.state());
        });
        rt.every(sensor_timeout, [&] {
          if (!sensors.has_value()) return;
          const double age = monotonic_s() - sensors.receive_time();
          if (age <= sensor_timeout) return;
          if (!stale) log::warn("ROBOT_SENSORS stale since tick {}", sensors.tick());
          stale = true;
          rt.set_fault("sensors", fmt::format("no ROBOT_SENSORS for {:.0f} ms", age * 1e3));
          c.control(EstimatedState::kSensorStale);
          publish();
          report(rt, c, c.state());
        });
        return rt.run();
      });
}
