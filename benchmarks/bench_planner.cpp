// Per-tick compute of the balance planner for a robot on closed-loop runs: holding the posture
// through a 15 N s push (65 N peak), and stepping out of a 55 N s push (the force observer, the
// capture point, the step decision, the swing and the kinematics at lift-off): with the robot's
// configuration at a 130 N peak where it steps (at 65 N push compensation holds it standing),
// else with config/overlays/<robot>_stepping.yaml at 65 N where the robot has one.
//
//   bench_planner [robot] [seconds]    prints median, p99 and max of the planner step [us]
#include <cstdio>
#include <filesystem>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/experiments/trial.hpp"
#include "hpr/graph/closed_loop.hpp"

namespace {

std::string config_file(const std::string& robot) { return std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml"; }

void measure(const std::string& robot, double seconds, const char* what, double impulse, double peak,
             const std::vector<std::string>& overrides) {
  hpr::graph::ClosedLoop loop(config_file(robot), overrides);
  loop.push_base(impulse, peak, Eigen::Vector3d::UnitX(), 3.0);
  std::vector<double> us;
  loop.run(seconds, [&] { us.push_back(loop.times().planner_us); });
  std::printf("planner step, %s (%s, %zu ticks, a %.0f N s push of %.0f N peak at t = 3 s, steps %d, fallen %d): median %.2f us, p99 %.2f us, max %.1f us\n",
              what, robot.c_str(), us.size(), impulse, peak, loop.plan().reference.stepping.steps_taken, loop.sim.truth().fallen ? 1 : 0,
              hpr::percentile(us, 0.5), hpr::percentile(us, 0.99), hpr::percentile(us, 1.0));
}

}  // namespace

int main(int argc, char** argv) {
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_planner");
  if (!args) return 2;
  measure(args->robot, args->seconds, "holding the posture", 15.0, 65.0, {});
  const std::string overlay = std::string(HPR_SOURCE_DIR) + "/config/overlays/" + args->robot + "_stepping.yaml";
  hpr::experiments::TrialSpec configured;
  configured.config = config_file(args->robot);
  if (hpr::experiments::steps_enabled(configured)) {
    measure(args->robot, args->seconds, "stepping", 55.0, 130.0, {});
  } else if (std::filesystem::exists(overlay)) {
    measure(args->robot, args->seconds, "stepping", 55.0, 65.0, hpr::experiments::overlay_overrides(overlay));
  }
  return 0;
}
