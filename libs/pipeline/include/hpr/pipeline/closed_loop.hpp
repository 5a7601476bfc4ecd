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
#include "hpr/motion_opt/component.hpp"
#include "hpr/msg/balance.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/wbc/component.hpp"

namespace hpr::pipeline {

struct ClosedLoopOptions {
  bool cam = false;                ///< reference_gen + motion_opt in the loop (else the ankle strategy)
  bool estimator_in_loop = false;  ///< the controllers see the estimator's state (else the simulator's truth)
  bool run_estimator = false;      ///< run the estimator alongside even when it is not in the loop
};

/// The components of the loop, for a probe around each one's step.
enum class Component { kEstimator, kReferenceGen, kMotionOpt, kWbc };

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

  /// A support mode requested from time t on, as an OPERATOR message asks the wbc and motion_opt.
  void request_support(balance::Support s, double t);

  ClosedLoopOptions opt;
  Config cfg;
  model::RobotSpec spec;
  sim::Simulator sim;
  wbc::WbcComponent wbc;
  std::optional<estimator::Estimator> estimator;
  std::optional<reference_gen::ReferenceGenerator> generator;
  std::optional<motion_opt::MotionOptComponent> optimizer;
  // What each component published in the last tick.
  wbc::WbcComponent::Outputs wbc_out;   ///< JOINT_COMMAND and BALANCE_STATUS
  balance::CamReference cam;            ///< CAM_REFERENCE
  balance::WholebodyCommand wholebody;  ///< WHOLEBODY_COMMAND
  bool have_wholebody = false;          ///< motion_opt published this tick
  StepTimes times;
  /// Called right before (`entering` true) and right after each component's step, when set: for a
  /// test that counts what a component does (allocations, say) apart from the rest of the loop.
  std::function<void(Component, bool entering)> probe;

 private:
  /// Times `f` (a component's step) into `us`, with the probe around it.
  template <class F>
  void run_component(Component c, double& us, F&& f);
  /// The estimator's input: the simulator's sensors as the estimator node decodes ROBOT_SENSORS.
  const SensorSample& sensors_as_received();

  // The channels between the components, as the nodes exchange them.
  /// `sent` through the channel's conversion (message `m`) into `value`, as its receiving node
  /// decodes it.
  template <class Message, class Value, class... Context>
  void pass(const char* channel, const Value& sent, Message& m, Value& value, const Context&... context);
  /// pass() with the estimator in the loop, else a copy (the controllers on the simulator's truth).
  template <class Message, class Value, class... Context>
  void receive(const char* channel, const Value& sent, Message& m, Value& value, const Context&... context);

  msg::RobotNames names_;
  std::vector<std::string> free_names_;
  humanoid::robot_sensors_t sensors_msg_{};
  humanoid::robot_state_t state_msg_{};
  humanoid::balance_status_t balance_msg_{};
  humanoid::cam_reference_t cam_msg_{};
  humanoid::wholebody_command_t wholebody_msg_{};
  // The channels as their receivers decode them.
  SensorSample sample_;
  EstimatedState state_;  ///< ROBOT_STATE of the tick (or the simulator's truth)
  balance::BalanceStatus balance_;  ///< BALANCE_STATUS of the previous tick
  bool have_balance_ = false;
  balance::CamReference cam_;
  balance::WholebodyCommand wholebody_;
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
