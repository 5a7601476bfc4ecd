#include "hpr/pipeline/closed_loop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <type_traits>

#include "hpr/common/args.hpp"

namespace hpr::pipeline {

namespace {

using Clock = std::chrono::steady_clock;

double us_since(Clock::time_point t0) { return std::chrono::duration<double, std::micro>(Clock::now() - t0).count(); }

}  // namespace

ClosedLoop::ClosedLoop(const std::string& config_file, const std::vector<std::string>& overrides, ClosedLoopOptions options)
    : opt(options),
      cfg(Config::load(config_file, overrides)),
      spec(model::RobotSpec::load(cfg.section("robot"))),
      sim(spec, sim::SimConfig::load(cfg.section("sim"))),
      wbc(spec, wbc::WbcConfig::load(cfg.section("wbc"), spec), balance::PostureReferenceConfig::load(cfg.section("balance")),
          static_cast<int>(cfg.section("wbc").integer_or("bad_state_ticks", 20, 1, 100000))) {
  names_.joints = spec.model.joint_name;
  for (int j : spec.free_joints) free_names_.push_back(spec.model.joint_name[static_cast<size_t>(j)]);
  sample_.resize(spec.model.nj);
  wbc_out.command.resize(spec.model.nj);
  if (opt.estimator_in_loop || opt.run_estimator) {
    estimator.emplace(spec, estimator::EstimatorConfig::load(cfg.section("estimator")));
    estimator->update(sensors_as_received());
  }
  if (opt.cam) {
    generator.emplace(reference_gen::GeneratorConfig::load(cfg.section("reference_gen")));
    optimizer.emplace(spec, motion_opt::MotionOptConfig::load(cfg.section("motion_opt"), spec),
                      balance::PostureReferenceConfig::load(cfg.section("balance")));
  }
}

template <class Message, class Value, class... Context>
void ClosedLoop::pass(const char* channel, const Value& sent, Message& m, Value& value, const Context&... context) {
  msg::to_message(sent, context..., m);
  std::string why;
  if constexpr (std::is_same_v<Message, humanoid::robot_sensors_t> || std::is_same_v<Message, humanoid::robot_state_t>) {
    why = msg::from_message(m, names_, value);
  } else if constexpr (std::is_same_v<Message, humanoid::wholebody_command_t>) {
    why = msg::from_message(m, free_names_, value);
  } else {
    why = msg::from_message(m, value);
  }
  if (!why.empty()) throw std::runtime_error(std::string("in-process ") + channel + " refused: " + why);
}

template <class Message, class Value, class... Context>
void ClosedLoop::receive(const char* channel, const Value& sent, Message& m, Value& value, const Context&... context) {
  if (opt.estimator_in_loop) {
    pass(channel, sent, m, value, context...);
  } else {
    value = sent;
  }
}

const SensorSample& ClosedLoop::sensors_as_received() {
  pass("ROBOT_SENSORS", sim.sensors(), sensors_msg_, sample_, names_);
  return sample_;
}

template <class F>
void ClosedLoop::run_component(Component c, double& us, F&& f) {
  if (probe) probe(c, true);
  const auto t0 = Clock::now();
  f();
  us = us_since(t0);
  if (probe) probe(c, false);
}

void ClosedLoop::request_support(balance::Support s, double t) {
  wbc.request_support(s, t);
  if (optimizer) optimizer->request_support(s, t);
}

void ClosedLoop::step() {
  if (opt.estimator_in_loop) {  // ROBOT_STATE as the controllers decode it
    pass("ROBOT_STATE", estimator->state(), state_msg_, state_, names_);
  } else {
    state_.q = sim.truth().q;
    state_.v = sim.truth().v;
    state_.time = sim.time();
    state_.status = 0;
  }
  state_.tick = sim.tick();
  have_wholebody = false;
  if (opt.cam) {
    // reference_gen: BALANCE_STATUS of the previous tick, the posture error of the last command.
    run_component(Component::kReferenceGen, times.reference_gen_us, [&] {
      generator->step({state_.tick, state_.time, have_balance_ ? &balance_ : nullptr, wholebody_.posture_error}, cam);
    });
    receive("CAM_REFERENCE", cam, cam_msg_, cam_);
    run_component(Component::kMotionOpt, times.motion_opt_us,
                  [&] { have_wholebody = optimizer->step({&state_, &cam_}, wholebody); });
    if (have_wholebody) receive("WHOLEBODY_COMMAND", wholebody, wholebody_msg_, wholebody_, free_names_, names_);
  }
  run_component(Component::kWbc, times.wbc_us,
                [&] { wbc.step({&state_, have_wholebody ? &wholebody_.command : nullptr}, wbc_out); });
  sim.set_command(wbc_out.command);
  have_balance_ = wbc_out.mode == wbc::WbcComponent::Mode::kBalance;
  if (have_balance_) receive("BALANCE_STATUS", wbc_out.status, balance_msg_, balance_, names_);
  sim.step();
  if (estimator) {
    const SensorSample& sample = sensors_as_received();
    run_component(Component::kEstimator, times.estimator_us, [&] { estimator->update(sample); });
  }
}

void ClosedLoop::run(double seconds, const std::function<void()>& each) {
  const auto steps = static_cast<long>(std::lround(seconds / sim.config().dt));
  for (long k = 0; k < steps; ++k) {
    step();
    if (each) each();
    if (sim.truth().fallen) return;
  }
}

void ClosedLoop::push_base(double impulse, double peak, const Eigen::Vector3d& direction, double start) {
  sim::Push p;
  p.id = 1;
  p.link = spec.model.body_name[0];
  p.force_W = peak * direction.normalized();
  p.duration = impulse / peak * M_PI / 2.0;
  p.start = start;
  sim.add_push(p);
}

std::optional<BenchArgs> read_bench_args(int argc, char** argv, const char* name) {
  BenchArgs a;
  try {
    if (argc > 1) a.robot = argv[1];
    if (argc > 2) a.seconds = parse_number(argv[2], "seconds");
    if (argc > 3 || !(a.seconds > 0)) throw UsageError(std::string("usage: ") + name + " [robot] [seconds > 0]");
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return std::nullopt;
  }
  return a;
}

}  // namespace hpr::pipeline
