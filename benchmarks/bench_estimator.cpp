// Per-sample compute of the estimator for a robot: joint filter, leg kinematics, contact, attitude
// and position filters, centroidal momentum and the momentum observer. The samples come from a
// closed-loop simulation with sensor noise on (the wbc on the simulator's truth), including a
// 15 N s push at t = 3 s.
//
//   bench_estimator [robot] [seconds]      prints median, p99 and max of Estimator::update [us]
#include <cstdio>
#include <vector>

#include "hpr/graph/closed_loop.hpp"
#include "hpr/common/stats.hpp"

int main(int argc, char** argv) {
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_estimator");
  if (!args) return 2;
  const std::string& robot = args->robot;
  const double seconds = args->seconds;
  hpr::graph::ClosedLoop loop(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml", {"sim.noise.enabled=true"},
                                    {.run_estimator = true});
  loop.push_base(15.0, 65.0, Eigen::Vector3d::UnitX(), 3.0);
  std::vector<double> us;
  loop.run(seconds, [&] { us.push_back(loop.times().estimator_us); });
  std::printf("estimator update (%s, %zu samples with sensor noise, a 15 N s push at t = 3 s, fallen %d): "
              "median %.1f us, p99 %.1f us, max %.1f us\n",
              robot.c_str(), us.size(), loop.sim.truth().fallen ? 1 : 0, hpr::percentile(us, 0.5), hpr::percentile(us, 0.99),
              hpr::percentile(us, 1.0));
  return 0;
}
