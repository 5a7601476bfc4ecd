#pragma once
// In-process closed loop: the Bullet simulator and the controllers' components stepping in one
// process, without LCM, for closed-loop tests, the per-component benchmarks and in-process push
// trials. The data flow per tick is the stack's: sensors → estimator → (reference_gen with the
// previous tick's balance status → motion_opt) → wbc → joint command → simulator, through the same
// components the nodes run (estimator::Estimator, reference_gen::ReferenceGenerator,
// motion_opt::MotionOptComponent, wbc::WbcComponent). With the estimator in the loop, every channel
// between the components passes through its hpr::msg conversion (ROBOT_SENSORS, ROBOT_STATE,
// BALANCE_STATUS, CAM_REFERENCE, WHOLEBODY_COMMAND; times in whole microseconds as the messages
// carry them), so the controllers compute what the processes compute from the same messages.
#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "hpr/balance/task_reference.hpp"
#include "hpr/common/config.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/graph/controllers.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/sim/simulator.hpp"

namespace hpr::graph {

struct ClosedLoopOptions {
  bool cam = false;                ///< reference_gen + motion_opt in the loop (else the ankle strategy)
  bool estimator_in_loop = false;  ///< the controllers see the estimator's state (else the simulator's truth)
  bool run_estimator = false;      ///< run the estimator alongside even when it is not in the loop
};

/// The configuration, the robot and its simulation (the first base of ClosedLoop, so that they
/// exist before the controllers are built from them).
struct SimulatedRobot {
  SimulatedRobot(const std::string& config_file, const std::vector<std::string>& overrides);
  Config cfg;
  model::RobotSpec spec;
  sim::Simulator sim;
};

/// The simulated robot and its controllers, stepped one control period at a time. The members are
/// public: a test reads the simulator's truth, the estimator's state or the wbc's status directly.
struct ClosedLoop : SimulatedRobot, Controllers {
  /// `config_file`: a robot configuration (config/<robot>.yaml) with `overrides` ("key.path=value").
  explicit ClosedLoop(const std::string& config_file, const std::vector<std::string>& overrides = {},
                      ClosedLoopOptions loop_options = {});

  /// One control period.
  void step();
  /// Runs for `seconds`, calling `each` after every step; stops early when the robot fell.
  void run(double seconds, const std::function<void()>& each = {});
  /// Pushes the base link with a half-sine of peak force `peak` [N] along `direction` for
  /// `impulse` [N s] (duration T = π I / (2 F)), starting at simulated time `start` [s].
  void push_base(double impulse, double peak, const Eigen::Vector3d& direction, double start);

  /// The estimator's input: the simulator's sensors as the estimator node decodes ROBOT_SENSORS.
  const SensorSample& sensors_as_received();

  ClosedLoopOptions opt;

 private:

  humanoid::robot_sensors_t sensors_msg_{};
  SensorSample sample_;
  EstimatedState truth_;  ///< the simulator's truth as a state (estimator not in the loop)
};

/// The command line of the per-component benchmarks that run this loop: `NAME [robot] [seconds]`
/// (defaults toro, 10 s).
struct BenchArgs {
  std::string robot = "toro";
  double seconds = 10.0;
};
/// Reads argv; on bad use prints why (prefixed by `name`) and returns nothing.
std::optional<BenchArgs> read_bench_args(int argc, char** argv, const char* name);

}  // namespace hpr::graph
