// truth_state: the simulator's true state on ROBOT_STATE, in the estimator's place.
//
// For simulated groups only (sim-truth-lockstep): a controller tested against the state a perfect
// estimator would give. Steps on every ROBOT_SENSORS sample (tick k) with the SIM_TRUTH of the same
// tick and publishes ROBOT_STATE(k): the root link's pose and twist, the CoM and the feet's contacts
// from SIM_TRUTH, the joints from ROBOT_SENSORS (msg::state_from_truth). A tick whose SIM_TRUTH does
// not come within 0.5 s (the simulator publishes both before it waits) publishes nothing: the wbc,
// without its state, damps.
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/sim_truth_t.hpp>

#include "hpr/common/robot_io.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/sim_truth.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/node/command_line.hpp"
#include "hpr/node/runtime.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  return node::run_main(
      argc, argv, "truth_state", "the simulator's true state as ROBOT_STATE (simulated groups only)",
      [](const node::CommandLine& cl, const Config& cfg) {
        const auto robot = model::RobotSpec::load(cfg.section("robot"));
        node::Runtime rt(estimator::kTruthStatePorts, cl.name, node::lcm_url(cl, cfg), node::runtime_options(cfg, 1e-3));
        msg::RobotNames names;
        names.joints = robot.model.joint_name;
        SensorSample sample;
        sample.resize(robot.model.nj);
        SimTruth truth;
        EstimatedState state;
        auto& sensors_in = rt.subscribe(msg::channels::kRobotSensors,
            [&](const humanoid::robot_sensors_t& m) { return msg::from_message(m, names, sample); });
        auto& truth_in =
            rt.subscribe(msg::channels::kSimTruth, [&](const humanoid::sim_truth_t& m) { return msg::from_message(m, truth); });
        auto out = rt.advertise(msg::channels::kRobotState);
        humanoid::robot_state_t state_msg{};
        const Read& r = estimator::kTruthStatePorts.at(channel::kSimTruth);
        constexpr double kTruthTimeout = 0.5;  // [s]
        rt.on_tick(sensors_in, {{&truth_in, r.tick_offset, {}, r.optional}}, kTruthTimeout, [&](const node::TickInfo& info) {
          if (truth_in.tick() != info.tick + r.tick_offset) {
            rt.set_fault("truth", "no SIM_TRUTH for this tick: no state published");
            rt.report(node::StepOutcome::kNotReady);
            return;
          }
          rt.clear_fault("truth");
          msg::state_from_truth(truth, sample, state);
          state.tick = info.tick;
          msg::to_message(state, names, state_msg);
          out.publish(state_msg);
        });
        return rt.run();
      });
}
