#pragma once
// In-process closed loop for tests: the Bullet simulator and the controllers stepping in one
// process, without LCM (the processes themselves are tested separately). The data flow per tick is
// the stack's: sensors → estimator → (reference_gen with the previous tick's balance status →
// motion_opt) → wbc → joint command → simulator.
#include <algorithm>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "hpr/balance/task_reference.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/motion_opt/optimizer.hpp"
#include "hpr/reference_gen/generator.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/wbc/controller.hpp"
#include "process_group.hpp"

namespace hpr::test {

struct ClosedLoopOptions {
  bool cam = false;                ///< reference_gen + motion_opt in the loop (else the ankle strategy)
  bool estimator_in_loop = false;  ///< the controllers see the estimator's state (else the simulator's truth)
  bool run_estimator = false;      ///< run the estimator alongside even when it is not in the loop
};

struct ClosedLoop {
  explicit ClosedLoop(const std::string& robot, const std::vector<std::string>& overrides = {},
                      ClosedLoopOptions options = {})
      : opt(options),
        cfg(Config::load(source_dir() + "/config/" + robot + ".yaml", overrides)),
        spec(model::RobotSpec::load(cfg.section("robot"))),
        desc(model::load_urdf(cfg.section("robot").file_path("urdf"))),
        sim(spec, desc, sim::SimConfig::load(cfg.section("sim"))),
        wbc(spec, wbc::WbcConfig::load(cfg.section("wbc"), spec)),
        reference(spec, balance::PostureReferenceConfig::load(cfg.section("balance"))) {
    if (opt.estimator_in_loop || opt.run_estimator) {
      estimator.emplace(spec, estimator::EstimatorConfig::load(cfg.section("estimator")));
      estimator->update(sim.sensors());
    }
    if (opt.cam) {
      generator.emplace(reference_gen::GeneratorConfig::load(cfg.section("reference_gen")));
      optimizer.emplace(spec, motion_opt::MotionOptConfig::load(cfg.section("motion_opt"), spec));
    }
    reference.start(opt.estimator_in_loop ? estimator->state().q : sim.truth().q, sim.time());
  }

  /// One control period.
  void step() {
    const double dt = sim.config().dt;
    wbc::RobotState st;
    if (opt.estimator_in_loop) {
      st.q = estimator->state().q;
      st.v = estimator->state().v;
    } else {
      st.q = sim.truth().q;
      st.v = sim.truth().v;
    }
    st.time = sim.time();
    st.tick = sim.tick();
    const balance::TaskReference& r = reference.update(sim.time());
    const balance::TaskReference* cmd = &r;
    if (opt.cam) {
      const auto& o = generator->step(sim.time(), dt, balance, have_balance, posture_error);
      const bool generating = std::any_of(o.phase.begin(), o.phase.end(), [](reference_gen::Phase p) {
        return p == reference_gen::Phase::kGenerate || p == reference_gen::Phase::kReduce;
      });
      const auto& m = optimizer->step(st.q, st.v, r, o.l_ref_W, true, dt, generating);
      posture_error = m.posture_error;
      cmd = &m.command;
    }
    sim.set_command(wbc.step(st, *cmd));
    const auto& bs = wbc.status();
    balance.time = sim.time();
    balance.tau_ankle_V = bs.tau_ankle_V;
    balance.tau_min_V = bs.tau_min_V;
    balance.tau_max_V = bs.tau_max_V;
    balance.yaw_WV = bs.yaw_WV;
    have_balance = true;
    sim.step();
    if (estimator) estimator->update(sim.sensors());
  }
  /// Runs for `seconds`, calling `each` after every step; stops early when the robot fell.
  void run(double seconds, const std::function<void()>& each = {}) {
    const auto steps = static_cast<long>(std::lround(seconds / sim.config().dt));
    for (long k = 0; k < steps; ++k) {
      step();
      if (each) each();
      if (sim.truth().fallen) return;
    }
  }
  /// Pushes the base link with a half-sine of peak force `peak` [N] along `direction` for `impulse` N s.
  void push_base(double impulse, double peak, const Eigen::Vector3d& direction, double start) {
    sim::Push p;
    p.id = 1;
    p.link = spec.model.body_name[0];
    p.force_W = peak * direction.normalized();
    p.duration = impulse / peak * M_PI / 2.0;
    p.start = start;
    sim.add_push(p);
  }

  ClosedLoopOptions opt;
  Config cfg;
  model::RobotSpec spec;
  model::RobotDescription desc;
  sim::Simulator sim;
  wbc::WholeBodyController wbc;
  balance::PostureReference reference;
  std::optional<estimator::Estimator> estimator;
  std::optional<reference_gen::ReferenceGenerator> generator;
  std::optional<motion_opt::MotionOptimizer> optimizer;
  reference_gen::BalanceInput balance;
  bool have_balance = false;
  double posture_error = 0.0;
};

}  // namespace hpr::test
