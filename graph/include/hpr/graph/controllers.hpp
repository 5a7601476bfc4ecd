#pragma once
/// \file
/// The stack's controllers as one: estimator → planner → reference_gen → motion_opt → wbc, stepping tick by
/// tick with the data flow of the processes (README.md, "The processes"), for the in-process loop and the
/// composed process. Every channel between the components passes through its hpr::msg conversion,
/// as the processes exchange them, and the messages of the last tick are kept for a composed
/// process to publish: the same traffic as the processes, bit for bit.
///
/// Per tick k:
///   estimate(ROBOT_SENSORS k)                                  → ROBOT_STATE k
///   planner(ROBOT_STATE k)                                     → BALANCE_PLAN k
///   reference_gen(ROBOT_STATE k, BALANCE_STATUS k−1, WHOLEBODY_COMMAND k−1) → CAM_REFERENCE k
///   motion_opt(ROBOT_STATE k, BALANCE_PLAN k, CAM_REFERENCE k) → WHOLEBODY_COMMAND k
///   wbc(ROBOT_STATE k, BALANCE_PLAN k, WHOLEBODY_COMMAND k)    → JOINT_COMMAND k, BALANCE_STATUS k

#include <humanoid/balance_plan_t.hpp>
#include <humanoid/balance_status_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/robot_sensors_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hpr/balance/ports.hpp"
#include "hpr/common/component.hpp"
#include "hpr/common/config.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/motion_opt/component.hpp"
#include "hpr/msg/codec.hpp"
#include "hpr/planner/component.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/wbc/component.hpp"

namespace hpr::graph {

/// The components, for a probe around each one's step.
enum class Component { kEstimator, kPlanner, kReferenceGen, kMotionOpt, kWbc };

/// Compute time of each component in the last tick [us] (0 for a component not in the loop).
struct StepTimes {
  double estimator_us = 0;
  double planner_us = 0;
  double reference_gen_us = 0;
  double motion_opt_us = 0;
  double wbc_us = 0;
};

struct ControllersOptions {
  bool cam = true;        ///< reference_gen + motion_opt (else the wbc follows the plan: the ankle strategy)
  bool estimator = true;  ///< run the estimator
  bool messages = true;   ///< pass every channel through its message (else hand the values over)
};

/// The options of the controller processes that concern their exchange over LCM (waits, timeouts,
/// staleness): composed, every input of a tick is there when it steps, so they do not apply; they
/// are validated with the processes' ranges for the components `run` runs, so that one
/// configuration serves both and a misspelt key is refused the same way.
void check_exchange_options(const Config& cfg, const ControllersOptions& run);

class Controllers {
 public:
  /// `cfg`: the robot configuration (sections robot, estimator, reference_gen, motion_opt, wbc,
  /// balance) describing `robot`.
  Controllers(const Config& cfg, const model::RobotSpec& robot, ControllersOptions options);

  /// ROBOT_SENSORS of a tick into the estimator (required before control() with the estimate).
  void estimate(const SensorSample& sample);
  /// One control tick on the estimator's state (as ROBOT_STATE carries it), with `extra_status`
  /// bits set (EstimatedState::kSensorStale when the samples stopped and the last state goes on).
  void control(std::int32_t extra_status = 0);
  /// One control tick on `state` (the simulator's truth, say; no ROBOT_STATE message).
  void control(const EstimatedState& state);

  /// A support mode requested from time t on, as an OPERATOR message asks the planner.
  void request_support(balance::Support s, double t);
  /// Forgets the estimate, the references and the held posture (a clock that restarted).
  void reset();

  /// The state the last control tick used (ROBOT_STATE as its readers decode it).
  [[nodiscard]] const EstimatedState& state() const { return state_; }
  [[nodiscard]] const msg::RobotNames& names() const { return naming_.names; }
  [[nodiscard]] const ControllersOptions& options() const { return options_; }

  // What each component made in the last tick.
  [[nodiscard]] const balance::BalancePlan& plan() const { return plan_; }  ///< BALANCE_PLAN (when have_plan())
  /// The planner made a BALANCE_PLAN this tick (a usable estimate has started it).
  [[nodiscard]] bool have_plan() const { return plan_out_.valid; }
  [[nodiscard]] const balance::CamReference& cam() const { return reference_out_.reference; }  ///< CAM_REFERENCE
  [[nodiscard]] const balance::WholebodyCommand& wholebody() const { return motion_out_.wholebody; }  ///< WHOLEBODY_COMMAND
  /// motion_opt made a WHOLEBODY_COMMAND this tick.
  [[nodiscard]] bool have_wholebody() const { return have_wholebody_; }
  [[nodiscard]] const wbc::WbcComponent::Outputs& wbc_out() const { return wbc_out_; }  ///< JOINT_COMMAND, BALANCE_STATUS
  /// The reports of the components that stepped in the last tick, in the data flow's order
  /// (estimator, planner, reference_gen, motion_opt, wbc): a composed process applies them to its
  /// HEALTH as the separate processes apply theirs.
  [[nodiscard]] std::span<const StepReport* const> reports() const { return {reports_.data(), n_reports_}; }

  /// The messages of the last tick (with `options().messages`).
  struct Messages {
    humanoid::robot_state_t state{};          ///< ROBOT_STATE
    humanoid::balance_plan_t plan{};          ///< BALANCE_PLAN (when have_plan())
    humanoid::cam_reference_t cam{};          ///< CAM_REFERENCE (with cam)
    humanoid::wholebody_command_t wholebody{};  ///< WHOLEBODY_COMMAND (when have_wholebody())
    humanoid::joint_command_t command{};      ///< JOINT_COMMAND
    humanoid::balance_status_t balance{};     ///< BALANCE_STATUS (when the wbc balanced)
  };
  [[nodiscard]] const Messages& messages() const { return messages_; }
  /// Compute time of each component in the last tick.
  [[nodiscard]] const StepTimes& times() const { return times_; }

  // The components (a test reads their state; a composed process adds their live parameters).
  std::optional<estimator::Estimator> estimator;
  planner::BalancePlanner planner;
  std::optional<reference_gen::ReferenceGenerator> generator;
  std::optional<motion_opt::MotionOptComponent> optimizer;
  wbc::WbcComponent wbc;
  /// Called right before (`entering` true) and right after each component's step, when set: for a
  /// test that counts what a component does (allocations, say) apart from the rest.
  std::function<void(Component, bool entering)> probe;

 private:
  /// `sent` through the channel's conversion (message `m`) into `value`, as its receiving node
  /// decodes it; a copy without `options.messages`.
  template <class Message, class Value>
  void pass(const char* channel, const Value& sent, Message& m, Value& value);
  /// Times `f` (a component's step) into `us`, with the probe around it.
  template <class F>
  void run_component(Component c, double& us, F&& f);
  /// planner, reference_gen, motion_opt and wbc on state_.
  void step_controllers();

  ControllersOptions options_;
  msg::Naming naming_;
  // Each component's outputs.
  estimator::Estimator::Outputs estimate_out_;
  planner::BalancePlanner::Outputs plan_out_;
  reference_gen::ReferenceGenerator::Outputs reference_out_;
  motion_opt::MotionOptComponent::Outputs motion_out_;
  wbc::WbcComponent::Outputs wbc_out_;
  bool have_wholebody_ = false;
  std::array<const StepReport*, 5> reports_{};
  std::size_t n_reports_ = 0;
  Messages messages_;
  StepTimes times_;
  // The channels as their receivers decode them.
  EstimatedState state_;            ///< ROBOT_STATE of the tick
  EstimatedState flagged_;          ///< the estimate with extra status bits
  balance::BalancePlan plan_;       ///< BALANCE_PLAN of the tick
  balance::BalanceStatus balance_;  ///< BALANCE_STATUS of the previous tick
  bool have_balance_ = false;
  balance::CamReference cam_;
  balance::WholebodyCommand wholebody_;
};

}  // namespace hpr::graph
