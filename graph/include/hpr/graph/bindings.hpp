#pragma once
/// \file
/// How each component of the graph is bound to its channels (the contract:
/// hpr/graph/component_node.hpp): the typed channels it reads and writes (its declared ports,
/// checked at compile time), its inputs from the latest value of each, what it publishes, and the
/// node keys of its configuration section (which channels to wait for, how long, when a value is
/// too old to use).

#include <cstdint>
#include <string_view>
#include <tuple>

#include "hpr/balance/ports.hpp"
#include "hpr/common/config.hpp"
#include "hpr/common/log.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/estimator/node.hpp"
#include "hpr/estimator/truth_state.hpp"
#include "hpr/graph/component_node.hpp"
#include "hpr/model/robot.hpp"
#include "hpr/motion_opt/component.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/planner/component.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/wbc/component.hpp"
#include "hpr/wbc/node.hpp"

namespace hpr::graph {

/// The estimator: steps on every ROBOT_SENSORS sample and publishes ROBOT_STATE for the same tick.
/// When the samples stop for longer than `estimator.sensor_timeout` [s] (wall clock), it
/// republishes the last state flagged STATUS_SENSOR_STALE at that period and holds the fault
/// "sensors": a dropout is never silently held.
class EstimatorBinding {
 public:
  using Component = estimator::Estimator;
  static constexpr const char* kSummary = "floating-base state estimator";
  static constexpr std::tuple kReads{msg::channels::kRobotSensors};
  static constexpr std::tuple kWrites{msg::channels::kRobotState};
  static constexpr const char* kSilentFault = "sensors";

  EstimatorBinding(const model::RobotSpec& robot, const Config& cfg)
      : est_(robot, estimator::EstimatorConfig::load(cfg.section("estimator"))),
        sensor_timeout_(cfg.section("estimator").real_or("sensor_timeout", 0.02, 1e-3, 60.0)) {}
  [[nodiscard]] Component& component() { return est_; }
  [[nodiscard]] static double period() { return 1e-3; }
  [[nodiscard]] static bool waits_for(std::string_view) { return false; }
  [[nodiscard]] static double timeout() { return 0.0; }
  void parameters(ParameterSet& set) { estimator::add_parameters(set, est_.tunable_config()); }

  [[nodiscard]] static Component::Inputs inputs(const Slots<kReads>& s, std::int64_t) { return {slot<SensorSample>(s).value}; }
  [[nodiscard]] static std::tuple<const EstimatedState*> written(const Component::Outputs& out, std::int64_t) { return {&out.state}; }
  /// The faults of the tick and the log of refused samples (estimator::TickReport).
  void report(node::Runtime& rt, const Component::Outputs& out, std::int64_t tick) { report_(rt, est_, out.report, tick); }

  [[nodiscard]] double silent_after() const { return sensor_timeout_; }
  [[nodiscard]] std::tuple<const EstimatedState*> silent_written() {
    stale_ = est_.state();
    stale_.status |= estimator::kStatusSensorStale;
    return {&stale_};
  }

 private:
  Component est_;
  double sensor_timeout_;
  estimator::TickReport report_;
  EstimatedState stale_;
};

/// The balance planner: steps on ROBOT_STATE (tick k) and publishes the BALANCE_PLAN of tick k once
/// a usable estimate has started the posture (the wbc damps meanwhile); OPERATOR support requests
/// shift the support.
class PlannerBinding {
 public:
  using Component = planner::BalancePlanner;
  static constexpr const char* kSummary = "balance planner: posture, support changes, push compensation and steps";
  static constexpr std::tuple kReads{msg::channels::kRobotState, msg::channels::kOperator};
  static constexpr std::tuple kWrites{msg::channels::kBalancePlan};

  PlannerBinding(const model::RobotSpec& robot, const Config& cfg)
      : planner_(robot, balance::PostureReferenceConfig::load(cfg.section("balance"))) {}
  [[nodiscard]] Component& component() { return planner_; }
  [[nodiscard]] static double period() { return 1e-3; }
  [[nodiscard]] static bool waits_for(std::string_view) { return false; }
  [[nodiscard]] static double timeout() { return 0.0; }

  [[nodiscard]] Component::Inputs inputs(const Slots<kReads>& s, std::int64_t) const { return {slot<EstimatedState>(s).value}; }
  [[nodiscard]] static std::tuple<const balance::BalancePlan*> written(const Component::Outputs& out, std::int64_t) {
    return {out.valid ? &out.plan : nullptr};
  }
  /// An OPERATOR support request, from the time of the latest state on.
  void on(const humanoid::operator_t& m, const Slots<kReads>& s) {
    if (m.command != humanoid::operator_t::COMMAND_SET_SUPPORT) return;
    const auto support = static_cast<balance::Support>(m.support);
    log::info("OPERATOR from {}: support {} requested", m.source, balance::to_string(support));
    planner_.request_support(support, slot<EstimatedState>(s).value.time);
  }

 private:
  Component planner_;
};

/// The reference generator: steps on ROBOT_STATE (tick k) with the BALANCE_STATUS of tick k−1 (the
/// paper's one-period lag between torque computation and reference update) and the posture error
/// of the last WHOLEBODY_COMMAND; publishes CAM_REFERENCE for tick k. Keys of `reference_gen`:
/// wait_for_balance, balance_timeout [s].
class ReferenceGenBinding {
 public:
  using Component = reference_gen::ReferenceGenerator;
  static constexpr const char* kSummary = "three-phase CAM reference generator";
  static constexpr std::tuple kReads{msg::channels::kRobotState, msg::channels::kBalanceStatus, msg::channels::kWholebodyCommand};
  static constexpr std::tuple kWrites{msg::channels::kCamReference};

  ReferenceGenBinding(const model::RobotSpec&, const Config& cfg)
      : gen_(reference_gen::GeneratorConfig::load(cfg.section("reference_gen"))),
        wait_(cfg.section("reference_gen").boolean_or("wait_for_balance", true)),
        timeout_(cfg.section("reference_gen").real_or("balance_timeout", 0.5, 0.0, 60.0)) {}
  [[nodiscard]] Component& component() { return gen_; }
  [[nodiscard]] double period() const { return gen_.config().dt; }
  /// BALANCE_STATUS of the previous tick when configured (optional: without it the reference
  /// ramps to zero); the last WHOLEBODY_COMMAND's posture error is taken as it comes.
  [[nodiscard]] bool waits_for(std::string_view ch) const { return wait_ && ch == msg::channels::kBalanceStatus.name; }
  [[nodiscard]] double timeout() const { return timeout_; }
  void parameters(ParameterSet& set) { reference_gen::add_parameters(set, gen_); }

  [[nodiscard]] static Component::Inputs inputs(const Slots<kReads>& s, std::int64_t tick) {
    const auto& balance = slot<balance::BalanceStatus>(s);
    const auto& wholebody = slot<balance::WholebodyCommand>(s);
    return {.tick = tick,
            .time = slot<EstimatedState>(s).value.time,
            .balance = OptionalRef<balance::BalanceStatus>::when(balance.heard(), balance.value),
            .posture_error = wholebody.heard() ? wholebody.value.posture_error : 0.0};
  }
  [[nodiscard]] static std::tuple<const balance::CamReference*> written(const Component::Outputs& out, std::int64_t) {
    return {&out.reference};
  }

 private:
  Component gen_;
  bool wait_;
  double timeout_;
};

/// The motion optimiser: steps on ROBOT_STATE (tick k) with the BALANCE_PLAN and the CAM_REFERENCE
/// of the same tick, and publishes the WHOLEBODY_COMMAND of tick k: the plan with the optimised
/// adjusted DoF. Keys of `motion_opt`: wait_for_reference, reference_timeout [s],
/// reference_stale_ticks and plan_stale_ticks (how old a reference or a plan may be and still be
/// used).
class MotionOptBinding {
 public:
  using Component = motion_opt::MotionOptComponent;
  static constexpr const char* kSummary = "CAM-based whole-body motion optimisation";
  static constexpr std::tuple kReads{msg::channels::kRobotState, msg::channels::kBalancePlan, msg::channels::kCamReference};
  static constexpr std::tuple kWrites{msg::channels::kWholebodyCommand};

  MotionOptBinding(const model::RobotSpec& robot, const Config& cfg)
      : opt_(robot, motion_opt::MotionOptConfig::load(cfg.section("motion_opt"), robot)),
        wait_(cfg.section("motion_opt").boolean_or("wait_for_reference", true)),
        timeout_(cfg.section("motion_opt").real_or("reference_timeout", 0.5, 0.0, 60.0)),
        reference_stale_(cfg.section("motion_opt").integer_or("reference_stale_ticks", 20, 1, 100000)),
        plan_stale_(cfg.section("motion_opt").integer_or("plan_stale_ticks", 20, 1, 100000)) {}
  [[nodiscard]] Component& component() { return opt_; }
  [[nodiscard]] double period() const { return opt_.optimizer().config().dt; }
  /// BALANCE_PLAN of the tick (without a plan there is nothing to optimise around), and the
  /// CAM_REFERENCE of the tick when configured (optional: without it, the posture task only).
  [[nodiscard]] bool waits_for(std::string_view ch) const { return ch == msg::channels::kBalancePlan.name || wait_; }
  /// The plan is waited for once the planner plans (it starts on the first usable state).
  [[nodiscard]] bool needs(std::string_view ch, const Slots<kReads>& s) const {
    return ch != msg::channels::kBalancePlan.name || have_plan_ || slot<EstimatedState>(s).value.usable();
  }
  [[nodiscard]] double timeout() const { return timeout_; }
  void parameters(ParameterSet& set) { motion_opt::add_parameters(set, opt_.optimizer().tunable_config()); }
  /// A restarted clock: the plans before it are not followed.
  void restart() { have_plan_ = false; }
  void on(const balance::BalancePlan&, const Slots<kReads>&) { have_plan_ = true; }

  [[nodiscard]] Component::Inputs inputs(const Slots<kReads>& s, std::int64_t tick) const {
    const auto& plan = slot<balance::BalancePlan>(s);
    const auto& cam = slot<balance::CamReference>(s);
    return {.state = slot<EstimatedState>(s).value,
            .plan = OptionalRef<balance::TaskReference>::when(have_plan_ && plan.fresh(tick, plan_stale_), plan.value.reference),
            .cam = OptionalRef<balance::CamReference>::when(cam.fresh(tick, reference_stale_), cam.value)};
  }
  /// The command carries the tick of the state it answers (the component stamps it).
  [[nodiscard]] static std::tuple<const balance::WholebodyCommand*> written(const Component::Outputs& out, std::int64_t) {
    return {out.valid ? &out.wholebody : nullptr};
  }

 private:
  Component opt_;
  bool wait_;
  double timeout_;
  std::int64_t reference_stale_, plan_stale_;
  bool have_plan_ = false;  ///< a BALANCE_PLAN since the state's clock started
};

/// The simulator's true state in the estimator's place (simulated groups only): steps on every
/// ROBOT_SENSORS sample (tick k) with the SIM_TRUTH of the same tick, which the simulator publishes
/// before it waits (up to 0.5 s), and publishes ROBOT_STATE k; nothing for a tick without it.
class TruthStateBinding {
 public:
  using Component = estimator::TruthState;
  static constexpr const char* kSummary = "the simulator's true state as ROBOT_STATE (simulated groups only)";
  static constexpr std::tuple kReads{msg::channels::kRobotSensors, msg::channels::kSimTruth};
  static constexpr std::tuple kWrites{msg::channels::kRobotState};

  TruthStateBinding(const model::RobotSpec&, const Config&) {}
  [[nodiscard]] Component& component() { return truth_; }
  [[nodiscard]] static double period() { return 1e-3; }
  [[nodiscard]] static bool waits_for(std::string_view ch) { return ch == msg::channels::kSimTruth.name; }
  [[nodiscard]] static double timeout() { return 0.5; }

  [[nodiscard]] static Component::Inputs inputs(const Slots<kReads>& s, std::int64_t tick) {
    const auto& truth = slot<SimTruth>(s);
    return {.sensors = slot<SensorSample>(s).value, .truth = OptionalRef<SimTruth>::when(truth.tick == tick, truth.value)};
  }
  [[nodiscard]] static std::tuple<const EstimatedState*> written(const Component::Outputs& out, std::int64_t) {
    return {out.valid ? &out.state : nullptr};
  }

 private:
  Component truth_;
};

/// The wbc: steps on every ROBOT_STATE (from the estimator, or in a simulated group from
/// truth_state) with the BALANCE_PLAN of the same tick, towards the WHOLEBODY_COMMAND of the same
/// tick when motion_opt runs (waiting for both up to a timeout), else towards the plan itself.
/// Publishes JOINT_COMMAND every tick and BALANCE_STATUS while it balances; damps while it has no
/// plan; OPERATOR damp, stop and enable (wbc::apply_operator). Keys of `wbc`: wbc::WbcNodeOptions.
class WbcBinding {
 public:
  using Component = wbc::WbcComponent;
  static constexpr const char* kSummary = "passivity-based whole-body controller";
  static constexpr std::tuple kReads{msg::channels::kRobotState, msg::channels::kBalancePlan, msg::channels::kWholebodyCommand,
                                     msg::channels::kOperator};
  static constexpr std::tuple kWrites{msg::channels::kJointCommand, msg::channels::kBalanceStatus};

  WbcBinding(const model::RobotSpec& robot, const Config& cfg)
      : options_(wbc::WbcNodeOptions::load(cfg.section("wbc"))),
        wbc_(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot), options_.bad_state_ticks),
        nj_(robot.model.nj) {}
  [[nodiscard]] Component& component() { return wbc_; }
  [[nodiscard]] static double period() { return 1e-3; }
  /// The plan of the tick, and the motion optimiser's command of the tick when configured
  /// (optional: with the motion optimiser gone, the wbc follows the plan, the ankle strategy, at
  /// full rate).
  [[nodiscard]] bool waits_for(std::string_view ch) const {
    return ch == msg::channels::kBalancePlan.name || (ch == msg::channels::kWholebodyCommand.name && options_.wait_for_wholebody);
  }
  /// Both only when the tick balances (a damping wbc answers at once, with the planner gone too):
  /// the plan once the planner plans (from the first usable state on).
  [[nodiscard]] bool needs(std::string_view, const Slots<kReads>& s) const {
    const EstimatedState& state = slot<EstimatedState>(s).value;
    return wbc_.balances(state, have_plan_ || state.usable());
  }
  [[nodiscard]] double timeout() const { return options_.wholebody_timeout; }
  void parameters(ParameterSet& set) { wbc::add_parameters(set, wbc_.controller()); }
  void prepare(Component::Outputs& out) const { out.command.resize(nj_); }
  void restart() { have_plan_ = have_wholebody_ = false; }
  void on(const balance::BalancePlan&, const Slots<kReads>&) { have_plan_ = true; }
  void on(const balance::WholebodyCommand&, const Slots<kReads>&) { have_wholebody_ = true; }
  /// Support requests are the planner's.
  void on(const humanoid::operator_t& m, const Slots<kReads>&) { wbc::apply_operator(wbc_, m); }

  [[nodiscard]] Component::Inputs inputs(const Slots<kReads>& s, std::int64_t tick) const {
    const auto& plan = slot<balance::BalancePlan>(s);
    const auto& wholebody = slot<balance::WholebodyCommand>(s);
    return {.state = slot<EstimatedState>(s).value,
            .plan = OptionalRef<balance::TaskReference>::when(have_plan_ && plan.fresh(tick, options_.plan_stale_ticks), plan.value.reference),
            .wholebody = OptionalRef<balance::TaskReference>::when(have_wholebody_ && wholebody.fresh(tick, options_.wholebody_stale_ticks),
                                                                   wholebody.value.command)};
  }
  [[nodiscard]] static std::tuple<const JointCommand*, const balance::BalanceStatus*> written(const Component::Outputs& out, std::int64_t) {
    return {&out.command, out.mode == Component::Mode::kBalance ? &out.status : nullptr};
  }

 private:
  wbc::WbcNodeOptions options_;
  Component wbc_;
  int nj_;
  bool have_plan_ = false;       ///< a BALANCE_PLAN since the state's clock started
  bool have_wholebody_ = false;  ///< a WHOLEBODY_COMMAND since then
};

}  // namespace hpr::graph
