// Per-tick compute of the whole-body controller for the TORO-like robot: model update, impedances,
// feedforward, contact wrench QP (hot-started), torques and the virtual stance foot, on a closed-loop
// run (the state comes from the simulator, so the QP sees realistic tick-to-tick changes, including
// a push that saturates the CoP).
//
//   bench_wbc [robot] [seconds]        prints median, p99 and max of the controller step [us]
#include <chrono>
#include <cstdio>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/sim/simulator.hpp"
#include "hpr/wbc/controller.hpp"

int main(int argc, char** argv) {
  using namespace hpr;
  const std::string robot = argc > 1 ? argv[1] : "toro";
  const double seconds = argc > 2 ? std::atof(argv[2]) : 10.0;
  const Config cfg = Config::load(std::string(HPR_SOURCE_DIR) + "/config/" + robot + ".yaml");
  const auto spec = model::RobotSpec::load(cfg.section("robot"));
  const auto desc = model::load_urdf(cfg.section("robot").file_path("urdf"));
  sim::Simulator sim(spec, desc, sim::SimConfig::load(cfg.section("sim")));
  wbc::WholeBodyController ctl(spec, wbc::WbcConfig::load(cfg.section("wbc"), spec));
  balance::PostureReference ref(spec, balance::PostureReferenceConfig::load(cfg.section("balance")));
  ref.start(sim.truth().q, 0.0);
  sim::Push p;
  p.link = spec.model.body_name[0];
  p.force_W = Eigen::Vector3d(65, 0, 0);
  p.duration = 15.0 / 65.0 * M_PI / 2;
  p.start = 3.0;
  sim.add_push(p);
  std::vector<double> us;
  const long steps = static_cast<long>(seconds * 1000);
  for (long k = 0; k < steps; ++k) {
    wbc::RobotState st;
    st.q = sim.truth().q;
    st.v = sim.truth().v;
    st.time = sim.time();
    const auto& r = ref.update(sim.time());
    const auto t0 = std::chrono::steady_clock::now();
    const auto& cmd = ctl.step(st, r);
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    sim.set_command(cmd);
    sim.step();
  }
  std::printf("wbc step (%s, %ld ticks, a 15 N s push at t = 3 s): median %.1f us, p99 %.1f us, max %.1f us\n",
              robot.c_str(), steps, percentile(us, 0.5), percentile(us, 0.99), percentile(us, 1.0));
  return 0;
}
