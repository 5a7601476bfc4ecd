// Per-tick compute of the composed controllers (what the `controllers` process does between
// receiving ROBOT_SENSORS k and publishing JOINT_COMMAND k, without LCM): the estimator, the
// planner, reference_gen, motion_opt and the wbc, with every channel between them through its
// message (encode and decode), on a closed-loop run with a 15 N s push from behind at t = 3 s. The
// components' own steps are timed apart, so the difference is what the composition costs.
//
//   bench_controllers [robot] [seconds]     prints median, p99 and max [us]
#include <chrono>
#include <cstdio>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/graph/closed_loop.hpp"

int main(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  const auto args = hpr::graph::read_bench_args(argc, argv, "bench_controllers");
  if (!args) return 2;
  hpr::graph::ClosedLoop loop(std::string(HPR_SOURCE_DIR) + "/config/" + args->robot + ".yaml", {},
                              {.cam = true, .estimator_in_loop = true});
  loop.push_base(15.0, 65.0, Eigen::Vector3d::UnitX(), 3.0);
  const auto ticks = static_cast<long>(args->seconds / loop.sim.config().dt);
  std::vector<double> tick_us, components_us;
  tick_us.reserve(static_cast<size_t>(ticks));
  components_us.reserve(static_cast<size_t>(ticks));
  const auto us = [](Clock::duration d) { return std::chrono::duration<double, std::micro>(d).count(); };
  // Tick k: the estimate of sample k (decoded as the process decodes ROBOT_SENSORS), then control.
  double estimate_us = loop.times().estimator_us;  // sample 0, estimated when the loop was built
  for (long k = 0; k < ticks && !loop.sim.truth().fallen; ++k) {
    const auto t0 = Clock::now();
    loop.control();
    const auto t1 = Clock::now();
    const hpr::graph::StepTimes& t = loop.times();
    tick_us.push_back(estimate_us + us(t1 - t0));
    components_us.push_back(t.estimator_us + t.planner_us + t.reference_gen_us + t.motion_opt_us + t.wbc_us);
    hpr::sim::Simulator::Outputs plant;
    loop.sim.step({&loop.wbc_out().command}, plant);
    const hpr::SensorSample& sample = loop.sensors_as_received();
    const auto t2 = Clock::now();
    loop.estimate(sample);
    estimate_us = us(Clock::now() - t2);
  }
  std::printf("composed controllers (%s, %zu ticks, a 15 N s push at t = 3 s, fallen %d):\n", args->robot.c_str(), tick_us.size(),
              loop.sim.truth().fallen ? 1 : 0);
  std::printf("  whole tick (ROBOT_SENSORS decoded -> JOINT_COMMAND encoded): median %.1f us, p99 %.1f us, max %.1f us\n",
              hpr::percentile(tick_us, 0.5), hpr::percentile(tick_us, 0.99), hpr::percentile(tick_us, 1.0));
  std::printf("  the five components' steps alone: median %.1f us, p99 %.1f us, max %.1f us\n", hpr::percentile(components_us, 0.5),
              hpr::percentile(components_us, 0.99), hpr::percentile(components_us, 1.0));
  return 0;
}
