// One 1 ms physics step of each robot standing on the ground, with sensors and ground truth.
//
//   bench_sim [--benchmark_filter=REGEX] [--benchmark_repetitions=N]
//
// SimStep/ROBOT                  the simulator's step (drive torques, Bullet step, contact forces,
//                                sensors, truth) with the configuration's collisions (the feet)
// SimStep/g1/all_meshes/hullN    the G1 with every link's mesh colliding with the ground as a convex
//                                hull of at most N points (16, 64, 256)
// The counter realtime_factor is simulated seconds per wall second.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "hpr/sim/simulator.hpp"

namespace {

using namespace hpr;

struct Setup {
  explicit Setup(const std::string& robot, const std::vector<std::string>& overrides)
      : cfg(Config::load(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml", overrides)),
        spec(model::RobotSpec::load(cfg.section("robot"))),
        sim_config(sim::SimConfig::load(cfg.section("sim"))) {
    command.resize(spec.model.nj);
    command.mode = JointCommand::Mode::kRun;
    command.q_des = spec.q_joints_stand;
    sim::hold_gains(spec, spec.standing_configuration(), 1500, 30, sim_config.dt / sim_config.substeps, command.kp,
                    command.kd);
  }
  Config cfg;
  model::RobotSpec spec;
  sim::SimConfig sim_config;
  JointCommand command;
};

void sim_step(benchmark::State& st, const std::string& robot, const std::vector<std::string>& overrides) {
  const Setup s(robot, overrides);
  sim::Simulator sim(s.spec, s.sim_config);
  for (auto _ : st) {
    sim.set_command(s.command);
    sim.step();
    benchmark::DoNotOptimize(sim.sensors().q.data());
  }
  st.counters["realtime_factor"] = benchmark::Counter(static_cast<double>(st.iterations()) * s.sim_config.dt,
                                                      benchmark::Counter::kIsRate);
  st.counters["joints"] = static_cast<double>(sim.simulated_model().nj);
}

}  // namespace

int main(int argc, char** argv) {
  for (const char* robot : {"toro", "h1_2", "g1"}) {
    benchmark::RegisterBenchmark((std::string("SimStep/") + robot).c_str(), sim_step, robot, std::vector<std::string>{})
        ->Unit(benchmark::kMicrosecond)
        ->MinTime(2.0);
  }
  for (int points : {16, 64, 256}) {
    benchmark::RegisterBenchmark(("SimStep/g1/all_meshes/hull" + std::to_string(points)).c_str(), sim_step, "g1",
                                 std::vector<std::string>{"sim.collisions=all",
                                                          "robot.mesh_hull_points=" + std::to_string(points)})
        ->Unit(benchmark::kMicrosecond)
        ->MinTime(2.0);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
