// Per-tick compute of the balance planner for a robot on closed-loop runs: holding the posture
// through a 15 N s push (the robot's configuration), and stepping out of a 55 N s push (with
// config/overlays/<robot>_stepping.yaml, where the robot has one: the force observer, the
// capture point, the step decision, the swing and the kinematics at lift-off).
//
//   bench_planner [robot] [seconds]    prints median, p99 and max of the planner step [us]
#include <cstdio>
#include <filesystem>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/experiments/trial.hpp"
#include "hpr/graph/closed_loop.hpp"

namespace {

void measure(const std::string& robot, double seconds, const char* what, double impulse, const std::vector<std::string>& overrides) {
  hpr::graph::ClosedLoop loop(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml", overrides);
  loop.push_base(impulse, 65.0, Eigen::Vector3d::UnitX(), 3.0);
  std::vector<double> us;
  loop.run(seconds, [&] { us.push_back(loop.times().planner_us); });
  std::printf("planner step, %s (%s, %zu ticks, a %.0f N s push at t = 3 s, steps %d, fallen %d): median %.2f us, p99 %.2f us, max %.1f us\n",
              what, robot.c_str(), us.size(), impulse, loop.plan().reference.stepping.steps_taken, loop.sim.truth().fallen ? 1 : 0,
              hpr::percentile(us, 0.5), hpr::percentile(us, 0.99), hpr::percentile(us, 1.0));
}

}  // namespace

int main(int argc, char** argv) {
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_planner");
  if (!args) return 2;
  measure(args->robot, args->seconds, "holding the posture", 15.0, {});
  const std::string overlay = std::string(HPR_SOURCE_DIR) + "/config/overlays/" + args->robot + "_stepping.yaml";
  if (std::filesystem::exists(overlay)) {
    measure(args->robot, args->seconds, "stepping", 55.0, hpr::experiments::overlay_overrides(overlay));
  }
  return 0;
}
