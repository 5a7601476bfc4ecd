#pragma once
// In-process closed loop for tests: the Bullet simulator and the controllers stepping in one
// process, without LCM (the processes themselves are tested separately).
#include <functional>
#include <memory>
#include <string>

#include "hpr/balance/task_reference.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/wbc/controller.hpp"
#include "process_group.hpp"

namespace hpr::test {

struct ClosedLoop {
  explicit ClosedLoop(const std::string& robot, const std::vector<std::string>& overrides = {})
      : cfg(Config::load(source_dir() + "/config/" + robot + ".yaml", overrides)),
        spec(model::RobotSpec::load(cfg.section("robot"))),
        desc(model::load_urdf(cfg.section("robot").file_path("urdf"))),
        sim(spec, desc, sim::SimConfig::load(cfg.section("sim"))),
        wbc(spec, wbc::WbcConfig::load(cfg.section("wbc"), spec)),
        reference(spec, balance::PostureReferenceConfig::load(cfg.section("balance"))) {
    reference.start(sim.truth().q, sim.time());
  }

  /// One control period with the state from the simulator's truth.
  void step() {
    wbc::RobotState st;
    st.q = sim.truth().q;
    st.v = sim.truth().v;
    st.time = sim.time();
    st.tick = sim.tick();
    const auto& r = reference.update(sim.time());
    sim.set_command(wbc.step(st, r));
    sim.step();
  }
  /// Runs for `seconds`, calling `each` after every step.
  void run(double seconds, const std::function<void()>& each = {}) {
    const auto steps = static_cast<long>(std::lround(seconds / sim.config().dt));
    for (long k = 0; k < steps; ++k) {
      step();
      if (each) each();
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

  Config cfg;
  model::RobotSpec spec;
  model::RobotDescription desc;
  sim::Simulator sim;
  wbc::WholeBodyController wbc;
  balance::PostureReference reference;
};

}  // namespace hpr::test
