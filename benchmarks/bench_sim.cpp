// One 1 ms physics step of each robot standing on the ground, with sensors and ground truth.
//
//   bench_sim [--benchmark_filter=REGEX] [--benchmark_repetitions=N]
//
// SimStep/ROBOT                  the simulator's step (drive torques, Bullet step, contact forces,
//                                sensors, truth) with the configuration's collisions (the feet)
// SimStep/g1/all_meshes/hullN    the G1 with every link's mesh colliding with the ground as a convex
//                                hull of at most N points (16, 64, 256)
// .../single_point               the same with sim.ground.multipoint off: Bullet's one new contact
//                                point per step, no perturbed queries of polyhedral shapes
// SimStep/ROBOT/no_limits        without the joint-limit constraints (sim.joint_limits off)
// SimStep/g1/held_impedance      the G1's 14 held finger joints simulated, held by joint impedance,
//                                instead of welded (sim.held_joints.rigid off)
// SimStep/ROBOT/mujoco           the same step in MuJoCo (sim.engine: mujoco), the configuration's
//                                physics step; .../substepsN and .../iterationsN the same at N
//                                physics steps per 1 ms or N solver iterations (either engine)
// The counter realtime_factor is simulated seconds per wall second; for the hull variants,
// hull_gap_max_mm and hull_gap_mean_mm say how far inside the exact convex hull of each collision
// mesh the simplified hull lies at worst (over 2000 directions), the largest and the mean over the
// meshes. The contact counters say what the step computes standing, for the convergence of the
// contact forces: fz_over_weight (both soles' normal force over the weight) and cop_x_mm, cop_y_mm
// (the right sole's centre of pressure in the world, relative to its sole frame's origin).
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "hpr/mesh/mesh.hpp"
#include "hpr/sim/engines.hpp"
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

// The simplified hulls' worst gap to the exact ones over every collision mesh [m]: (max, mean).
std::pair<double, double> hull_gaps(const model::RobotSpec& spec) {
  double worst = 0.0, sum = 0.0;
  int n = 0;
  for (const auto& link : spec.description.links) {
    for (const auto& g : link.collisions) {
      if (g.type != model::Geometry::Type::kMesh) continue;
      const auto points = mesh::load(g.mesh, g.mesh_scale).vertices;
      const double gap = mesh::hull_gap(points, mesh::hull_points(points, spec.mesh_hull_points));
      worst = std::max(worst, gap);
      sum += gap;
      ++n;
    }
  }
  return {worst, n > 0 ? sum / n : 0.0};
}

void sim_step(benchmark::State& st, const std::string& robot, const std::vector<std::string>& overrides) {
  const Setup s(robot, overrides);
  if (s.sim_config.feet_only_collisions == false) {
    const auto [worst, mean] = hull_gaps(s.spec);
    st.counters["hull_gap_max_mm"] = 1e3 * worst;
    st.counters["hull_gap_mean_mm"] = 1e3 * mean;
  }
  sim::Simulator sim(s.spec, s.sim_config, sim::make_engine);
  for (auto _ : st) {
    sim.set_command(s.command);
    sim.step();
    benchmark::DoNotOptimize(sim.sensors().q.data());
  }
  st.counters["realtime_factor"] = benchmark::Counter(static_cast<double>(st.iterations()) * s.sim_config.dt,
                                                      benchmark::Counter::kIsRate);
  st.counters["joints"] = static_cast<double>(sim.simulated_model().nj);
  const auto& t = sim.truth();
  st.counters["fz_over_weight"] = (t.contact_wrench_W[0](2) + t.contact_wrench_W[1](2)) / (sim.simulated_model().mass * 9.81);
  const model::Vector6d& w = t.contact_wrench_W[0];  // about the sole frame's origin
  if (w(2) > 1.0) {
    st.counters["cop_x_mm"] = -1e3 * w(4) / w(2);
    st.counters["cop_y_mm"] = 1e3 * w(3) / w(2);
  }
}

}  // namespace

int main(int argc, char** argv) {
  for (const char* robot : {"toro", "h1_2", "g1"}) {
    benchmark::RegisterBenchmark((std::string("SimStep/") + robot).c_str(), sim_step, robot, std::vector<std::string>{})
        ->Unit(benchmark::kMicrosecond)
        ->MinTime(2.0);
    benchmark::RegisterBenchmark((std::string("SimStep/") + robot + "/single_point").c_str(), sim_step, robot,
                                 std::vector<std::string>{"sim.ground.multipoint=false"})
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
  for (const char* robot : {"toro", "g1"}) {
    benchmark::RegisterBenchmark((std::string("SimStep/") + robot + "/no_limits").c_str(), sim_step, robot,
                                 std::vector<std::string>{"sim.joint_limits=false"})
        ->Unit(benchmark::kMicrosecond)
        ->MinTime(2.0);
  }
  benchmark::RegisterBenchmark("SimStep/g1/held_impedance", sim_step, "g1", std::vector<std::string>{"sim.held_joints.rigid=false"})
      ->Unit(benchmark::kMicrosecond)
      ->MinTime(2.0);
  benchmark::RegisterBenchmark("SimStep/g1/all_meshes/hull64/single_point", sim_step, "g1",
                               std::vector<std::string>{"sim.collisions=all", "robot.mesh_hull_points=64", "sim.ground.multipoint=false"})
      ->Unit(benchmark::kMicrosecond)
      ->MinTime(2.0);
  for (const char* robot : {"toro", "h1_2", "g1"}) {
    benchmark::RegisterBenchmark((std::string("SimStep/") + robot + "/mujoco").c_str(), sim_step, robot, std::vector<std::string>{"sim.engine=mujoco"})
        ->Unit(benchmark::kMicrosecond)
        ->MinTime(2.0);
  }
  // Convergence: the TORO-like robot at other physics steps and solver iterations, in each engine.
  for (const char* engine : {"bullet", "mujoco"}) {
    for (const char* variant : {"substeps=1", "substeps=4", "substeps=8", "solver_iterations=5", "solver_iterations=50"}) {
      std::string name = std::string(variant);
      name.erase(name.find('='), 1);
      benchmark::RegisterBenchmark((std::string("SimStep/toro/") + engine + "/" + name).c_str(), sim_step, "toro",
                                   std::vector<std::string>{std::string("sim.engine=") + engine, std::string("sim.") + variant})
          ->Unit(benchmark::kMicrosecond)
          ->MinTime(1.0);
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
