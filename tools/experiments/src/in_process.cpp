// A push trial through the in-process pipeline: the same plan (configuration, overrides, push) as
// run_trial, the same evaluation from the same messages, the stack's libraries stepping in one
// thread instead of processes over LCM.
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "hpr/experiments/trial.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/pipeline/closed_loop.hpp"
#include "hpr/msg/sim_truth.hpp"

namespace hpr::experiments {

TrialResult run_trial_in_process(const TrialSpec& spec, const std::function<void(const std::string&)>& progress) {
  if (!spec.log_file.empty()) throw std::invalid_argument("an in-process trial writes no log: run it through the processes (run_trial)");
  const auto wall0 = std::chrono::steady_clock::now();
  const TrialPlan plan = plan_trial(spec);
  pipeline::ClosedLoopOptions options;
  options.cam = spec.strategy == Strategy::kCam;
  // The controllers see the estimator's state, or (truth_state) the simulator's truth.
  options.estimator_in_loop = !spec.truth_state;
  pipeline::ClosedLoop loop(plan.config, plan.overrides, options);
  loop.sim.add_push(plan.push);
  const double t_push = plan.push.start, t_end = t_push + plan.push.duration;
  TrialEvaluator eval(loop.spec, spec.support, t_push, t_end);
  eval.allow_steps(steps_enabled(spec.overrides));

  // The messages the evaluator reads, as sim_bullet and motion_opt would publish them.
  msg::RobotNames names;
  names.joints = loop.spec.model.joint_name;
  humanoid::sim_truth_t truth{};
  humanoid::robot_sensors_t sensors{};
  humanoid::wholebody_command_t wholebody{};
  const auto observe_plant = [&] {  // in sim_bullet's order: ROBOT_SENSORS, then SIM_TRUTH
    msg::to_message(loop.sim.sensors(), names, sensors);
    eval.on_sensors(sensors);
    msg::to_message(loop.sim.truth(), names.feet, truth);
    eval.on_truth(truth);
  };
  TrialWatch watch(spec, eval, t_push, t_end, progress, wall0);
  // As sim_bullet in lockstep: the plant's messages of every tick before the end, each answered.
  while (loop.sim.time() < plan.sim_duration) {
    observe_plant();
    if (watch.stop()) break;
    const double t = loop.sim.time();
    loop.step();
    if (loop.have_wholebody) {
      // The evaluator reads the commanded CAM of WHOLEBODY_COMMAND (stamped with the state's time).
      wholebody.utime = static_cast<std::int64_t>(std::llround(t * 1e6));
      const Eigen::Vector3d& l_cmd = loop.wholebody.l_cmd;
      for (int k = 0; k < 3; ++k) wholebody.l_cmd_W[k] = l_cmd(k);
      eval.on_wholebody(wholebody);
    }
  }
  return watch.result();
}

}  // namespace hpr::experiments
