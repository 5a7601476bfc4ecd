// Per-tick compute of the balance planner for a robot (the posture, the support, and with the
// configuration's balance.stepping and balance.push_compensation the force observer, the capture
// point and the steps), on a closed-loop run with a 15 N s push at t = 3 s.
//
//   bench_planner [robot] [seconds]    prints median, p99 and max of the planner step [us]
#include <cstdio>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/graph/closed_loop.hpp"

int main(int argc, char** argv) {
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_planner");
  if (!args) return 2;
  const std::string& robot = args->robot;
  hpr::graph::ClosedLoop loop(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml");
  loop.push_base(15.0, 65.0, Eigen::Vector3d::UnitX(), 3.0);
  std::vector<double> us;
  loop.run(args->seconds, [&] { us.push_back(loop.times().planner_us); });
  std::printf("planner step (%s, %zu ticks, a 15 N s push at t = 3 s, fallen %d): median %.2f us, p99 %.2f us, max %.1f us\n",
              robot.c_str(), us.size(), loop.sim.truth().fallen ? 1 : 0, hpr::percentile(us, 0.5), hpr::percentile(us, 0.99),
              hpr::percentile(us, 1.0));
  return 0;
}
