#pragma once
/// \file
/// The stack's controllers as one: estimator → planner → reference_gen → motion_opt → wbc, stepping tick by
/// tick with the data flow of the processes (README.md, "The processes"), for the in-process loop and the
/// composed process. The planner, reference_gen, motion_opt and wbc are composed from their
/// bindings (hpr/graph/bindings.hpp), the connections computed from what each declares; every
/// channel between the components passes through its hpr::msg conversion, as the processes
/// exchange them, and the messages of the last tick are kept for a composed process to publish:
/// the same traffic as the processes, bit for bit.
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
#include <humanoid/operator_t.hpp>
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
#include "hpr/graph/bindings.hpp"
#include "hpr/graph/diagram.hpp"
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

/// The options of the controller processes that no component's binding reads when composed (the
/// bindings read their own waits, timeouts and staleness limits, hpr/graph/bindings.hpp): the
/// estimator's sensor timeout and the lcm section, validated with the processes' ranges so that one
/// configuration serves both and a misspelt key is refused the same way.
void check_exchange_options(const Config& cfg, const ControllersOptions& run);

/// The four controllers that follow the state, composed from their bindings (the connections
/// computed from the declarations, hpr/graph/diagram.hpp).
using ControllerDiagram = Diagram<PlannerBinding, ReferenceGenBinding, MotionOptBinding, WbcBinding>;

class Controllers {
  ControllerDiagram diagram_;  // first: the components' references below point into it

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

  /// An OPERATOR message, to each component that reads it, as the processes take it: the planner
  /// (support requests, from the time of the last state on) and the wbc (damp, stop, enable).
  void apply(const humanoid::operator_t& m);
  /// A support mode requested from time t on, as an OPERATOR message asks the planner.
  void request_support(balance::Support s, double t);
  /// Forgets the estimate, the references and the held posture (a clock that restarted).
  void reset();

  /// The state the last control tick used (ROBOT_STATE as its readers decode it).
  [[nodiscard]] const EstimatedState& state() const { return diagram_.slot<PlannerBinding, EstimatedState>().value; }
  [[nodiscard]] const msg::RobotNames& names() const { return diagram_.naming().names; }
  [[nodiscard]] const ControllersOptions& options() const { return options_; }

  // What each component made in the last tick.
  /// BALANCE_PLAN as its readers decode it (when have_plan()).
  [[nodiscard]] const balance::BalancePlan& plan() const { return diagram_.slot<WbcBinding, balance::BalancePlan>().value; }
  /// The planner made a BALANCE_PLAN this tick (a usable estimate has started it).
  [[nodiscard]] bool have_plan() const { return diagram_.outputs<PlannerBinding>().valid; }
  /// CAM_REFERENCE (with cam).
  [[nodiscard]] const balance::CamReference& cam() const { return diagram_.outputs<ReferenceGenBinding>().reference; }
  /// WHOLEBODY_COMMAND (when have_wholebody()).
  [[nodiscard]] const balance::WholebodyCommand& wholebody() const { return diagram_.outputs<MotionOptBinding>().wholebody; }
  /// motion_opt made a WHOLEBODY_COMMAND this tick.
  [[nodiscard]] bool have_wholebody() const { return options_.cam && diagram_.outputs<MotionOptBinding>().valid; }
  /// JOINT_COMMAND, BALANCE_STATUS.
  [[nodiscard]] const wbc::WbcComponent::Outputs& wbc_out() const { return diagram_.outputs<WbcBinding>(); }
  /// The reports of the components that stepped in the last tick, in the data flow's order
  /// (estimator, planner, reference_gen, motion_opt, wbc): a composed process applies them to its
  /// HEALTH as the separate processes apply theirs.
  [[nodiscard]] std::span<const StepReport* const> reports() const { return {reports_.data(), n_reports_}; }
  /// The last message of type `Msg` (with `options().messages`): ROBOT_STATE, BALANCE_PLAN (when
  /// have_plan()), CAM_REFERENCE (with cam), WHOLEBODY_COMMAND (when have_wholebody()),
  /// JOINT_COMMAND, BALANCE_STATUS (when the wbc balanced).
  template <class Msg>
  [[nodiscard]] const Msg& message() const {
    return diagram_.message<Msg>();
  }
  /// Compute time of each component in the last tick.
  [[nodiscard]] const StepTimes& times() const { return times_; }

  // The components (a test reads their state; a composed process adds their live parameters).
  std::optional<estimator::Estimator> estimator;
  planner::BalancePlanner& planner;
  reference_gen::ReferenceGenerator* generator;     ///< null without cam
  motion_opt::MotionOptComponent* optimizer;        ///< null without cam
  wbc::WbcComponent& wbc;
  /// Called right before (`entering` true) and right after each component's step, when set: for a
  /// test that counts what a component does (allocations, say) apart from the rest.
  std::function<void(Component, bool entering)> probe;

 private:
  /// Times `f` (a component's step) into `us`, with the probe around it.
  template <class F>
  void run_component(Component c, double& us, F&& f);
  /// planner, reference_gen, motion_opt and wbc on the state fed.
  void step_controllers();

  ControllersOptions options_;
  estimator::Estimator::Outputs estimate_out_;
  std::array<const StepReport*, 5> reports_{};
  std::size_t n_reports_ = 0;
  StepTimes times_;
  EstimatedState flagged_;  ///< the estimate with extra status bits
};

}  // namespace hpr::graph
