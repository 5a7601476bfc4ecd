// The in-process pipeline against the processes: the same push through push_trial's processes in
// lockstep (recorded) and through hpr::graph::ClosedLoop must give the same messages, tick by
// tick and bit for bit: ROBOT_STATE, BALANCE_PLAN, CAM_REFERENCE, WHOLEBODY_COMMAND and JOINT_COMMAND. And the
// two ways of running a trial (run_trial with and without in_process) must judge alike.
#include <gtest/gtest.h>

#include <humanoid/balance_plan_t.hpp>
#include <humanoid/cam_reference_t.hpp>
#include <humanoid/joint_command_t.hpp>
#include <humanoid/robot_state_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "hpr/experiments/trial.hpp"
#include "hpr/msg/robot_io.hpp"
#include "hpr/msg/state.hpp"
#include "hpr/graph/closed_loop.hpp"
#include "paper.hpp"
#include "process_group.hpp"

namespace {

using hpr::experiments::Strategy;
using hpr::experiments::TrialSpec;

/// Every message of one type on `channel` of a log, by tick.
template <class M>
std::map<std::int64_t, M> read_channel(const std::string& path, const std::string& channel) {
  std::map<std::int64_t, M> out;
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (e->channel != channel) continue;
    M m;
    if (m.decode(e->data, 0, static_cast<int>(e->datalen)) < 0) continue;
    out.emplace(m.tick, m);
  }
  return out;
}

/// Counts the ticks whose message differs from the recorded one and remembers the first.
struct Comparison {
  explicit Comparison(std::string name) : channel(std::move(name)) {}
  std::string channel;
  long compared = 0, differing = 0;
  std::int64_t first = -1;
  std::string first_what;
  void add(std::int64_t tick, const std::string& what) {
    ++compared;
    if (what.empty()) return;
    if (differing++ == 0) {
      first = tick;
      first_what = what;
    }
  }
};

std::string differ(const char* name, const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return std::string(name) + ": sizes differ";
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] != b[i]) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), "%s[%zu]: %.17g recorded, %.17g in process", name, i, a[i], b[i]);
      return buf;
    }
  }
  return "";
}
std::string differ(const char* name, const double* a, const double* b, int n) {
  return differ(name, std::vector<double>(a, a + n), std::vector<double>(b, b + n));
}
std::string differ(const char* name, const std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b) {
  if (a.size() != b.size()) return std::string(name) + ": sizes differ";
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::string what = differ(name, a[i], b[i]); !what.empty()) return "foot " + std::to_string(i) + " " + what;
  }
  return "";
}
template <class T>
  requires std::is_integral_v<T>
std::string differ(const char* name, const std::vector<T>& a, const std::vector<T>& b) {
  return a == b ? "" : std::string(name) + " differs";
}
template <class T>
  requires std::is_arithmetic_v<T>
std::string differ(const char* name, T a, T b) {
  if (a == b) return "";
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%s: %.17g recorded, %.17g in process", name, static_cast<double>(a), static_cast<double>(b));
  return buf;
}

/// The first of a list of named differences, or "".
std::string first_of(std::initializer_list<std::string> whats) {
  for (const std::string& w : whats) {
    if (!w.empty()) return w;
  }
  return "";
}

/// The paper's experiment 1 at `impulse`: the TORO-like robot in the paper's configuration
/// (config/overlays/paper.yaml), pushed from behind at a 65 N peak.
TrialSpec experiment(Strategy strategy, double impulse) {
  // The tree's configuration and the processes of this build (run_trial starts them by name).
  ::setenv("HPR_CONFIG_DIR", (hpr::test::source_dir() + "/config").c_str(), 1);
  const char* path = std::getenv("PATH");
  if (path == nullptr || std::string(path).find(hpr::test::bin_dir()) != 0) {
    ::setenv("PATH", (hpr::test::bin_dir() + ":" + (path != nullptr ? path : "/usr/bin:/bin")).c_str(), 1);
  }
  TrialSpec spec;
  spec.config = hpr::experiments::find_config("toro");
  spec.overrides = hpr::test::paper_and();
  spec.strategy = strategy;
  spec.direction_deg = 0.0;
  spec.peak = 65.0;
  spec.impulse = impulse;
  spec.after = 1.5;
  return spec;
}

void expect_same_messages(TrialSpec spec, const std::string& name, int min_steps = 0) {
  const Strategy strategy = spec.strategy;
  const std::string dir = hpr::test::temp_dir("in-process-" + name);
  spec.log_file = dir + "/run.lcm";
  spec.work_dir = dir + "/processes";
  const auto recorded = hpr::experiments::run_trial(spec);
  ASSERT_FALSE(recorded.fallen) << recorded.failure;
  ASSERT_GE(recorded.steps, min_steps) << "the push should make the robot step";
  const auto states = read_channel<humanoid::robot_state_t>(spec.log_file, "ROBOT_STATE");
  const auto plans = read_channel<humanoid::balance_plan_t>(spec.log_file, "BALANCE_PLAN");
  const auto cams = read_channel<humanoid::cam_reference_t>(spec.log_file, "CAM_REFERENCE");
  const auto wholebodies = read_channel<humanoid::wholebody_command_t>(spec.log_file, "WHOLEBODY_COMMAND");
  const auto commands = read_channel<humanoid::joint_command_t>(spec.log_file, "JOINT_COMMAND");
  ASSERT_GT(commands.size(), 3000U);

  const auto plan = hpr::experiments::plan_trial(spec);
  hpr::graph::ClosedLoopOptions options;
  options.cam = strategy == Strategy::kCam;
  options.estimator_in_loop = true;
  hpr::graph::ClosedLoop loop(plan.config, plan.overrides, options);
  loop.sim.add_push(plan.push);
  hpr::msg::RobotNames names;
  names.joints = loop.spec.model.joint_name;
  Comparison state_cmp("ROBOT_STATE"), plan_cmp("BALANCE_PLAN"), cam_cmp("CAM_REFERENCE"), wholebody_cmp("WHOLEBODY_COMMAND"), command_cmp("JOINT_COMMAND");
  humanoid::robot_state_t state{};
  humanoid::joint_command_t command{};
  humanoid::wholebody_command_t wholebody{};
  std::vector<std::string> free_names;
  for (int j : loop.spec.free_joints) free_names.push_back(loop.spec.model.joint_name[static_cast<size_t>(j)]);
  while (true) {
    const std::int64_t k = loop.sim.tick();
    const auto c = commands.find(k);
    if (c == commands.end()) break;  // the recording ends here
    if (const auto s = states.find(k); s != states.end()) {
      hpr::msg::to_message(loop.estimator->state(), names, state);
      const auto& rec = s->second;
      state_cmp.add(k, first_of({differ("q", rec.q, state.q), differ("qd", rec.qd, state.qd), differ("tau", rec.tau, state.tau),
                                 differ("p_WB", rec.p_WB, state.p_WB, 3), differ("quat_WB", rec.quat_WB, state.quat_WB, 4),
                                 differ("v_WB", rec.v_WB, state.v_WB, 3), differ("omega_WB", rec.omega_WB, state.omega_WB, 3),
                                 differ("p_WCom", rec.p_WCom, state.p_WCom, 3), differ("v_WCom", rec.v_WCom, state.v_WCom, 3),
                                 differ("foot_contact", rec.foot_contact, state.foot_contact),
                                 differ("foot_force_z", rec.foot_force_z, state.foot_force_z),
                                 differ("foot_wrench_W", rec.foot_wrench_W, state.foot_wrench_W),
                                 differ("l_WCom", rec.l_WCom, state.l_WCom, 3), differ("ldot_WCom", rec.ldot_WCom, state.ldot_WCom, 3),
                                 differ("status", rec.status, state.status), differ("utime", rec.utime, state.utime)}));
    }
    loop.step();
    if (const auto p = plans.find(k); p != plans.end()) {
      const auto& rec = p->second;
      const auto& in = loop.message<humanoid::balance_plan_t>();  // the in-process plan as its message
      plan_cmp.add(k, loop.have_plan() ? first_of({differ("utime", rec.utime, in.utime), differ("stage", rec.stage, in.stage),
                                                   differ("support", rec.support, in.support), differ("settled", rec.settled, in.settled),
                                                   differ("p_WCom", rec.p_WCom, in.p_WCom, 3), differ("v_WCom", rec.v_WCom, in.v_WCom, 3),
                                                   differ("a_WCom", rec.a_WCom, in.a_WCom, 3), differ("R_WB", &rec.R_WB[0][0], &in.R_WB[0][0], 9),
                                                   differ("omega_WB", rec.omega_WB, in.omega_WB, 3), differ("p_WF", rec.p_WF, in.p_WF),
                                                   differ("R_WF", rec.R_WF, in.R_WF), differ("v_WF", rec.v_WF, in.v_WF),
                                                   differ("a_WF", rec.a_WF, in.a_WF), differ("foot_contact", rec.foot_contact, in.foot_contact),
                                                   differ("foot_load_limit", rec.foot_load_limit, in.foot_load_limit),
                                                   differ("q_free", rec.q_free, in.q_free), differ("f_ext_W", rec.f_ext_W, in.f_ext_W, 2),
                                                   differ("xi_W", rec.xi_W, in.xi_W, 2), differ("step_foot", rec.step_foot, in.step_foot),
                                                   differ("step_target_W", rec.step_target_W, in.step_target_W, 3),
                                                   differ("steps_taken", rec.steps_taken, in.steps_taken)})
                                     : std::string("no plan in process"));
    }
    if (loop.generator) {
      if (const auto r = cams.find(k); r != cams.end()) {
        const auto& o = loop.generator->output();
        cam_cmp.add(k, differ("l_ref_W", r->second.l_ref_W, o.l_ref_W.data(), 3));
      }
      if (const auto w = wholebodies.find(k); w != wholebodies.end()) {
        const auto& o = loop.wholebody();
        hpr::msg::to_message(o, free_names, names, wholebody);
        const auto& rec = w->second;
        const auto& w_in = wholebody;  // the in-process command as its message
        wholebody_cmp.add(
            k, first_of({differ("support", rec.support, w_in.support), differ("l_cmd_W", rec.l_cmd_W, o.l_cmd.data(), 3),
                         differ("p_WCom", rec.p_WCom, w_in.p_WCom, 3), differ("v_WCom", rec.v_WCom, w_in.v_WCom, 3),
                         differ("a_WCom", rec.a_WCom, w_in.a_WCom, 3), differ("quat_WB", rec.quat_WB, w_in.quat_WB, 4),
                         differ("omega_WB", rec.omega_WB, w_in.omega_WB, 3), differ("omegadot_WB", rec.omegadot_WB, w_in.omegadot_WB, 3),
                         differ("p_WF", rec.p_WF, w_in.p_WF), differ("quat_WF", rec.quat_WF, w_in.quat_WF),
                         differ("v_WF", rec.v_WF, w_in.v_WF), differ("a_WF", rec.a_WF, w_in.a_WF),
                         differ("foot_contact", rec.foot_contact, w_in.foot_contact),
                         differ("foot_load_limit", rec.foot_load_limit, w_in.foot_load_limit),
                         differ("q_free", rec.q_free, w_in.q_free), differ("qd_free", rec.qd_free, w_in.qd_free),
                         differ("qdd_free", rec.qdd_free, w_in.qdd_free), differ("posture_error", rec.posture_error, o.posture_error),
                         differ("xi_W", rec.xi_W, w_in.xi_W, 2), differ("xi_excess", rec.xi_excess, w_in.xi_excess),
                         differ("step_foot", rec.step_foot, w_in.step_foot),
                         differ("step_target_W", rec.step_target_W, w_in.step_target_W, 3),
                         differ("step_time_left", rec.step_time_left, w_in.step_time_left),
                         differ("steps_taken", rec.steps_taken, w_in.steps_taken),
                         differ("follow_steps", rec.follow_steps, w_in.follow_steps)}));
      }
    }
    hpr::msg::to_message(loop.wbc_out().command, names, command);
    const auto& rec = c->second;
    command_cmp.add(k, first_of({differ("tau_ff", rec.tau_ff, command.tau_ff), differ("q_des", rec.q_des, command.q_des),
                                 differ("qd_des", rec.qd_des, command.qd_des), differ("kp", rec.kp, command.kp),
                                 differ("kd", rec.kd, command.kd), differ("mode", rec.mode, command.mode)}));
  }
  for (const Comparison* cmp : {&state_cmp, &plan_cmp, &cam_cmp, &wholebody_cmp, &command_cmp}) {
    if ((cmp->channel == "CAM_REFERENCE" || cmp->channel == "WHOLEBODY_COMMAND") && strategy == Strategy::kAnkle) continue;
    std::printf("%-18s %5ld ticks compared, %5ld differ%s%s\n", cmp->channel.c_str(), cmp->compared, cmp->differing,
                cmp->first >= 0 ? ", first at tick " : "", cmp->first >= 0 ? (std::to_string(cmp->first) + ": " + cmp->first_what).c_str() : "");
    EXPECT_GT(cmp->compared, 3000) << cmp->channel;
    EXPECT_EQ(cmp->differing, 0) << cmp->channel << " first differs at tick " << cmp->first << ": " << cmp->first_what;
  }
}

TEST(InProcess, CamStrategyGivesTheProcessesMessagesBitForBit) { expect_same_messages(experiment(Strategy::kCam, 18.0), "cam"); }

// The default controller (config/toro.yaml: lean budget, push compensation, stepping) stepping,
// with ticks in the swing where both soles are off the ground and the estimate is flagged: the
// wbc process must wait for the motion optimiser's command of the tick as the composed wbc uses it
// (it once stepped on the previous tick's there, and the two fell apart).
TEST(InProcess, TheDefaultControllerSteppingGivesTheProcessesMessagesBitForBit) {
  // From behind at 130 N: a step and the trailing foot following it (standing it falls).
  TrialSpec spec = experiment(Strategy::kCam, 80.0);
  spec.overrides.clear();
  spec.peak = 130.0;
  expect_same_messages(spec, "stepping", 2);
}

TEST(InProcess, AnkleStrategyGivesTheProcessesMessagesBitForBit) { expect_same_messages(experiment(Strategy::kAnkle, 18.0), "ankle"); }

// MuJoCo in Bullet's place (sim.engine: the sim_mujoco process, the in-process simulator over
// MuJoCo): the same messages bit for bit, so a MuJoCo run is as deterministic and replayable as a
// Bullet one.
TEST(InProcess, MujocoGivesTheProcessesMessagesBitForBit) {
  TrialSpec spec = experiment(Strategy::kCam, 18.0);
  spec.overrides.emplace_back("sim.engine=mujoco");
  expect_same_messages(spec, "mujoco");
}

TEST(InProcess, JudgesPushesAsTheProcessesDo) {
  // Each strategy on both sides of its largest recovered impulse from behind (docs/RESULTS.md:
  // ankle 32.70, CAM 28.12 N s), both ways.
  for (const auto& [strategy, impulse] : std::vector<std::pair<Strategy, double>>{
           {Strategy::kAnkle, 32.0}, {Strategy::kAnkle, 33.5}, {Strategy::kCam, 27.5}, {Strategy::kCam, 29.0}}) {
    TrialSpec spec = experiment(strategy, impulse);
    spec.after = 5.0;
    spec.stop_when_decided = true;
    const auto processes = hpr::experiments::run_trial(spec);
    spec.in_process = true;
    const auto in_process = hpr::experiments::run_trial(spec);
    const std::string which = std::string(to_string(strategy)) + " " + std::to_string(impulse) + " N s";
    EXPECT_EQ(processes.recovered, in_process.recovered) << which;
    EXPECT_EQ(processes.fallen, in_process.fallen) << which;
    if (processes.recovered) {
      // The whole run both ways: the same figures to the last bit (a failed run stops when the
      // evaluation has seen it fail, which through the processes it may do a few ticks late).
      EXPECT_EQ(processes.min_cop_margin, in_process.min_cop_margin) << which;
      EXPECT_EQ(processes.max_tilt_deg, in_process.max_tilt_deg) << which;
      EXPECT_EQ(processes.max_slip, in_process.max_slip) << which;
      EXPECT_EQ(processes.peak_cam, in_process.peak_cam) << which;
      EXPECT_EQ(processes.return_time, in_process.return_time) << which;
      EXPECT_EQ(processes.final_joint_deg, in_process.final_joint_deg) << which;
      EXPECT_EQ(processes.sim_time, in_process.sim_time) << which;
    }
    std::printf("%s %.1f N s: %s / %s; wall time %.1f s through the processes, %.1f s in process\n", to_string(strategy), impulse,
                processes.recovered ? "recovered" : "not recovered", in_process.recovered ? "recovered" : "not recovered",
                processes.wall_time, in_process.wall_time);
  }
}

TEST(InProcess, ACheckpointBeforeThePushGivesTheFreshRunsResultBitForBit) {
  // One run to just before the push, continued in a copy of the process per push: each result is
  // the fresh in-process run's, every field to the last bit (the wall time aside), for a recovered
  // and a lost push and for another direction from the same checkpoint.
  TrialSpec base = experiment(Strategy::kCam, 27.5);
  base.after = 5.0;
  base.stop_when_decided = true;
  base.in_process = true;
  const hpr::experiments::PrePushCheckpoint checkpoint(base);
  for (const auto& [direction, impulse] : std::vector<std::pair<double, double>>{{0.0, 27.5}, {0.0, 29.0}, {180.0, 30.0}}) {
    TrialSpec spec = base;
    spec.direction_deg = direction;
    spec.impulse = impulse;
    hpr::experiments::TrialResult fresh = hpr::experiments::run_trial(spec);
    hpr::experiments::TrialResult forked = checkpoint.run(spec);
    fresh.wall_time = forked.wall_time = 0.0;
    EXPECT_EQ(forked.to_json(spec), fresh.to_json(spec)) << direction << " deg " << impulse << " N s";
    // docs/RESULTS.md: CAM recovers 28.12 N s from behind and 42.45 N s from the front.
    EXPECT_EQ(fresh.recovered, direction != 0.0 || impulse < 28.0) << direction << " deg " << impulse << " N s";
  }
  // Only the push may change.
  TrialSpec ankle = base;
  ankle.strategy = Strategy::kAnkle;
  EXPECT_THROW((void)checkpoint.run(ankle), std::invalid_argument);
  TrialSpec other = base;
  other.alpha = 0.8;
  EXPECT_THROW((void)checkpoint.run(other), std::invalid_argument);
}

TEST(InProcess, TheTruthStateGivesEveryControllerTheSimulatorsStateAndNoEstimatorRuns) {
  // --truth-state: the same trial as a closed loop whose controllers read the simulator's truth,
  // bit for bit; it differs from the trial with the estimator in the loop; the processes refuse it,
  // and the wbc process's own switch to the truth is refused in process rather than ignored.
  TrialSpec spec = experiment(Strategy::kCam, 18.0);
  spec.after = 5.0;
  spec.in_process = true;
  spec.truth_state = true;
  const auto truth = hpr::experiments::run_trial(spec);
  ASSERT_TRUE(truth.recovered) << truth.failure;

  const auto plan = hpr::experiments::plan_trial(spec);
  hpr::graph::ClosedLoop loop(plan.config, plan.overrides, {.cam = true, .estimator_in_loop = false});
  loop.sim.add_push(plan.push);
  double peak_cam_y = 0.0;  // the commanded CAM from the push on, as the evaluator reads it
  while (loop.sim.time() < plan.sim_duration) {
    const double t = loop.sim.time();
    loop.step();
    if (loop.have_wholebody() && t >= plan.push.start) peak_cam_y = std::max(peak_cam_y, std::abs(loop.wholebody().l_cmd.y()));
  }
  EXPECT_FALSE(loop.estimator.has_value()) << "no estimator runs";
  EXPECT_GT(peak_cam_y, 0.1) << "the hip strategy acted";
  EXPECT_EQ(truth.peak_cam_cmd.y(), peak_cam_y) << "the commanded CAM of the truth-fed closed loop";

  spec.truth_state = false;
  const auto estimated = hpr::experiments::run_trial(spec);
  EXPECT_NE(truth.peak_cam_cmd.y(), estimated.peak_cam_cmd.y());

  spec.truth_state = true;
  spec.in_process = false;
  EXPECT_THROW(hpr::experiments::run_trial(spec), std::invalid_argument);
}

// In process as in the processes, every key of the configuration is checked: a misspelt key of
// the lcm section (which only the processes use) stops the trial naming the nearest key, and a
// value out of range names its range.
TEST(InProcess, AMisspeltOrOutOfRangeLcmKeyIsRefusedAsTheProcessesRefuseIt) {
  const std::string config = hpr::test::source_dir() + "/config/toro.yaml";
  try {
    hpr::graph::ClosedLoop loop(config, {"lcm.tick_windw=5"}, {.cam = true, .estimator_in_loop = false});
    ADD_FAILURE() << "lcm.tick_windw was accepted";
  } catch (const hpr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'tick_window'?"), std::string::npos) << e.what();
  }
  try {
    hpr::graph::ClosedLoop loop(config, {"lcm.time_slack_s=-1"}, {.cam = true, .estimator_in_loop = false});
    ADD_FAILURE() << "lcm.time_slack_s = -1 was accepted";
  } catch (const hpr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("lcm.time_slack_s"), std::string::npos) << e.what();
  }
}

}  // namespace
