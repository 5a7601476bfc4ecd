// Per-sample compute of the estimator for a robot: joint filter, leg kinematics, contact, attitude
// and position filters, centroidal momentum and the momentum observer. The samples come from a
// closed-loop simulation with sensor noise on (the wbc on the simulator's truth), including a push.
//
//   bench_estimator [robot] [seconds]      prints median, p99 and max of Estimator::update [us]
#include <chrono>
#include <cstdio>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/estimator/estimator.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/wbc/controller.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  const std::string robot = argc > 1 ? argv[1] : "toro";
  const double seconds = argc > 2 ? std::atof(argv[2]) : 10.0;
  const Config cfg = Config::load(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml", {"sim.noise.enabled=true"});
  const auto spec = model::RobotSpec::load(cfg.section("robot"));
  const auto desc = model::load_urdf(cfg.section("robot").file_path("urdf"));
  sim::Simulator sim(spec, desc, sim::SimConfig::load(cfg.section("sim")));
  wbc::WholeBodyController ctl(spec, wbc::WbcConfig::load(cfg.section("wbc"), spec));
  balance::PostureReference ref(spec, balance::PostureReferenceConfig::load(cfg.section("balance")));
  estimator::Estimator est(spec, estimator::EstimatorConfig::load(cfg.section("estimator")));
  ref.start(sim.truth().q, 0.0);
  sim::Push p;
  p.link = spec.model.body_name[0];
  p.force_W = Eigen::Vector3d(65, 0, 0);
  p.duration = 15.0 / 65.0 * M_PI / 2;
  p.start = 3.0;
  sim.add_push(p);
  std::vector<double> us;
  const long steps = static_cast<long>(seconds * 1000);
  est.update(sim.sensors());
  for (long k = 0; k < steps; ++k) {
    wbc::RobotState st;
    st.q = sim.truth().q;
    st.v = sim.truth().v;
    st.time = sim.time();
    sim.set_command(ctl.step(st, ref.update(sim.time())));
    sim.step();
    const auto t0 = std::chrono::steady_clock::now();
    est.update(sim.sensors());
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  std::printf("estimator update (%s, %ld samples with sensor noise, a 15 N s push at t = 3 s): median %.1f us, p99 %.1f us, max %.1f us\n",
              robot.c_str(), steps, percentile(us, 0.5), percentile(us, 0.99), percentile(us, 1.0));
  return 0;
}
