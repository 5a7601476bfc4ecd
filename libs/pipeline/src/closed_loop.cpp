#include "hpr/pipeline/closed_loop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

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
      wbc(spec, wbc::WbcConfig::load(cfg.section("wbc"), spec)),
      reference(spec, balance::PostureReferenceConfig::load(cfg.section("balance"))) {
  names_.joints = spec.model.joint_name;
  for (int j : spec.free_joints) free_names_.push_back(spec.model.joint_name[static_cast<size_t>(j)]);
  sample_.resize(spec.model.nj);
  if (opt.estimator_in_loop || opt.run_estimator) {
    estimator.emplace(spec, estimator::EstimatorConfig::load(cfg.section("estimator")));
    estimator->update(sensors_as_received());
  }
  if (opt.cam) {
    generator.emplace(reference_gen::GeneratorConfig::load(cfg.section("reference_gen")));
    optimizer.emplace(spec, motion_opt::MotionOptConfig::load(cfg.section("motion_opt"), spec));
  }
}

const SensorSample& ClosedLoop::sensors_as_received() {
  msg::to_message(sim.sensors(), names_, sensors_msg_);
  const std::string why = msg::from_message(sensors_msg_, names_, sample_);
  if (!why.empty()) throw std::runtime_error("in-process ROBOT_SENSORS refused: " + why);
  return sample_;
}

void ClosedLoop::step() {
  const double dt = sim.config().dt;
  wbc::RobotState& st = wbc_state_;  // kept between ticks: no allocation
  if (opt.estimator_in_loop) {
    // ROBOT_STATE as the controllers decode it.
    msg::to_message(estimator->state(), names_, state_msg_);
    const std::string why = msg::from_message(state_msg_, names_, state_);
    if (!why.empty()) throw std::runtime_error("in-process ROBOT_STATE refused: " + why);
    st.q = state_.q;
    st.v = state_.v;
    st.time = state_.time;
  } else {
    st.q = sim.truth().q;
    st.v = sim.truth().v;
    st.time = sim.time();
  }
  st.tick = sim.tick();
  // The posture reference starts from the first state, as the wbc's and motion_opt's do.
  if (!reference_started_) {
    reference.start(st.q, st.time);
    reference_started_ = true;
  }
  const balance::TaskReference& r = reference.update(st.time);
  const balance::TaskReference* cmd = &r;
  if (opt.cam) {
    auto t0 = Clock::now();
    const auto& o = generator->step(st.time, dt, balance, have_balance, posture_error);
    times.reference_gen_us = us_since(t0);
    const bool generating = std::any_of(o.phase.begin(), o.phase.end(), [](reference_gen::Phase p) {
      return p == reference_gen::Phase::kGenerate || p == reference_gen::Phase::kReduce;
    });
    t0 = Clock::now();
    const auto& m = optimizer->step(st.q, st.v, r, o.l_ref_W, true, dt, generating);
    times.motion_opt_us = us_since(t0);
    posture_error = m.posture_error;
    motion_opt_iterations = m.qp_iterations;
    cmd = &m.command;
    if (opt.estimator_in_loop) {
      // WHOLEBODY_COMMAND as the wbc decodes it.
      msg::to_message(m.command, free_names_, names_, wholebody_msg_);
      const std::string why = msg::from_message(wholebody_msg_, free_names_, wholebody_);
      if (!why.empty()) throw std::runtime_error("in-process WHOLEBODY_COMMAND refused: " + why);
      cmd = &wholebody_;
    }
  }
  const auto t0 = Clock::now();
  const auto& command = wbc.step(st, *cmd);
  times.wbc_us = us_since(t0);
  sim.set_command(command);
  const auto& bs = wbc.status();
  // BALANCE_STATUS carries the state's time in whole microseconds.
  balance.time = opt.estimator_in_loop ? static_cast<double>(std::llround(st.time * 1e6)) * 1e-6 : sim.time();
  balance.tau_ankle_V = bs.tau_ankle_V;
  balance.tau_min_V = bs.tau_min_V;
  balance.tau_max_V = bs.tau_max_V;
  balance.yaw_WV = bs.yaw_WV;
  have_balance = true;
  sim.step();
  if (estimator) {
    const SensorSample& sample = sensors_as_received();
    const auto t1 = Clock::now();
    estimator->update(sample);
    times.estimator_us = us_since(t1);
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
