#include "hpr/graph/controllers.hpp"

#include <chrono>
#include <stdexcept>

#include "hpr/msg/channels.hpp"
#include "hpr/msg/codec.hpp"
#include "hpr/msg/lcm_section.hpp"

namespace hpr::graph {

void check_exchange_options(const Config& cfg, const ControllersOptions& run) {
  if (run.cam) {
    const Config rg = cfg.section("reference_gen"), mo = cfg.section("motion_opt");
    (void)rg.boolean_or("wait_for_balance", true);
    (void)rg.real_or("balance_timeout", 0.5, 0.0, 60.0);
    (void)mo.boolean_or("wait_for_reference", true);
    (void)mo.real_or("reference_timeout", 0.5, 0.0, 60.0);
    (void)mo.integer_or("reference_stale_ticks", 20, 1, 100000);
    (void)mo.integer_or("plan_stale_ticks", 20, 1, 100000);
  }
  const Config wb = cfg.section("wbc");
  (void)wb.integer_or("plan_stale_ticks", 20, 1, 100000);
  (void)wb.boolean_or("wait_for_wholebody", true);
  (void)wb.real_or("wholebody_timeout", 0.5, 0.0, 60.0);
  (void)wb.integer_or("wholebody_stale_ticks", 50, 1, 100000);
  if (run.estimator) (void)cfg.section("estimator").real_or("sensor_timeout", 0.02, 1e-3, 60.0);
  (void)msg::LcmSection::load(cfg);
}

namespace {
using Clock = std::chrono::steady_clock;
}  // namespace

Controllers::Controllers(const Config& cfg, const model::RobotSpec& robot, ControllersOptions opts)
    : planner(robot, balance::PostureReferenceConfig::load(cfg.section("balance"))),
      wbc(robot, wbc::WbcConfig::load(cfg.section("wbc"), robot),
          static_cast<int>(cfg.section("wbc").integer_or("bad_state_ticks", 20, 1, 100000))),
      options_(opts),
      naming_(msg::Naming::of(robot)) {
  wbc_out_.command.resize(robot.model.nj);
  if (options_.estimator) estimator.emplace(robot, estimator::EstimatorConfig::load(cfg.section("estimator")));
  if (options_.cam) {
    generator.emplace(reference_gen::GeneratorConfig::load(cfg.section("reference_gen")));
    optimizer.emplace(robot, motion_opt::MotionOptConfig::load(cfg.section("motion_opt"), robot));
  }
}

template <class Message, class Value>
void Controllers::pass(const char* channel, const Value& sent, Message& m, Value& value) {
  if (!options_.messages) {
    value = sent;
    return;
  }
  msg::Codec<Message>::encode(sent, naming_, m);
  const std::string why = msg::Codec<Message>::decode(m, naming_, value);
  if (!why.empty()) throw std::runtime_error(std::string("in-process ") + channel + " refused: " + why);
}

template <class F>
void Controllers::run_component(Component c, double& us, F&& f) {
  if (probe) probe(c, true);
  const auto t0 = Clock::now();
  f();
  us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
  if (probe) probe(c, false);
}

void Controllers::estimate(const SensorSample& sample) {
  if (!estimator) throw std::logic_error("Controllers::estimate: no estimator in this loop");
  run_component(Component::kEstimator, times_.estimator_us, [&] { estimator->step({sample}, estimate_out_); });
}

void Controllers::control(std::int32_t extra_status) {
  if (!estimator) throw std::logic_error("Controllers::control: no estimator in this loop");
  n_reports_ = 0;
  if (extra_status == 0) {
    pass(msg::channels::kRobotState.name, estimator->state(), messages_.state, state_);
  } else {
    flagged_ = estimator->state();
    flagged_.status |= extra_status;
    pass(msg::channels::kRobotState.name, flagged_, messages_.state, state_);
    estimator->report(state_, estimate_out_.report);
  }
  reports_[n_reports_++] = &estimate_out_.report;
  step_controllers();
}

void Controllers::control(const EstimatedState& state) {
  state_ = state;
  n_reports_ = 0;
  step_controllers();
}

// The wiring below, checked against the components' declared ports: a declaration that changes
// (another channel, another tick) stops the composition from compiling.
using estimator::Estimator;
using motion_opt::MotionOptComponent;
using planner::BalancePlanner;
using reference_gen::ReferenceGenerator;
using wbc::WbcComponent;
static_assert(Estimator::kPorts.steps_on(channel::kRobotSensors));
static_assert(wired(Estimator::kPorts, channel::kRobotState, BalancePlanner::kPorts, 0));
static_assert(wired(Estimator::kPorts, channel::kRobotState, ReferenceGenerator::kPorts, 0));
static_assert(wired(Estimator::kPorts, channel::kRobotState, MotionOptComponent::kPorts, 0));
static_assert(wired(Estimator::kPorts, channel::kRobotState, WbcComponent::kPorts, 0));
static_assert(wired(WbcComponent::kPorts, channel::kBalanceStatus, ReferenceGenerator::kPorts, -1));    // balance_ of the last tick
static_assert(wired(MotionOptComponent::kPorts, channel::kWholebodyCommand, ReferenceGenerator::kPorts, -1));  // the last command's
static_assert(wired(BalancePlanner::kPorts, channel::kBalancePlan, MotionOptComponent::kPorts, 0));
static_assert(wired(BalancePlanner::kPorts, channel::kBalancePlan, WbcComponent::kPorts, 0));
static_assert(wired(ReferenceGenerator::kPorts, channel::kCamReference, MotionOptComponent::kPorts, 0));
static_assert(wired(MotionOptComponent::kPorts, channel::kWholebodyCommand, WbcComponent::kPorts, 0));

void Controllers::step_controllers() {
  have_wholebody_ = false;
  run_component(Component::kPlanner, times_.planner_us, [&] { planner.step({state_}, plan_out_); });
  reports_[n_reports_++] = &plan_out_.report;
  if (plan_out_.valid) pass(msg::channels::kBalancePlan.name, plan_out_.plan, messages_.plan, plan_);
  const auto plan = OptionalRef<balance::TaskReference>::when(plan_out_.valid, plan_.reference);
  if (options_.cam) {
    run_component(Component::kReferenceGen, times_.reference_gen_us, [&] {
      generator->step({.tick = state_.tick,
                       .time = state_.time,
                       .balance = OptionalRef<balance::BalanceStatus>::when(have_balance_, balance_),
                       .posture_error = wholebody_.posture_error},
                      reference_out_);
    });
    reports_[n_reports_++] = &reference_out_.report;
    pass(msg::channels::kCamReference.name, reference_out_.reference, messages_.cam, cam_);
    run_component(Component::kMotionOpt, times_.motion_opt_us, [&] { optimizer->step({.state = state_, .plan = plan, .cam = cam_}, motion_out_); });
    reports_[n_reports_++] = &motion_out_.report;
    have_wholebody_ = motion_out_.valid;
    if (have_wholebody_) {
      pass(msg::channels::kWholebodyCommand.name, motion_out_.wholebody, messages_.wholebody, wholebody_);
    }
  }
  run_component(Component::kWbc, times_.wbc_us, [&] {
    wbc.step({.state = state_,
              .plan = plan,
              .wholebody = OptionalRef<balance::TaskReference>::when(have_wholebody_, wholebody_.command)},
             wbc_out_);
  });
  reports_[n_reports_++] = &wbc_out_.report;
  if (options_.messages) msg::Codec<humanoid::joint_command_t>::encode(wbc_out_.command, naming_, messages_.command);
  have_balance_ = wbc_out_.mode == wbc::WbcComponent::Mode::kBalance;
  if (have_balance_) pass(msg::channels::kBalanceStatus.name, wbc_out_.status, messages_.balance, balance_);
}

void Controllers::request_support(balance::Support s, double t) {
  planner.request_support(s, t);
}

void Controllers::reset() {
  if (estimator) estimator->reset();
  planner.reset();
  if (generator) generator->reset();
  if (optimizer) optimizer->reset();
  wbc.reset();
  have_balance_ = false;
  have_wholebody_ = false;
  wholebody_.posture_error = 0.0;
}

}  // namespace hpr::graph
