#include "hpr/graph/controllers.hpp"

#include <array>
#include <chrono>
#include <stdexcept>

#include "hpr/msg/channels.hpp"
#include "hpr/msg/codec.hpp"
#include "hpr/msg/lcm_section.hpp"

namespace hpr::graph {

void check_exchange_options(const Config& cfg, const ControllersOptions& run) {
  if (run.estimator) (void)cfg.section("estimator").real_or("sensor_timeout", 0.02, 1e-3, 60.0);
  (void)msg::LcmSection::load(cfg);
}

namespace {
using Clock = std::chrono::steady_clock;

/// Each part of the controller diagram's probe and timer.
constexpr std::array kPartComponent{Component::kPlanner, Component::kReferenceGen, Component::kMotionOpt, Component::kWbc};
constexpr std::array kPartTime{&StepTimes::planner_us, &StepTimes::reference_gen_us, &StepTimes::motion_opt_us, &StepTimes::wbc_us};
}  // namespace

Controllers::Controllers(const Config& cfg, const model::RobotSpec& robot, ControllersOptions opts)
    : diagram_(robot, cfg, {true, opts.cam, opts.cam, true}, opts.messages),
      planner(diagram_.part<PlannerBinding>()->component()),
      generator(opts.cam ? &diagram_.part<ReferenceGenBinding>()->component() : nullptr),
      optimizer(opts.cam ? &diagram_.part<MotionOptBinding>()->component() : nullptr),
      wbc(diagram_.part<WbcBinding>()->component()),
      options_(opts) {
  if (options_.estimator) estimator.emplace(robot, estimator::EstimatorConfig::load(cfg.section("estimator")));
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
    diagram_.feed<humanoid::robot_state_t>(estimator->state(), estimator->state().tick);
  } else {
    flagged_ = estimator->state();
    flagged_.status |= extra_status;
    diagram_.feed<humanoid::robot_state_t>(flagged_, flagged_.tick);
    estimator->report(state(), estimate_out_.report);
  }
  reports_[n_reports_++] = &estimate_out_.report;
  step_controllers();
}

void Controllers::control(const EstimatedState& state) {
  n_reports_ = 0;
  diagram_.feed<humanoid::robot_state_t>(state, state.tick, /*through_message=*/false);
  step_controllers();
}

// The estimator feeds the diagram's ROBOT_STATE (the diagram checks the rest of the wiring against
// the declarations when it compiles).
static_assert(estimator::Estimator::kPorts.steps_on(channel::kRobotSensors));
static_assert(estimator::Estimator::kPorts.writes_to(channel::kRobotState));
static_assert(planner::BalancePlanner::kPorts.steps_on(channel::kRobotState));

void Controllers::step_controllers() {
  diagram_.step(state().tick, [&](std::size_t part, auto&& step) { run_component(kPartComponent[part], times_.*kPartTime[part], step); });
  reports_[n_reports_++] = &diagram_.outputs<PlannerBinding>().report;
  if (options_.cam) {
    reports_[n_reports_++] = &diagram_.outputs<ReferenceGenBinding>().report;
    reports_[n_reports_++] = &diagram_.outputs<MotionOptBinding>().report;
  }
  reports_[n_reports_++] = &diagram_.outputs<WbcBinding>().report;
}

void Controllers::apply(const humanoid::operator_t& m) {
  diagram_.feed<humanoid::operator_t>(m, m.tick, /*through_message=*/false);
}

void Controllers::request_support(balance::Support s, double t) {
  planner.request_support(s, t);
}

void Controllers::reset() {
  if (estimator) estimator->reset();
  diagram_.reset();
}

}  // namespace hpr::graph
