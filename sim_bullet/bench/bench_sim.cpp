// One 1 ms physics step of the TORO-like robot standing on the ground, with sensors and ground truth.
//
//   bench_sim [--benchmark_repetitions=N]
//
// BM_SimStep         the simulator's step (drive torques, Bullet step, contact forces, sensors, truth)
// The counter realtime_factor is simulated seconds per wall second.
#include <benchmark/benchmark.h>

#include "hpr/model/urdf.hpp"
#include "hpr/sim/simulator.hpp"

namespace {

using namespace hpr;

struct Setup {
  Setup()
      : cfg(Config::load(std::string(HPR_SOURCE_DIR) + "/config/toro.yaml")),
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

void BM_SimStep(benchmark::State& st) {
  static Setup s;
  sim::Simulator sim(s.spec, s.sim_config);
  for (auto _ : st) {
    sim.set_command(s.command);
    sim.step();
    benchmark::DoNotOptimize(sim.sensors().q.data());
  }
  st.counters["realtime_factor"] = benchmark::Counter(static_cast<double>(st.iterations()) * s.sim_config.dt,
                                                      benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK(BM_SimStep)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK_MAIN();
