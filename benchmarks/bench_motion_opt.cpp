// Per-tick compute of the motion optimisation for a robot: Ā from the model (ccrba and the task
// Jacobian), the QP (13) hot-started, integration and the commanded CAM with its segment shares.
// The states come from a closed-loop simulation of the whole stack (reference generator, motion
// optimisation and wbc on the simulator's truth) with the paper's experiment-1 push (18 N s at
// t = 3 s), so the QP sees the working-set changes of a real recovery.
//
//   bench_motion_opt [robot] [seconds]    prints median, p99 and max of MotionOptimizer::step [us]
#include <algorithm>
#include <cstdio>
#include <vector>

#include "hpr/graph/closed_loop.hpp"
#include "hpr/common/stats.hpp"

int main(int argc, char** argv) {
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_motion_opt");
  if (!args) return 2;
  const std::string& robot = args->robot;
  const double seconds = args->seconds;
  hpr::graph::ClosedLoop loop(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml", {}, {.cam = true});
  loop.push_base(18.0, 65.0, Eigen::Vector3d::UnitX(), 3.0);
  std::vector<double> us;
  int max_changes = 0;
  loop.run(seconds, [&] {
    us.push_back(loop.times().motion_opt_us);
    max_changes = std::max(max_changes, loop.wholebody().qp_iterations);
  });
  std::printf("motion_opt step (%s, %zu ticks, 18 N s push at t = 3 s, fallen %d): median %.1f us, p99 %.1f us, max %.1f us; "
              "working-set changes per tick max %d\n",
              robot.c_str(), us.size(), loop.sim.truth().fallen ? 1 : 0, hpr::percentile(us, 0.5), hpr::percentile(us, 0.99),
              hpr::percentile(us, 1.0), max_changes);
  return 0;
}
