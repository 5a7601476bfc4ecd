// Per-tick compute of the whole-body controller for a robot: model update, impedances,
// feedforward, contact wrench QP (hot-started), torques and the virtual stance foot, on a closed-loop
// run (the state comes from the simulator, so the QP sees realistic tick-to-tick changes, including
// a 15 N s push at t = 3 s that saturates the CoP).
//
//   bench_wbc [robot] [seconds]        prints median, p99 and max of the controller step [us]
#include <cstdio>
#include <vector>

#include "hpr/graph/closed_loop.hpp"
#include "hpr/common/stats.hpp"

int main(int argc, char** argv) {
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_wbc");
  if (!args) return 2;
  const std::string& robot = args->robot;
  const double seconds = args->seconds;
  hpr::graph::ClosedLoop loop(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml");
  loop.push_base(15.0, 65.0, Eigen::Vector3d::UnitX(), 3.0);
  std::vector<double> us;
  loop.run(seconds, [&] { us.push_back(loop.times().wbc_us); });
  std::printf("wbc step (%s, %zu ticks, a 15 N s push at t = 3 s, fallen %d): median %.1f us, p99 %.1f us, max %.1f us\n",
              robot.c_str(), us.size(), loop.sim.truth().fallen ? 1 : 0, hpr::percentile(us, 0.5), hpr::percentile(us, 0.99),
              hpr::percentile(us, 1.0));
  return 0;
}
