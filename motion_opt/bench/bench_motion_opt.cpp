// Per-tick compute of the motion optimisation for a robot: Ā from the model (ccrba and the task
// Jacobian), the QP (13) hot-started, integration and the commanded CAM with its segment shares.
// The states come from a closed-loop simulation of the whole stack (reference generator, motion
// optimisation and wbc on the simulator's truth) with the paper's experiment-1 push, so the QP sees
// the working-set changes of a real recovery.
//
//   bench_motion_opt [robot] [seconds]    prints median, p99 and max of MotionOptimizer::step [us]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/model/urdf.hpp"
#include "hpr/motion_opt/optimizer.hpp"
#include "hpr/reference_gen/generator.hpp"
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
  reference_gen::ReferenceGenerator gen(reference_gen::GeneratorConfig::load(cfg.section("reference_gen")));
  motion_opt::MotionOptimizer opt(spec, motion_opt::MotionOptConfig::load(cfg.section("motion_opt"), spec));
  ref.start(sim.truth().q, 0.0);
  sim::Push p;
  p.link = spec.model.body_name[0];
  p.force_W = Eigen::Vector3d(65, 0, 0);
  p.duration = 18.0 / 65.0 * M_PI / 2;
  p.start = 3.0;
  sim.add_push(p);
  reference_gen::BalanceInput balance;
  bool have_balance = false;
  double posture_error = 0.0;
  std::vector<double> us;
  std::vector<int> changes;
  const long steps = static_cast<long>(seconds * 1000);
  const double dt = sim.config().dt;
  for (long k = 0; k < steps; ++k) {
    const Eigen::VectorXd q = sim.truth().q, v = sim.truth().v;
    const auto& r = ref.update(sim.time());
    const auto& o = gen.step(sim.time(), dt, balance, have_balance, posture_error);
    const auto t0 = std::chrono::steady_clock::now();
    const bool generating = std::any_of(o.phase.begin(), o.phase.end(), [](reference_gen::Phase ph) {
      return ph == reference_gen::Phase::kGenerate || ph == reference_gen::Phase::kReduce;
    });
    const auto& out = opt.step(q, v, r, o.l_ref_W, true, dt, generating);
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    changes.push_back(out.qp_iterations);
    posture_error = out.posture_error;
    wbc::RobotState st;
    st.q = q;
    st.v = v;
    st.time = sim.time();
    sim.set_command(ctl.step(st, out.command));
    const auto& bs = ctl.status();
    balance.time = sim.time();
    balance.tau_ankle_V = bs.tau_ankle_V;
    balance.tau_min_V = bs.tau_min_V;
    balance.tau_max_V = bs.tau_max_V;
    balance.yaw_WV = bs.yaw_WV;
    have_balance = true;
    sim.step();
  }
  int max_changes = 0;
  for (int c : changes) max_changes = std::max(max_changes, c);
  std::printf("motion_opt step (%s, %ld ticks, 18 N s push at t = 3 s, fallen %d): median %.1f us, p99 %.1f us, max %.1f us; "
              "working-set changes per tick max %d\n",
              robot.c_str(), steps, sim.truth().fallen ? 1 : 0, percentile(us, 0.5), percentile(us, 0.99), percentile(us, 1.0),
              max_changes);
  return 0;
}
