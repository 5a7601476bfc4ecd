// The paper's experiments in simulation, every process of the stack in lockstep with the estimator
// in the loop (push_trial, push_sweep): the TORO-like robot in the paper's configuration
// (config/overlays/paper.yaml, α = 0.9, β = 0.4) and the variants docs/RESULTS.md measures on it,
// the default controller (ankle → hip → step, config/toro.yaml) against its single strategies, and
// the other robots with configuration changes only. Figures from each run's LCM log go to the
// test's work folder (build/test-work/...).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <humanoid/cam_reference_t.hpp>
#include <humanoid/wholebody_command_t.hpp>

#include "hpr/balance/stepping.hpp"
#include "hpr/common/config.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/model/robot.hpp"
#include "paper.hpp"
#include "process_group.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// Runs a tool of the build tree, returns its exit status and stdout.
int run(const std::string& cmd, std::string* out = nullptr) {
  std::fprintf(stderr, "$ %s\n", cmd.c_str());
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return -1;
  std::string text;
  char buf[4096];
  while (std::fgets(buf, sizeof(buf), p) != nullptr) text += buf;
  const int status = ::pclose(p);
  if (out != nullptr) *out = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string bin(const std::string& name) { return hpr::test::bin_dir() + "/" + name; }

/// " --overlay" of config/overlays/NAME.yaml, for push_trial and push_sweep.
std::string overlay(const std::string& name) { return " --overlay " + hpr::test::source_dir() + "/config/overlays/" + name + ".yaml"; }

/// The paper's configuration: the standing posture, two strategies, no lean budget, no push
/// compensation, no stepping.
const std::string kPaper = overlay("paper");

/// push_trial with `args`; the JSON result. The LCM log and figures go to `dir` when given.
json trial(const std::string& args, const std::string& dir = "", const std::string& title = "") {
  std::string cmd = bin("push_trial") + " --quiet " + args;
  if (!dir.empty()) cmd += " --log " + dir + "/run.lcm";
  std::string out;
  const int rc = run(cmd, &out);
  EXPECT_TRUE(rc == 0 || rc == 1) << "push_trial failed (" << rc << "): " << out;
  json j = json::parse(out, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << out;
  std::fprintf(stderr, "%s\n", out.c_str());
  if (!dir.empty() && !j.is_discarded()) {
    EXPECT_EQ(run(bin("lcm_export") + " " + dir + "/run.lcm " + dir + "/csv > /dev/null"), 0);
    EXPECT_EQ(run("/usr/bin/python3 " + hpr::test::source_dir() + "/tools/plots/plot_trial.py " + dir + "/csv " + dir +
                  " --title '" + title + "'"),
              0);
    EXPECT_TRUE(fs::exists(dir + "/fig5.png"));
  }
  return j;
}

/// Every WHOLEBODY_COMMAND and CAM_REFERENCE of a log.
struct LogData {
  std::vector<humanoid::wholebody_command_t> wholebody;
  std::vector<humanoid::cam_reference_t> cam;
};

LogData read_log(const std::string& path) {
  LogData d;
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  for (const lcm::LogEvent* ev = log.readNextEvent(); ev != nullptr; ev = log.readNextEvent()) {
    if (ev->channel == "WHOLEBODY_COMMAND") {
      humanoid::wholebody_command_t m;
      if (m.decode(ev->data, 0, static_cast<int>(ev->datalen)) >= 0) d.wholebody.push_back(std::move(m));
    } else if (ev->channel == "CAM_REFERENCE") {
      humanoid::cam_reference_t m;
      if (m.decode(ev->data, 0, static_cast<int>(ev->datalen)) >= 0) d.cam.push_back(m);
    }
  }
  return d;
}

/// Largest |value| of a named adjusted coordinate's offset, with its sign.
double peak_offset(const LogData& d, const std::string& name) {
  double best = 0.0;
  for (const auto& w : d.wholebody) {
    for (size_t i = 0; i < w.adjusted_name.size(); ++i) {
      if (w.adjusted_name[i] == name && std::abs(w.xa_opt[i]) > std::abs(best)) best = w.xa_opt[i];
    }
  }
  return best;
}

/// Largest |CAM| about `axis` contributed by the segments whose name contains `part`, with its sign.
double peak_segment(const LogData& d, const std::string& part, int axis) {
  double best = 0.0;
  for (const auto& w : d.wholebody) {
    double sum = 0.0;
    for (size_t s = 0; s < w.segment_name.size(); ++s) {
      if (w.segment_name[s].find(part) != std::string::npos) sum += w.segment_l_W[s][static_cast<size_t>(axis)];
    }
    if (std::abs(sum) > std::abs(best)) best = sum;
  }
  return best;
}

TEST(PaperExperiments, Experiment1DoubleSupportPushFromBehind18Ns) {
  const std::string dir = hpr::test::temp_dir("experiment1");
  const json cam = trial("--robot toro --support double --strategy cam --direction 0 --peak 65 --impulse 18" + kPaper, dir,
                         "Experiment 1: double support, 18 N s from behind, CAM strategy");
  EXPECT_TRUE(cam["recovered"].get<bool>()) << cam.dump();
  EXPECT_NEAR(cam["applied_impulse_Ns"].get<double>(), 18.0, 0.1);
  // The robot bends forward and swings its arms back: CAM about +y, the sign that counteracts the
  // push (the ankles saturate resisting it), from the trunk and from both arms.
  const LogData d = read_log(dir + "/run.lcm");
  const double l_peak = cam["peak_cam_commanded_Nms"][1].get<double>();
  EXPECT_GT(l_peak, 0.2);
  double l_signed = 0.0;
  for (const auto& w : d.wholebody) l_signed = std::abs(w.l_cmd_W[1]) > std::abs(l_signed) ? w.l_cmd_W[1] : l_signed;
  EXPECT_GT(l_signed, 0.0) << "CAM about +y";
  EXPECT_GT(peak_offset(d, "base_rotation_y"), 0.005) << "the trunk bends forward";
  EXPECT_GT(peak_segment(d, "arm", 1), 0.05) << "the arms swing back";
  // The ankle strategy alone with the same gains at the same push, reported.
  const json ankle = trial("--robot toro --support double --strategy ankle --direction 0 --peak 65 --impulse 18" + kPaper,
                           hpr::test::temp_dir("experiment1-ankle"), "Experiment 1: the ankle strategy alone");
  std::printf("experiment 1 (18 N s from behind): CAM strategy %s, ankle strategy %s\n",
              cam["recovered"].get<bool>() ? "recovered" : "NOT recovered",
              ankle["recovered"].get<bool>() ? "recovered" : ("NOT recovered: " + ankle["failure"].get<std::string>()).c_str());
  std::printf("  CAM: min CoP margin %.1f mm, peak CAM %.2f N m s, back in %.2f s; ankle: min CoP margin %.1f mm\n",
              cam["min_cop_margin_m"].get<double>() * 1e3, cam["peak_cam_Nms"][1].get<double>(),
              cam["return_time_s"].is_null() ? -1.0 : cam["return_time_s"].get<double>(),
              ankle["min_cop_margin_m"].get<double>() * 1e3);
}

TEST(PaperExperiments, Experiment2SingleSupportPushFromTheFront22_5Ns) {
  const std::string dir = hpr::test::temp_dir("experiment2");
  const json r = trial("--robot toro --support right --strategy cam --direction 180 --peak 75 --impulse 22.5" + kPaper, dir,
                       "Experiment 2: single support (right), 22.5 N s from the front");
  EXPECT_TRUE(r["recovered"].get<bool>()) << r.dump();
  EXPECT_NEAR(r["applied_impulse_Ns"].get<double>(), 22.5, 0.1);
  // The swing leg contributes to the commanded CAM, with the sign of the total.
  const LogData d = read_log(dir + "/run.lcm");
  double total = 0.0;
  for (const auto& w : d.wholebody) total = std::abs(w.l_cmd_W[1]) > std::abs(total) ? w.l_cmd_W[1] : total;
  const double swing = peak_segment(d, "left_foot", 1);
  std::printf("experiment 2: peak commanded CAM %.2f N m s about y, of which the swing foot %.2f N m s\n", total, swing);
  EXPECT_LT(total, 0.0) << "pushed from the front: CAM about -y";
  EXPECT_LT(swing, 0.0);
  EXPECT_GT(std::abs(swing), 0.1 * std::abs(total)) << "the swing leg takes part";
}

// The paper's two experiments with MuJoCo in Bullet's place (the sim_mujoco process, the same
// controllers and estimator): both recovered, the CAM about the axis that counteracts the push; and
// the recorded run re-runs exactly (replay_check), as a Bullet run does.
TEST(SecondEngine, MujocoRecoversExperiments1And2AndItsLogReplaysExactly) {
  const std::string dir = hpr::test::temp_dir("mujoco-experiment1");
  const json e1 = trial("--engine mujoco --robot toro --support double --strategy cam --direction 0 --peak 65 --impulse 18" + kPaper, dir,
                        "Experiment 1 in MuJoCo: double support, 18 N s from behind, CAM strategy");
  EXPECT_TRUE(e1["recovered"].get<bool>()) << e1.dump();
  EXPECT_NEAR(e1["applied_impulse_Ns"].get<double>(), 18.0, 0.1);
  EXPECT_GT(e1["peak_cam_commanded_Nms"][1].get<double>(), 0.2);
  const json e2 = trial("--in-process --engine mujoco --robot toro --support right --strategy cam --direction 180 --peak 75 --impulse 22.5" + kPaper);
  EXPECT_TRUE(e2["recovered"].get<bool>()) << e2.dump();
  EXPECT_NEAR(e2["applied_impulse_Ns"].get<double>(), 22.5, 0.1);
  std::printf("MuJoCo: experiment 1 min CoP margin %.1f mm, peak CAM %.2f N m s; experiment 2 min CoP margin %.1f mm\n",
              e1["min_cop_margin_m"].get<double>() * 1e3, e1["peak_cam_Nms"][1].get<double>(), e2["min_cop_margin_m"].get<double>() * 1e3);
  std::string sets = " --set balance.support=double";
  for (const std::string& o : hpr::test::paper_and()) sets += " --set '" + o + "'";  // the overrides the log was recorded with
  std::string out;
  EXPECT_EQ(run(hpr::test::source_dir() + "/tools/replay " + dir + "/run.lcm --rerun estimator,planner,wbc,reference_gen,motion_opt" + sets +
                    " --json " + dir + "/replay.json --work-dir " + dir + "/replay",
                &out),
            0)
      << out;
  const json r = json::parse(std::ifstream(dir + "/replay.json"), nullptr, false);
  ASSERT_FALSE(r.is_discarded());
  EXPECT_TRUE(r["match"].get<bool>()) << r.dump(2);
  EXPECT_GT(r["channels"]["JOINT_COMMAND"]["compared"].get<int>(), 5000);
}

TEST(SingleSupport, PushedTowardsTheLiftedFootTheHipStrategyHoldsWhatTheAnkleStrategyLoses) {
  // On the right foot, pushed towards the lifted left one (+y) at a 65 N peak, in the paper's
  // posture with the stepping overlay's stiff swing foot and push compensation: the hip strategy
  // swings the lifted leg for momentum about x, but never lower than its clearance above the stance sole
  // (motion_opt.limits.swing_foot.clearance). Swung onto the ground, the foot took load the
  // contact plan knew nothing of and the robot fell over it from 12.5 N s on, where the ankle
  // strategy alone holds 17.8 N s (docs/RESULTS.md, "Single support").
  const std::string push = "--in-process --robot toro --support right --peak 65 --direction 90 --impulse 24" + kPaper +
                           overlay("toro_stepping") + overlay("push_compensation") + " --strategy ";
  const json cam = trial(push + "cam");
  const json ankle = trial(push + "ankle");
  EXPECT_TRUE(cam["recovered"].get<bool>()) << cam.dump();
  EXPECT_FALSE(ankle["recovered"].get<bool>()) << ankle.dump();
  EXPECT_GT(std::abs(cam["peak_cam_Nms"][0].get<double>()), 3.0) << "the hip strategy acted about x";
}

/// Phase-1 onset [s] (negative if phase 1 never started) and peak |l_c^ref| about y [N m s] of a
/// push from behind at the given α, with the trial's figures left in its folder.
std::pair<double, double> fig3_trial(double impulse, double alpha) {
  char tag[64];
  std::snprintf(tag, sizeof(tag), "fig3-%.0fNs-alpha%.0f", impulse, alpha * 10);
  const std::string dir = hpr::test::temp_dir(tag);
  char args[256];
  std::snprintf(args, sizeof(args), "--robot toro --strategy cam --direction 0 --peak 65 --impulse %.1f --alpha %.1f", impulse,
                alpha);
  char title[128];
  std::snprintf(title, sizeof(title), "Fig. 3 scenario: %.0f N s from behind, alpha = %.1f", impulse, alpha);
  const json r = trial(args + kPaper, dir, title);
  EXPECT_TRUE(r["recovered"].get<bool>()) << impulse << " N s, alpha " << alpha << ": " << r.dump();
  const LogData d = read_log(dir + "/run.lcm");
  double start = -1.0, peak = 0.0;
  for (const auto& c : d.cam) {
    if (start < 0 && c.phase[1] == humanoid::cam_reference_t::PHASE_GENERATE) start = static_cast<double>(c.utime) * 1e-6;
    peak = std::max(peak, std::abs(c.l_ref_V[1]));
  }
  std::printf("%.0f N s, alpha %.1f: phase 1 from %.3f s, peak CAM reference %.3f N m s\n", impulse, alpha, start, peak);
  return {start, peak};
}

TEST(PaperExperiments, Fig3ScenarioAtThreeAlphas) {
  // The paper's scenario, 12 N s from behind at α ∈ {0.7, 0.8, 0.9}, figures for each. This robot's
  // soles take the 12 N s push with the ankle torque at about 0.74 of its limit, so only α = 0.7
  // enters phase 1; a larger α activates later or not at all and never generates more CAM.
  double last_start = 0.0, last_peak = 1e9;
  for (const double alpha : {0.7, 0.8, 0.9}) {
    const auto [start, peak] = fig3_trial(12.0, alpha);
    if (alpha < 0.75) {
      EXPECT_GT(start, 0.0) << "phase 1 must start at alpha 0.7";
    }
    if (start > 0) {
      EXPECT_GT(start, last_start);
    }
    EXPECT_LE(peak, last_peak);
    last_start = start > 0 ? start : 1e9;
    last_peak = peak;
  }
  // The same scenario at 18 N s crosses all three thresholds: strictly later and less CAM with α.
  last_start = 0.0;
  last_peak = 1e9;
  for (const double alpha : {0.7, 0.8, 0.9}) {
    const auto [start, peak] = fig3_trial(18.0, alpha);
    ASSERT_GT(start, 0.0) << "phase 1 must start at alpha " << alpha;
    EXPECT_GT(start, last_start);
    EXPECT_LT(peak, last_peak);
    last_start = start;
    last_peak = peak;
  }
}

/// The largest recovered impulses of a sweep, by (strategy, direction).
std::map<std::pair<std::string, double>, double> sweep(const std::string& args, const std::string& dir) {
  std::string out;
  EXPECT_EQ(run(bin("push_sweep") + " " + args + " --jobs 2 --out " + dir, &out), 0) << out;
  std::fprintf(stderr, "%s\n", out.c_str());
  std::ifstream f(dir + "/sweep.json");
  const json j = json::parse(f, nullptr, false);
  std::map<std::pair<std::string, double>, double> m;
  if (j.is_discarded()) {
    ADD_FAILURE() << "no sweep.json in " << dir;
    return m;
  }
  for (const auto& r : j["results"]) m[{r["strategy"].get<std::string>(), r["direction_deg"].get<double>()}] = r["max_recovered_Ns"].get<double>();
  return m;
}

TEST(PushSweep, TheDominanceTableRunsTheThreeControllersOnEveryPushAndChecksThem) {
  // One direction in double support and either foot pushed both ways sideways, at one peak, coarse.
  // The paper's configuration does not step, so "cam" (as configured) and "cam-standing" (stepping
  // turned off) are the same controller: their limits must agree to the bit in every cell.
  const std::string dir = hpr::test::temp_dir("dominance");
  std::string out;
  ASSERT_EQ(run(bin("push_sweep") + " --robot toro --dominance --peaks 65 --angles 0 --max-impulse 40 --resolution 2 --jobs 2"
                " --in-process --out " + dir + kPaper, &out), 0) << out;
  std::ifstream f(dir + "/sweep.json");
  const json j = json::parse(f, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << "no sweep.json in " << dir;
  std::map<std::tuple<std::string, double, std::string>, double> limit;
  for (const auto& r : j["results"]) {
    EXPECT_EQ(r["peak_force_N"].get<double>(), 65.0);
    limit[{r["support"].get<std::string>(), r["direction_deg"].get<double>(), r["strategy"].get<std::string>()}] =
        r["max_recovered_Ns"].get<double>();
  }
  const std::vector<std::pair<std::string, double>> pushes = {{"double", 0}, {"left", 90}, {"left", 270}, {"right", 90}, {"right", 270}};
  ASSERT_EQ(limit.size(), 3 * pushes.size()) << j.dump(1);
  bool ankle_differs = false;
  for (const auto& [support, direction] : pushes) {
    const double cam = limit.at({support, direction, "cam"});
    EXPECT_EQ(cam, limit.at({support, direction, "cam-standing"})) << support << " " << direction;
    ankle_differs = ankle_differs || cam != limit.at({support, direction, "ankle-standing"});
  }
  EXPECT_TRUE(ankle_differs) << "the ankle strategy is another controller";
  std::ifstream md_file(dir + "/dominance.md");
  const std::string md((std::istreambuf_iterator<char>(md_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("### 65 N peak"), std::string::npos) << md;
  EXPECT_NE(md.find("| on the right foot, 270 deg |"), std::string::npos) << md;
  EXPECT_NE(out.find("dominance table: " + dir + "/dominance.md"), std::string::npos) << out;
}

TEST(PushGrid, RunsEveryPushOfTheGridAndListsWhatOneVariantHoldsAndTheOtherLoses) {
  // From behind at 130 N, 20 and 120 N s: the default holds both (docs/RESULTS.md, "The default
  // controller"); standing (stepping off) it holds 20 N s and loses 120 (its limit is 48.5 N s).
  const std::string dir = hpr::test::temp_dir("push-grid");
  std::string out;
  ASSERT_EQ(run("/usr/bin/python3 " + hpr::test::source_dir() + "/tools/push-grid --angles 0 --impulses 20:100:120 --jobs 2"
                " --variant standing=balance.stepping.enabled=false --bin " + hpr::test::bin_dir() + " --out " + dir, &out), 0) << out;
  std::ifstream f(dir + "/grid.json");
  const json j = json::parse(f, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << "no grid.json in " << dir;
  ASSERT_EQ(j["trials"].size(), 4u) << j.dump(1);
  std::map<std::pair<std::string, double>, bool> recovered;
  for (const auto& t : j["trials"]) recovered[{t["variant"].get<std::string>(), t["impulse_Ns"].get<double>()}] = t["recovered"].get<bool>();
  EXPECT_TRUE(recovered.at({"as configured", 20.0}));
  EXPECT_TRUE(recovered.at({"as configured", 120.0}));
  EXPECT_TRUE(recovered.at({"standing", 20.0}));
  EXPECT_FALSE(recovered.at({"standing", 120.0}));
  std::ifstream md_file(dir + "/grid.md");
  const std::string md((std::istreambuf_iterator<char>(md_file)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("| 0 deg | `RR` | `RF` |"), std::string::npos) << md;
  EXPECT_NE(md.find("| recovered | 2 of 2 | 1 of 2 |"), std::string::npos) << md;
  EXPECT_NE(md.find("Held as configured, lost standing (1): 0 deg 120 N s"), std::string::npos) << md;
  EXPECT_NE(md.find("Held standing, lost as configured (0): none"), std::string::npos) << md;
}

/// m ω d of a robot configuration: the largest impulse a point mass at the standing CoM height
/// recovers with its CoP at the sole's edge (less the wbc's CoP margin), the linear inverted
/// pendulum's capture bound for an instantaneous push (ξ = c + ċ/ω reaches the edge).
double lip_bound(const std::string& config_file) {
  const hpr::Config cfg = hpr::Config::load(config_file);
  const hpr::model::RobotSpec spec = hpr::model::RobotSpec::load(cfg.section("robot"));
  hpr::model::Data data(spec.model);
  const Eigen::VectorXd q = spec.standing_configuration();
  const double z = hpr::model::center_of_mass(spec.model, data, q).z();
  const double margin = cfg.section("wbc").section("contact").real_or("cop_margin", 0.005, 0.0, 0.05);
  const double d = 0.5 * spec.feet[0].length - margin;
  return spec.model.mass * hpr::balance::lip_omega(z, -spec.model.gravity.z()) * d;
}

TEST(PaperExperiments, EnvelopeOfBothStrategiesAgainstTheInvertedPendulumsBound) {
  const std::string dir = hpr::test::temp_dir("envelope");
  // Through the in-process pipeline, which gives the processes' messages bit for bit (InProcess.*),
  // in the four directions the test judges (docs/results/paper-configuration.md has all eight).
  // At 1 N s resolution: the checks below have margins of several N s.
  const auto m = sweep("--robot toro --supports double --strategies cam,ankle --directions 4 --resolution 1 --in-process" + kPaper, dir);
  ASSERT_EQ(m.size(), 8U);
  const double bound = lip_bound(hpr::test::source_dir() + "/config/toro.yaml");
  std::printf("m ω d = %.2f N s\n", bound);
  for (double d = 0; d < 360; d += 90) {
    const double cam = m.at({"cam", d}), ankle = m.at({"ankle", d});
    std::printf("%5.0f deg: CAM %.2f N s, ankle %.2f N s (x%.2f)\n", d, cam, ankle, cam / ankle);
  }
  // The ankle strategy alone gets the point mass's bound in both sagittal directions (a push that
  // lasts 0.6 s is a little easier than an instantaneous one): its wrench distribution wastes no
  // friction or CoP range on internal forces (it recovered 0.75 of it from behind when it did).
  for (double d : {0.0, 180.0}) EXPECT_GE(m.at({"ankle", d}), 0.95 * bound) << d << " deg";
  // From the front the hip strategy recovers more than the ankle strategy alone (42.5 against
  // 35.9 N s); from behind it loses to it (28.1 against 32.7 N s,
  // docs/results/paper-configuration.md), and both stay beyond the bound.
  EXPECT_GT(m.at({"cam", 180.0}), m.at({"ankle", 180.0})) << "from the front";
  for (double d : {0.0, 180.0}) EXPECT_GT(m.at({"cam", d}), bound) << d << " deg";
  // Sideways both hold every push tried (80 N s).
  for (double d : {90.0, 270.0}) {
    EXPECT_GE(m.at({"cam", d}), 80.0) << d << " deg";
    EXPECT_GE(m.at({"ankle", d}), 80.0) << d << " deg";
  }
  EXPECT_TRUE(fs::exists(dir + "/sweep.png"));
}

TEST(Robustness, CamBeatsTheAnkleStrategyWhenTheTrunkIsNotWhereTheModelSaysTheDrivesLagAndTheSensorsAreNoisy) {
  // The paper's claim that the hip strategy makes the robot more robust to model uncertainty, at
  // three mismatches from docs/results/paper-configuration.md, each at an impulse from the front
  // between the two strategies' largest recovered ones: the simulated trunk's centre of mass 2 cm ahead of the
  // controllers' model (CAM 45.62, ankle 39.81 N s), a 2 ms extra actuation delay (CAM 40.61, ankle
  // 35.33 N s) and the simulated sensors' noise (CAM 37.44, ankle 33.75 N s). In process (the
  // processes' messages bit for bit).
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"'sim.model_error=[{body: torso, com_offset: [0.02, 0, 0]}]'", "42.5"},
      {"sim.actuation_delay_ticks=2", "38"},
      {"sim.noise.enabled=true", "35.5"}};
  for (const auto& [mismatch, impulse] : cases) {
    const std::string args = "--in-process --robot toro --support double --direction 180 --peak 65 --impulse " + impulse + kPaper + " --set " + mismatch;
    const json ankle = trial(args + " --strategy ankle");
    const json cam = trial(args + " --strategy cam");
    EXPECT_FALSE(ankle["recovered"].get<bool>()) << mismatch << ": " << ankle.dump();
    EXPECT_TRUE(cam["recovered"].get<bool>()) << mismatch << ": " << cam.dump();
  }
}

TEST(Robustness, StandingLowerWithALeanBudgetTheHipStrategyBeatsTheAnkleStrategyFromBehindUnderMismatch) {
  // Knees bent (config/overlays/toro_knees_bent.yaml) with the lean budget [6, 10] about y, the CAM
  // strategy's lead from behind survives every mismatch of docs/results/paper-configuration.md
  // (1.26 to 1.54 times the ankle strategy's limit). Two of them, each at an impulse from behind between the strategies'
  // limits: the simulated trunk's CoM 2 cm ahead of the model (CAM 44.0, ankle 32.0 N s) and the
  // simulated sensors' noise (CAM 37.2, ankle 27.4 N s).
  const std::string posture = kPaper + overlay("toro_knees_bent") +
                              " --set reference_gen.y.lean_budget_negative=6 --set reference_gen.y.lean_budget_positive=10";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"'sim.model_error=[{body: torso, com_offset: [0.02, 0, 0]}]'", "38"}, {"sim.noise.enabled=true", "32"}};
  for (const auto& [mismatch, impulse] : cases) {
    const std::string args = "--in-process --robot toro --support double --direction 0 --peak 65 --impulse " + impulse + posture + " --set " + mismatch;
    const json ankle = trial(args + " --strategy ankle");
    const json cam = trial(args + " --strategy cam");
    EXPECT_FALSE(ankle["recovered"].get<bool>()) << mismatch << ": " << ankle.dump();
    EXPECT_TRUE(cam["recovered"].get<bool>()) << mismatch << ": " << cam.dump();
  }
}

TEST(LeanBudget, TheBoundedReferenceRecoversSagittalPushesBothStrategiesLoseAsConfigured) {
  // config/overlays/toro_lean_budget.yaml bounds the episode's ∫ l_c^ref dt about y (2.5 N m s² for
  // a push from behind, 12 from the front). The largest pushes the CAM strategy recovers go from
  // 28.1 to 36.9 N s from behind and from 42.5 to 53.8 N s from the front; the ankle strategy's are
  // 32.7 and 35.9 (docs/results/paper-configuration.md). At 35 N s from behind and 50 N s from the
  // front both strategies of the paper's configuration fall, and the CAM strategy with the budget
  // recovers.
  const std::string budget = overlay("toro_lean_budget");
  for (const auto& [direction, impulse] : std::vector<std::pair<std::string, std::string>>{{"0", "35"}, {"180", "50"}}) {
    const std::string push = "--in-process --robot toro --support double --peak 65 --direction " + direction + " --impulse " + impulse + kPaper;
    const std::string which = direction + " deg " + impulse + " N s";
    const json configured = trial(push + " --strategy cam");
    const json ankle = trial(push + " --strategy ankle");
    const json bounded = trial(push + budget + " --strategy cam");
    EXPECT_FALSE(configured["recovered"].get<bool>()) << which << ": " << configured.dump();
    EXPECT_FALSE(ankle["recovered"].get<bool>()) << which << ": " << ankle.dump();
    EXPECT_TRUE(bounded["recovered"].get<bool>()) << which << ": " << bounded.dump();
  }
}

TEST(KneesBent, StandingLowerTheHipStrategyRecoversPushesFromBehindTheConfiguredPostureLoses) {
  // config/overlays/toro_knees_bent.yaml (CoM 0.87 m instead of 0.93 m, base pitch within
  // ±0.55 rad): the largest push from behind the CAM strategy recovers goes from 28.1 to 42.2 N s,
  // the ankle strategy's in the same posture from 32.7 to 35.6 N s
  // (docs/results/paper-configuration.md). At 37 N s the paper's posture stretches the knees and
  // loses it; standing lower, the CAM strategy recovers it and the ankle strategy does not.
  const std::string push = "--in-process --robot toro --support double --direction 0 --peak 65 --impulse 37" + kPaper;
  const std::string knees = overlay("toro_knees_bent");
  const json configured = trial(push + " --strategy cam");
  const json ankle = trial(push + knees + " --strategy ankle");
  const json cam = trial(push + knees + " --strategy cam");
  EXPECT_FALSE(configured["recovered"].get<bool>()) << configured.dump();
  EXPECT_FALSE(ankle["recovered"].get<bool>()) << ankle.dump();
  EXPECT_TRUE(cam["recovered"].get<bool>()) << cam.dump();
}

TEST(PushCompensation, BothStrategiesHoldSteadyPushesTheirCoMImpedanceLoses) {
  // Under a steady horizontal force F at height h the paper's configuration holds the CoM F / K_com
  // ahead of its reference, so the CoP has to sit F (1 / K_com + h / (m g)) ahead of the ankles: a
  // 4 s push holds up to 44 N from behind with either strategy (docs/results/paper-configuration.md,
  // "Steady pushes").
  // balance.push_compensation cancels the observed force in the CoM wrench the wbc asks for, which
  // leaves F h / (m g): 60 N for 4 s from behind is then held by both strategies, and so is a
  // 60 N s push of the envelope's 65 N peak from the front, which both lose without it (limits
  // 42.5 and 35.9 N s).
  const std::string on = " --set balance.push_compensation.enabled=true";
  for (const std::string& push : {std::string("--direction 0 --peak 60 --duration 4"), std::string("--direction 180 --peak 65 --impulse 60")}) {
    for (const std::string strategy : {"cam", "ankle"}) {
      const std::string args = "--in-process --robot toro --support double --strategy " + strategy + " " + push + kPaper;
      const json configured = trial(args);
      const json compensated = trial(args + on);
      EXPECT_FALSE(configured["recovered"].get<bool>()) << strategy << " " << push << ": " << configured.dump();
      EXPECT_TRUE(compensated["recovered"].get<bool>()) << strategy << " " << push << ": " << compensated.dump();
      EXPECT_LT(compensated["max_foot_tilt_deg"].get<double>(), 1.0) << strategy << " " << push;
    }
  }
}

TEST(PhysicsStep, TheConfiguredStepGivesTheOutcomeOfAStepFourTimesFiner) {
  // Pushes near the sagittal limits, where one 1 ms physics step with 10 contact solver iterations
  // gave another outcome (CAM 40 N s from the front fell, ankle 31 N s from behind did not come
  // back; docs/results/paper-configuration.md, "The physics step"): at the configured step (2
  // sub-steps, 20 iterations) each comes out as with 8 sub-steps, and its posture returns at the
  // same time.
  for (const auto& [strategy, direction, impulse] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"cam", "180", "40"}, {"ankle", "0", "31"}}) {
    const std::string args = "--in-process --robot toro --support double --peak 65 --strategy " + strategy + " --direction " + direction + " --impulse " + impulse + kPaper;
    const json configured = trial(args);
    const json fine = trial(args + " --set sim.substeps=8");
    const std::string which = strategy + " " + direction + " deg " + impulse + " N s";
    ASSERT_TRUE(fine["recovered"].get<bool>()) << which << ": " << fine.dump();
    ASSERT_TRUE(configured["recovered"].get<bool>()) << which << ": " << configured.dump();
    EXPECT_NEAR(configured["return_time_s"].get<double>(), fine["return_time_s"].get<double>(), 0.05) << which;
  }
}

/// A robot's default as shipped, pushed at a 130 N peak from behind: `stepped` N s is recovered by
/// stepping where both single strategies (stepping off, the same posture) fall; `held` N s is held
/// standing, without a step.
void expect_steps_where_both_standing_strategies_fall(const std::string& robot, const std::string& stepped,
                                                      const std::string& held) {
  const std::string push = "--in-process --robot " + robot + " --support double --peak 130 --direction 0 --impulse ";
  const json by_step = trial(push + stepped + " --strategy cam");
  const json cam = trial(push + stepped + " --strategy cam-standing");
  const json ankle = trial(push + stepped + " --strategy ankle-standing");
  EXPECT_TRUE(by_step["recovered"].get<bool>()) << robot << ": " << by_step.dump();
  EXPECT_GE(by_step["steps"].get<int>(), 1) << robot << ": " << by_step.dump();
  EXPECT_FALSE(cam["recovered"].get<bool>()) << robot << ": " << cam.dump();
  EXPECT_FALSE(ankle["recovered"].get<bool>()) << robot << ": " << ankle.dump();
  const json standing = trial(push + held + " --strategy cam");
  EXPECT_TRUE(standing["recovered"].get<bool>()) << robot << ": " << standing.dump();
  EXPECT_EQ(standing["steps"].get<int>(), 0) << robot << ": " << standing.dump();
  EXPECT_EQ(standing["steps_started"].get<int>(), 0) << robot << ": " << standing.dump();
}

/// The push `push` (push_trial's arguments) is recovered as configured with `field` of its result
/// below `configured_below`, and lost with the override `set` (key=value), `field` above `set_above`.
void expect_held_as_configured_and_lost_with(const std::string& push, const std::string& set, const std::string& field,
                                             double configured_below, double set_above) {
  const json configured = trial(push);
  const json changed = trial(push + " --set " + set);
  EXPECT_TRUE(configured["recovered"].get<bool>()) << configured.dump();
  EXPECT_LT(configured[field].get<double>(), configured_below) << configured.dump();
  EXPECT_FALSE(changed["recovered"].get<bool>()) << set << ": " << changed.dump();
  EXPECT_GT(changed[field].get<double>(), set_above) << set << ": " << changed.dump();
}

/// The push `push` is held as configured without a step begun, and lost with the override `set`
/// after at least one.
void expect_held_standing_and_stepped_and_lost_with(const std::string& push, const std::string& set) {
  expect_held_as_configured_and_lost_with(push, set, "steps_started", 0.5, 0.5);
}

TEST(DefaultController, StepsWhereBothStandingStrategiesFallAndStandsThroughASmallerPush) {
  // config/toro.yaml as shipped: ankle, hip and step. At a 130 N peak from behind (docs/RESULTS.md,
  // "The default controller": the default holds a push of 120 N s, the CAM strategy standing 48.5
  // and the ankle strategy standing 39.8 N s), 55 N s: the default recovers by stepping where
  // both single strategies, in the same posture, fall. 20 N s: it holds standing, without a step.
  expect_steps_where_both_standing_strategies_fall("toro", "55", "20");
}

TEST(DefaultController, ALightlyLoadedSoleHoldsNoTorsionAboutItsLoadedCorner) {
  // 47 N s from the front and the left (135 deg, 130 N peak): the right sole carries 44-83 N with
  // its CoP at its inner heel corner. Bounded by torsion x f_z wherever its CoP is
  // (wbc.contact.sole_torsion false), the wbc asks that sole for a torsion its corners cannot hold,
  // it turns about the loaded corner and slides past 1 cm; bounded by what its four corners hold (as
  // configured) it holds (docs/notes/2026-12-01-sole-torsion.md).
  expect_held_as_configured_and_lost_with(
      "--in-process --robot toro --support double --peak 130 --direction 135 --impulse 47 --strategy cam",
      "wbc.contact.sole_torsion=false", "max_sole_slip_m", 0.01, 0.01);
}

TEST(DefaultController, TheTrailingFootFollowsOnlyOnceTheCapturePointIsOverTheLandedSole) {
  // 33.75 N s from the front and the right (225 deg, 260 N peak): one step sideways. Right after
  // touchdown the CoM swings over the landed foot and the trailing foot unloads for a moment; a
  // follow step begun then (balance.stepping.follow_reach 1 m: whatever the capture point) lifts the
  // foot the CoM swings back onto, and the robot walks in place, one follow step after another,
  // without coming to rest. With the capture point required over the landed sole (as configured)
  // the DCM settles between the feet and no follow step is taken.
  const std::string push = "--in-process --robot toro --support double --peak 260 --direction 225 --impulse 33.75 --strategy cam";
  const json configured = trial(push);
  const json eager = trial(push + " --set balance.stepping.follow_reach=1");
  EXPECT_TRUE(configured["recovered"].get<bool>()) << configured.dump();
  EXPECT_EQ(configured["steps"].get<int>(), 1) << configured.dump();
  EXPECT_EQ(configured["follow_steps"].get<int>(), 0) << configured.dump();
  EXPECT_FALSE(eager["recovered"].get<bool>()) << eager.dump();
  EXPECT_GE(eager["follow_steps"].get<int>(), 3) << eager.dump();
}

TEST(SecondRobot, H1StandsAndRecoversAPushItsAnkleStrategyDoesNot) {
  // Configuration only (config/h1_2.yaml), in the paper's configuration (config/overlays/paper.yaml)
  // and through the processes. The impulse sits between the two strategies' limits from the front
  // (see docs/RESULTS.md for the sweep that found them).
  const std::string args = "--robot h1_2" + overlay("paper") + " --support double --direction 180 --peak 65 --impulse ";
  const json stand = trial(args + "1 --strategy cam");
  EXPECT_TRUE(stand["recovered"].get<bool>()) << "stands: " << stand.dump();
  const std::string impulse = HPR_H1_TEST_IMPULSE;
  const json ankle = trial(args + impulse + " --strategy ankle");
  const json cam = trial(args + impulse + " --strategy cam", hpr::test::temp_dir("h1-cam"), "H1-2: push from the front, CAM strategy");
  EXPECT_FALSE(ankle["recovered"].get<bool>()) << ankle.dump();
  EXPECT_TRUE(cam["recovered"].get<bool>()) << cam.dump();
}

TEST(SecondRobot, H1DefaultStepsWhereBothStandingStrategiesFallAndStandsThroughASmallerPush) {
  // config/h1_2.yaml as shipped: ankle, hip and step. At a 130 N peak from behind (docs/RESULTS.md,
  // "The default controller (H1-2)": the CAM strategy standing holds 38.8 N s, the ankle strategy standing
  // 34.3), 50 N s: the default recovers by stepping where both single strategies, in the same
  // posture, fall. 20 N s: it holds standing, without a step. Sideways, 80 N s: the H1-2 holds it
  // standing and the default takes no step (it stepped and fell with the reach ahead beside the soles).
  expect_steps_where_both_standing_strategies_fall("h1_2", "50", "20");
  expect_held_standing_and_stepped_and_lost_with(
      "--in-process --robot h1_2 --support double --peak 130 --direction 90 --impulse 80 --strategy cam",
      "balance.stepping.cmp_reach_sideways=0.02");
}

TEST(SecondRobot, H1DiagonalPushLoadsASoleCornerTheHipStrategyHoldsItWithItsCoPACentimetreInside) {
  // 24 N s at 45 deg, 130 N peak, standing: the CoP of the front left sole goes to its corner. With
  // the CoP bounded 5 mm inside the soles (the paper's wbc.contact.cop_margin) the hip strategy
  // tilts that sole past 2 deg and loses the push the ankle strategy alone holds (24.96 N s); 1 cm
  // inside (as configured) it holds it with the sole flat.
  expect_held_as_configured_and_lost_with(
      "--in-process --robot h1_2 --support double --peak 130 --direction 45 --impulse 24 --strategy cam-standing",
      "wbc.contact.cop_margin=0.005", "max_foot_tilt_deg", 1.0, 2.0);
}

TEST(ThirdRobot, G1AsPublishedStandsAndRecoversFromBehindAndTheFront) {
  // config/g1.yaml's robot section as `hpr_robot init` wrote it from the published URDF (meshes,
  // sphere feet, the fingers held), in the paper's configuration (config/overlays/paper.yaml). From
  // the front the impulse sits between the two strategies' limits; from behind the two strategies'
  // limits depend on the physics step (docs/RESULTS.md) and the test asks for a recovery below both.
  // The 30 s stand runs in process (the processes' messages bit for bit, `InProcess.*`), the pushes
  // through the processes.
  const std::string args = "--robot g1" + kPaper + " --support double --peak 65 ";
  const json stand = trial("--in-process " + args + "--direction 0 --impulse 1 --push-time 30 --strategy cam");
  EXPECT_TRUE(stand["recovered"].get<bool>()) << "stands 30 s: " << stand.dump();
  EXPECT_GE(stand["push_start_s"].get<double>(), 30.0);
  const json behind = trial(args + "--direction 0 --impulse " HPR_G1_TEST_IMPULSE_BEHIND " --strategy cam",
                            hpr::test::temp_dir("g1-cam-0"), "G1: push from behind, CAM strategy");
  EXPECT_TRUE(behind["recovered"].get<bool>()) << behind.dump();
  const std::string front = args + "--direction 180 --impulse " HPR_G1_TEST_IMPULSE_FRONT;
  const json ankle = trial(front + " --strategy ankle");
  const json cam = trial(front + " --strategy cam", hpr::test::temp_dir("g1-cam-180"), "G1: push from the front, CAM strategy");
  EXPECT_FALSE(ankle["recovered"].get<bool>()) << ankle.dump();
  EXPECT_TRUE(cam["recovered"].get<bool>()) << cam.dump();
}

TEST(ThirdRobot, G1DefaultStepsWhereBothStandingStrategiesFallAndStandsThroughASmallerPush) {
  // config/g1.yaml as shipped: ankle, hip and step. At a 130 N peak from behind (docs/RESULTS.md,
  // "The default controller (G1)": the default holds 29.88 N s, the CAM strategy standing 11.88 and
  // the ankle strategy standing 11.25), 20 N s: the default recovers by stepping where both single
  // strategies, in the same posture, fall. 5 N s: it holds standing, without a step (it steps from
  // 7 N s on). Sideways, 18 N s: the G1 holds it standing (19.22 N s) and the default takes no
  // step; with the H1-2's 8 cm reach beside the soles it steps and falls (the push's force shifts
  // the capture point by F / (m w^2), 24 cm at 130 N on this 34 kg robot).
  expect_steps_where_both_standing_strategies_fall("g1", "20", "5");
  expect_held_standing_and_stepped_and_lost_with(
      "--in-process --robot g1 --support double --peak 130 --direction 90 --impulse 18 --strategy cam",
      "balance.stepping.cmp_reach_sideways=0.08");
}

TEST(Onboarding, ABipedAsPublishedIsInitialisedStandsAndRecoversPushesFromBehindAndTheFront) {
  // The fixture biped (tests/unit/onboard/fixtures/make_biped.py) as a clone would hold it: the
  // package biped_description in a folder of another name, feet a mesh turned 90 deg in the link,
  // the IMU on the torso. `hpr_robot init --verify` with no hand edit and no mesh option: the file
  // it writes loads, the robot stands 10 s through the processes, and each strategy recovers from
  // behind and from the front at least 0.4 m w d (measured: 0.49 to 0.85); `--tune` with one
  // evaluation writes its overlay, which push_trial takes.
  const fs::path root = hpr::test::temp_dir("onboarding");
  fs::remove_all(root / "biped-description-main");
  fs::copy(hpr::test::source_dir() + "/tests/unit/onboard/fixtures/biped-description-main", root / "biped-description-main",
           fs::copy_options::recursive);
  const std::string cfg = (root / "config/biped.yaml").string();
  std::string out;
  ASSERT_EQ(run("cd " + root.string() + " && " + bin("hpr_robot") +
                    " init biped-description-main/urdf/biped.urdf --out config/biped.yaml --force --verify --jobs 2 --tune "
                    "--tune-evaluations 1",
                &out),
            0)
      << out;
  std::fprintf(stderr, "%s\n", out.c_str());
  EXPECT_NE(out.find("IMU at link 'imu_link'"), std::string::npos);
  EXPECT_NE(out.find("verify: stood 10 s"), std::string::npos);
  const auto bound_at = out.find("m w d = ");
  ASSERT_NE(bound_at, std::string::npos);
  const double bound = std::stod(out.substr(out.find(" = ", bound_at + 8) + 3));
  int rows = 0;
  for (const char* from : {"behind", "front"}) {
    for (const char* who : {"default (CAM strategy)", "ankle strategy alone"}) {
      const auto at = out.find(std::string("  ") + from + std::string(9 - std::string(from).size(), ' ') + who);
      ASSERT_NE(at, std::string::npos) << from << " " << who;
      const double largest = std::stod(out.substr(at + 2 + 9 + std::string(who).size()));
      std::printf("%s, %s: %.2f N s (%.2f m w d)\n", from, who, largest, largest / bound);
      EXPECT_GE(largest, 0.4 * bound) << from << " " << who;
      ++rows;
    }
  }
  EXPECT_EQ(rows, 4);
  const std::string overlay = (root / "config/biped.tuned.yaml").string();
  ASSERT_TRUE(fs::exists(overlay)) << out;
  const json tuned = trial("--in-process --robot " + cfg + " --overlay " + overlay + " --stand 5");
  EXPECT_EQ(tuned["outcome"], "stood") << tuned.dump();
  // The same robot with inertias only: init guesses the soles (and says so), the simulator stands
  // each foot on its configured sole, and the robot stands.
  ASSERT_EQ(run(bin("hpr_robot") + " init " + hpr::test::source_dir() + "/tests/unit/onboard/fixtures/inertias_only.urdf --out " +
                    (root / "config/inertias_only.yaml").string() + " --force",
                &out),
            0)
      << out;
  EXPECT_NE(out.find("warning: the foot link 'r_foot' has no collision geometry"), std::string::npos) << out;
  const json bare = trial("--in-process --robot " + (root / "config/inertias_only.yaml").string() + " --stand 5");
  EXPECT_EQ(bare["outcome"], "stood") << bare.dump();
}

}  // namespace
