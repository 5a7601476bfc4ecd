#include "hpr/graph/closed_loop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "hpr/common/args.hpp"
#include "hpr/estimator/truth_state.hpp"
#include "hpr/sim/engines.hpp"

namespace hpr::graph {

SimulatedRobot::SimulatedRobot(const std::string& config_file, const std::vector<std::string>& overrides)
    : cfg(Config::load(config_file, overrides)),
      spec(model::RobotSpec::load(cfg.section("robot"))),
      sim(spec, sim::SimConfig::load(cfg.section("sim")), sim::make_engine) {}

namespace {
ControllersOptions controllers_options(const ClosedLoopOptions& o) {
  return {.cam = o.cam, .estimator = o.estimator_in_loop || o.run_estimator, .messages = o.estimator_in_loop};
}
}  // namespace

ClosedLoop::ClosedLoop(const std::string& config_file, const std::vector<std::string>& overrides, ClosedLoopOptions loop_options)
    : SimulatedRobot(config_file, overrides), Controllers(cfg, spec, controllers_options(loop_options)), opt(loop_options) {
  sample_.resize(spec.model.nj);
  // Every key read, as each process checks its own: a misspelt override is refused, not ignored.
  // What only the processes use (their exchange over LCM, the simulator's clock) is validated too.
  check_exchange_options(cfg, controllers_options(loop_options));
  const Config s = cfg.section("sim");
  (void)s.choice_or("mode", "lockstep", {"lockstep", "realtime"});
  (void)s.real_or("lockstep_timeout", 1.0, 1e-3, 600.0);
  (void)s.real_or("startup_timeout", 10.0, 0.0, 600.0);
  (void)s.real_or("duration", 0.0, 0.0, 1e7);
  (void)s.boolean_or("publish_truth", true);
  (void)s.boolean_or("push_input", true);
  (void)s.string_or("scenario", "");
  cfg.check_all_read();
  if (estimator) estimate(sensors_as_received());
}

const SensorSample& ClosedLoop::sensors_as_received() {
  msg::to_message(sim.sensors(), names(), sensors_msg_);
  const std::string why = msg::from_message(sensors_msg_, names(), sample_);
  if (!why.empty()) throw std::runtime_error("in-process ROBOT_SENSORS refused: " + why);
  return sample_;
}

void ClosedLoop::step() {
  if (opt.estimator_in_loop) {
    control();
  } else {
    truth_.tick = sim.tick();
    truth_.time = sim.time();
    truth_.q = sim.truth().q;
    truth_.v = sim.truth().v;
    estimator::contacts_from_truth(sim.truth(), truth_);
    control(truth_);
  }
  sim::Simulator::Outputs plant;
  sim.step({&wbc_out().command}, plant);
  if (estimator) estimate(sensors_as_received());
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

}  // namespace hpr::graph
