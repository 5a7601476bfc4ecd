// Rigid-body algorithms per call, for both robots (the robot name is the benchmark's label).
//
//   bench_model [--benchmark_repetitions=N ...]     (run from the build tree; reads config/*.yaml)
//
// BM_ModelUpdate is everything the whole-body controller needs per tick: kinematics with frame
// placements, M (CRBA), C v + g, A_G with Ȧ_G v and the CoM, both foot Jacobians, the LU of the legs'
// block of J (2) with its condition estimate, J⁻¹ and Ā = A J⁻¹.
#include <benchmark/benchmark.h>

#include <random>

#include "hpr/common/config.hpp"
#include "hpr/model/centroidal.hpp"

namespace {

using namespace hpr::model;

struct Fixture {
  explicit Fixture(const std::string& name, const std::vector<std::string>& overrides = {})
      : robot(RobotSpec::load(hpr::Config::load(std::string(HPR_SOURCE_DIR) + "/config/" + name + ".yaml", overrides)
                                  .section("robot"))),
        data(robot.model),
        task(robot) {
    std::mt19937 gen(7);
    std::uniform_real_distribution<double> d(-0.1, 0.1);
    q = robot.standing_configuration();
    Eigen::VectorXd dq(robot.model.nv), v0(robot.model.nv);
    for (int k = 0; k < robot.model.nv; ++k) {
      dq(k) = d(gen);
      v0(k) = 5 * d(gen);
    }
    q = integrate(robot.model, q, dq);
    v = v0;
    a = 3 * v0;
  }
  RobotSpec robot;
  Data data;
  TaskSpace task;
  Eigen::VectorXd q, v, a;
};

/// toro, h1_2, and the G1 with every joint of its URDF in the model (g1_hands: 43 joints and its
/// hands, 49 DoF with the floating base; larger than the 38-DoF TALOS of the usual comparisons).
Fixture& fixture(const std::string& name) {
  static Fixture toro("toro"), h1("h1_2");
  if (name == "g1_hands") {
    static Fixture g1("g1", {"robot.held_joints={}"});
    return g1;
  }
  return name == "toro" ? toro : h1;
}

void BM_ForwardKinematics(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) {
    forward_kinematics(f.robot.model, f.data, f.q);
    benchmark::DoNotOptimize(f.data.oMi.data());
  }
  st.SetLabel(name);
}

void BM_Crba(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) benchmark::DoNotOptimize(crba(f.robot.model, f.data, f.q).data());
  st.SetLabel(name + " (nv " + std::to_string(f.robot.model.nv) + ")");
}

void BM_NonlinearEffects(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) benchmark::DoNotOptimize(nonlinear_effects(f.robot.model, f.data, f.q, f.v).data());
  st.SetLabel(name);
}

void BM_Rnea(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) benchmark::DoNotOptimize(rnea(f.robot.model, f.data, f.q, f.v, f.a).data());
  st.SetLabel(name);
}

void BM_CentroidalMap(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) benchmark::DoNotOptimize(ccrba(f.robot.model, f.data, f.q, f.v).data());
  st.SetLabel(name);
}

// Both feet's Jacobians from q, each with the placements of its leg only (Pinocchio's
// computeFrameJacobian, twice).
void BM_FootJacobians(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  const Model& m = f.robot.model;
  for (auto _ : st) {
    for (int k = 0; k < 2; ++k) {
      compute_frame_jacobian(m, f.data, f.q, f.robot.feet[static_cast<size_t>(k)].sole_frame,
                             ReferenceFrame::kLocalWorldAligned, f.data.J);
      benchmark::DoNotOptimize(f.data.J.data());
    }
  }
  st.SetLabel(name);
}

// The whole tree's kinematics (with the world inertias the dynamics need), then both feet's
// Jacobians from it.
void BM_KinematicsAndFootJacobians(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  const Model& m = f.robot.model;
  for (auto _ : st) {
    forward_kinematics(m, f.data, f.q);
    for (int k = 0; k < 2; ++k) {
      frame_jacobian(m, f.data, f.robot.feet[static_cast<size_t>(k)].sole_frame, ReferenceFrame::kLocalWorldAligned,
                     f.data.J);
      benchmark::DoNotOptimize(f.data.J.data());
    }
  }
  st.SetLabel(name);
}

void BM_CentroidalInverseDynamics(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) {
    benchmark::DoNotOptimize(centroidal_inverse_dynamics(f.robot.model, f.data, f.q, f.v, f.v, f.a).data());
  }
  st.SetLabel(name);
}

void BM_ModelUpdate(benchmark::State& st, const std::string& name) {
  Fixture& f = fixture(name);
  for (auto _ : st) {
    compute_all_terms(f.robot.model, f.data, f.q, f.v);
    f.task.update(f.robot.model, f.data);
    benchmark::DoNotOptimize(f.task.Abar().data());
  }
  st.SetLabel(name);
}

}  // namespace

BENCHMARK_CAPTURE(BM_ForwardKinematics, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_ForwardKinematics, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_Crba, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_Crba, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_NonlinearEffects, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_NonlinearEffects, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_Rnea, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_Rnea, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_CentroidalMap, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_CentroidalMap, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_FootJacobians, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_FootJacobians, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_KinematicsAndFootJacobians, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_KinematicsAndFootJacobians, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_Crba, g1_hands, std::string("g1_hands"));
BENCHMARK_CAPTURE(BM_CentroidalMap, g1_hands, std::string("g1_hands"));
BENCHMARK_CAPTURE(BM_FootJacobians, g1_hands, std::string("g1_hands"));
BENCHMARK_CAPTURE(BM_CentroidalInverseDynamics, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_CentroidalInverseDynamics, h1_2, std::string("h1_2"));
BENCHMARK_CAPTURE(BM_ModelUpdate, toro, std::string("toro"));
BENCHMARK_CAPTURE(BM_ModelUpdate, h1_2, std::string("h1_2"));
BENCHMARK_MAIN();
