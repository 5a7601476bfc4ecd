#pragma once
// In-process closed loop: the Bullet simulator and the controllers' libraries stepping in one
// process, without LCM, for closed-loop tests, the per-component benchmarks and in-process push
// trials. The data flow per tick is the stack's: sensors → estimator → (reference_gen with the
// previous tick's balance status → motion_opt) → wbc → joint command → simulator. With the
// estimator in the loop, every channel between the components passes through the conversion its
// node applies (ROBOT_SENSORS, ROBOT_STATE, WHOLEBODY_COMMAND; times in whole microseconds as the
// messages carry them), so the controllers compute what the processes compute from the same
// messages. The processes themselves (the same libraries behind LCM nodes) are exercised by
// push_trial and the integration tests.
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
#include "hpr/motion_opt/optimizer.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/wbc/controller.hpp"

namespace hpr::pipeline {

struct ClosedLoopOptions {
  bool cam = false;                ///< reference_gen + motion_opt in the loop (else the ankle strategy)
  bool estimator_in_loop = false;  ///< the controllers see the estimator's state (else the simulator's truth)
  bool run_estimator = false;      ///< run the estimator alongside even when it is not in the loop
};

/// Compute time of each component in the last step [us] (0 for a component not in the loop).
struct StepTimes {
  double estimator_us = 0;
  double reference_gen_us = 0;
  double motion_opt_us = 0;
  double wbc_us = 0;
};

/// The simulated robot and its controllers, stepped one control period at a time. The members are
/// public: a test reads the simulator's truth, the estimator's state or the wbc's status directly.
struct ClosedLoop {
  /// `config_file`: a robot configuration (config/<robot>.yaml) with `overrides` ("key.path=value").
  explicit ClosedLoop(const std::string& config_file, const std::vector<std::string>& overrides = {},
                      ClosedLoopOptions options = {});

  /// One control period.
  void step();
  /// Runs for `seconds`, calling `each` after every step; stops early when the robot fell.
  void run(double seconds, const std::function<void()>& each = {});
  /// Pushes the base link with a half-sine of peak force `peak` [N] along `direction` for
  /// `impulse` [N s] (duration T = π I / (2 F)), starting at simulated time `start` [s].
  void push_base(double impulse, double peak, const Eigen::Vector3d& direction, double start);

  ClosedLoopOptions opt;
  Config cfg;
  model::RobotSpec spec;
  sim::Simulator sim;
  wbc::WholeBodyController wbc;
  balance::PostureReference reference;
  std::optional<estimator::Estimator> estimator;
  std::optional<reference_gen::ReferenceGenerator> generator;
  std::optional<motion_opt::MotionOptimizer> optimizer;
  reference_gen::BalanceInput balance;  ///< the wbc's status of the previous tick, as on BALANCE_STATUS
  bool have_balance = false;
  double posture_error = 0.0;
  int motion_opt_iterations = 0;  ///< working-set changes of the last motion_opt QP
  StepTimes times;

 private:
  /// The estimator's input: the simulator's sensors as the estimator node decodes ROBOT_SENSORS.
  const SensorSample& sensors_as_received();

  // The channels between the components, as the nodes exchange them.
  msg::RobotNames names_;
  std::vector<std::string> free_names_;
  humanoid::robot_sensors_t sensors_msg_{};
  humanoid::robot_state_t state_msg_{};
  humanoid::wholebody_command_t wholebody_msg_{};
  SensorSample sample_;
  EstimatedState state_;
  wbc::RobotState wbc_state_;  ///< the wbc's input of the tick
  balance::TaskReference wholebody_;
  bool reference_started_ = false;
};

/// The command line of the per-component benchmarks that run this loop: `NAME [robot] [seconds]`
/// (defaults toro, 10 s).
struct BenchArgs {
  std::string robot = "toro";
  double seconds = 10.0;
};
/// Reads argv; on bad use prints why (prefixed by `name`) and returns nothing.
std::optional<BenchArgs> read_bench_args(int argc, char** argv, const char* name);

}  // namespace hpr::pipeline
