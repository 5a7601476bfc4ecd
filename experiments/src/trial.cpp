#include "hpr/experiments/trial.hpp"

#include <fmt/format.h>
#include <humanoid/health_t.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <set>
#include <yaml-cpp/yaml.h>

#include "hpr/common/args.hpp"
#include "hpr/common/config.hpp"
#include "hpr/launch/process_group.hpp"
#include "hpr/model/algorithms.hpp"
#include "hpr/msg/channels.hpp"
#include "hpr/node/lcm_url.hpp"

namespace hpr::experiments {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

bool overrides_enable_steps(const std::vector<std::string>& overrides, bool configured) {
  bool on = configured;
  for (const std::string& o : overrides) {
    if (o.rfind("balance.stepping.enabled=", 0) == 0) on = o.substr(o.find('=') + 1) == "true";
  }
  return on;
}

bool steps_enabled(const TrialSpec& spec) {
  const Config c = Config::load(spec.config, spec.overrides);
  if (!c.has("balance") || !c.section("balance").has("stepping")) return false;
  return c.section("balance").section("stepping").boolean_or("enabled", false);
}

std::string find_in_config_dirs(const std::string& relative) {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("HPR_CONFIG_DIR")) dirs.emplace_back(env);
  const fs::path exe = launch::executable_dir();
  dirs.push_back(exe / ".." / ".." / "config");       // build tree: build/bin
  dirs.push_back(exe / ".." / "share" / "hpr" / "config");  // installed: prefix/bin
  std::string searched;
  for (const auto& d : dirs) {
    const fs::path p = d / relative;
    if (fs::exists(p)) return fs::canonical(p).string();
    searched += " " + p.lexically_normal().string();
  }
  throw std::runtime_error("no " + relative + " (looked for" + searched + ")");
}

std::string find_config(const std::string& robot) {
  if (robot.find('/') != std::string::npos || robot.ends_with(".yaml")) {
    if (fs::exists(robot)) return fs::absolute(robot).string();
    throw std::runtime_error("configuration file '" + robot + "' not found");
  }
  try {
    return find_in_config_dirs(robot + ".yaml");
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("no configuration for robot '" + robot + "': " + e.what());
  }
}

const char* const kOutcomeLegend =
    "outcomes (judged from 5 s after the push ends; a standing trial from when the push would have come):\n"
    "  recovered     no fall; stance soles flat (tilt < 2 deg) and in place (slip < 1 cm); CoM, base and every\n"
    "                free joint back within 1 cm and 1 deg of the pre-push posture within 5 s (with stepping:\n"
    "                the same until the first step lands; from 50 ms before its lift-off the soles may move,\n"
    "                and the robot must come to rest on flat soles, base within 5 deg, wherever it stepped)\n"
    "  stood         the same for a trial without a push\n"
    "  fell          the simulator saw the robot fall\n"
    "  tilted        a stance sole rolled onto an edge (tilt of 2 deg or more)\n"
    "  slipped       a stance sole slid 1 cm or more\n"
    "  unsettled     still standing on flat soles, but not back in the posture within 5 s\n"
    "  inconclusive  the run ended before the verdict (nothing decided yet); a sweep runs it again\n"
    "  error         the run itself failed (a process, the configuration): no verdict\n"
    "  CoP margin    the smallest distance of a loaded stance sole's centre of pressure inside the sole\n"
    "                rectangle the controllers use (robot.feet.*.sole_size); negative: on the part of the\n"
    "                collision geometry the rectangle leaves out. A measurement, not a criterion: a sole\n"
    "                whose pressure reaches the real edge rolls about it, which the tilt judges.\n";

double TrialSpec::push_duration() const {
  if (standing()) return 0.0;
  if (duration > 0.0) return duration;
  return impulse * M_PI / (2.0 * peak);
}

namespace {

/// Collects the run's messages into the evaluator and watches HEALTH for readiness.
class Listener {
 public:
  Listener(lcm::LCM& lcm, TrialEvaluator& eval) : eval_(eval) {
    // The evaluation sees every tick.
    lcm.subscribe(hpr::msg::channels::kSimTruth.name, &Listener::truth, this)->setQueueCapacity(node::kCountingQueueCapacity);
    lcm.subscribe(hpr::msg::channels::kRobotSensors.name, &Listener::sensors, this)->setQueueCapacity(node::kCountingQueueCapacity);
    lcm.subscribe(hpr::msg::channels::kWholebodyCommand.name, &Listener::wholebody, this)->setQueueCapacity(node::kCountingQueueCapacity);
    lcm.subscribe(hpr::msg::channels::kHealth.name, &Listener::health, this);
  }
  void truth(const lcm::ReceiveBuffer*, const std::string&, const humanoid::sim_truth_t* m) { eval_.on_truth(*m); }
  void sensors(const lcm::ReceiveBuffer*, const std::string&, const humanoid::robot_sensors_t* m) { eval_.on_sensors(*m); }
  void wholebody(const lcm::ReceiveBuffer*, const std::string&, const humanoid::wholebody_command_t* m) { eval_.on_wholebody(*m); }
  void health(const lcm::ReceiveBuffer*, const std::string&, const humanoid::health_t* m) { seen_.insert(m->node); }
  [[nodiscard]] bool seen(const std::string& node) const { return seen_.count(node) != 0; }

 private:
  TrialEvaluator& eval_;
  std::set<std::string> seen_;
};

}  // namespace

TrialWatch::TrialWatch(const TrialSpec& spec, const TrialEvaluator& eval, double push_start, double push_end,
                       std::function<void(const std::string&)> progress, std::chrono::steady_clock::time_point start)
    : spec_(spec), eval_(eval), push_start_(push_start), push_end_(push_end), progress_(std::move(progress)),
      start_(start),
      deadline_(start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(spec.timeout))) {}

bool TrialWatch::stop() {
  const double t = eval_.last_time();
  if (progress_ && t >= next_report_) {
    progress_(fmt::format("  t = {:5.2f} s{}", t, t >= push_start_ && t < push_end_ ? "  (push)" : ""));
    next_report_ = std::floor(t) + 1.0;
  }
  if (eval_.fallen()) {
    if (progress_) progress_(fmt::format("  fell at t = {:.2f} s", t));
    return true;
  }
  if (spec_.stop_when_decided && eval_.failed()) {
    if (progress_) progress_(fmt::format("  not recoverable at t = {:.2f} s: stopped", t));
    return true;
  }
  if (std::chrono::steady_clock::now() > deadline_) {
    timed_out_ = true;
    return true;
  }
  return false;
}

TrialResult TrialWatch::result() const {
  TrialResult r = eval_.result();
  if (timed_out_) r.failure += (r.failure.empty() ? "" : "; ") + fmt::format("timed out after {:.0f} s", spec_.timeout);
  r.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  return r;
}

std::string dated_name(const std::string& prefix) {
  const auto t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof(buf), "-%Y%m%d-%H%M%S", std::localtime(&t));
  return prefix + buf;
}

TrialPlan plan_trial(const TrialSpec& spec) {
  TrialPlan plan;
  plan.config = find_config(spec.config);
  const Config cfg = Config::load(plan.config, spec.overrides);
  plan.robot = std::make_shared<const model::RobotSpec>(model::RobotSpec::load(cfg.section("robot")));
  const model::RobotSpec& robot = *plan.robot;
  if (cfg.section("sim").string_or("engine", "bullet") == "mujoco") plan.sim_process = "sim_mujoco";
  if (spec.support != "double" && spec.support != "left" && spec.support != "right") {
    throw std::invalid_argument("support '" + spec.support + "': expected double, left or right");
  }
  if (!spec.standing() && (!(spec.peak > 0.0) || !(spec.push_duration() > 0.0))) {
    throw std::invalid_argument("the push needs a positive peak force and duration (or impulse and duration 0: no push)");
  }
  // When the push comes: 1 s after the support is settled.
  const Config balance = cfg.section("balance");
  double settled = balance.real_or("init_time", 1.0);
  if (spec.support != "double") settled += balance.real_or("shift_time", 1.2) + balance.real_or("lift_time", 0.6);
  plan.push.id = 1;
  plan.push.start = spec.push_time > 0.0 ? spec.push_time : settled + 1.0;
  plan.push.duration = spec.push_duration();
  plan.push.profile = sim::Push::Profile::kHalfSine;
  // The push point: on the link (default the base), at the requested height above the ground in
  // the standing posture.
  plan.push.link = spec.link.empty() ? robot.model.body_name[0] : spec.link;
  const int frame = robot.model.frame_index(plan.push.link);
  if (spec.height) {
    model::Data data(robot.model);
    model::forward_kinematics(robot.model, data, robot.standing_configuration());
    const model::SE3& X = model::update_frame_placement(robot.model, data, frame);
    plan.push.point_L = X.R.transpose() * Eigen::Vector3d(0.0, 0.0, *spec.height - X.p.z());
  }
  const double th = spec.direction_deg * M_PI / 180.0;
  plan.push.force_W = spec.peak * Eigen::Vector3d(std::cos(th), std::sin(th), 0.0);
  // The numbers as the scenario file carries them to the simulator (6 decimals), so that every
  // way of running the trial pushes alike.
  const auto carried = [](double x) { return std::stod(fmt::format("{:.6f}", x)); };
  for (int i = 0; i < 3; ++i) {
    plan.push.point_L(i) = carried(plan.push.point_L(i));
    plan.push.force_W(i) = i < 2 ? carried(plan.push.force_W(i)) : 0.0;
  }
  plan.push.start = carried(plan.push.start);
  plan.push.duration = carried(plan.push.duration);
  plan.sim_duration = plan.push.start + plan.push.duration + spec.after + 0.01;
  // Every process's overrides, in this order.
  plan.overrides = {"balance.support=" + spec.support};
  plan.overrides.insert(plan.overrides.end(), spec.overrides.begin(), spec.overrides.end());
  if (spec.alpha) plan.overrides.push_back(fmt::format("reference_gen.alpha={}", *spec.alpha));
  if (spec.beta) plan.overrides.push_back(fmt::format("reference_gen.beta={}", *spec.beta));
  return plan;
}

namespace {

/// The simulator's scenario file for the plan's push (none for a standing trial); its path.
std::string write_scenario(const TrialSpec& spec, const TrialPlan& plan, const std::string& work) {
  const std::string scenario = work + "/push.yaml";
  std::ofstream f(scenario);
  if (spec.standing()) {
    f << "pushes: []\n";
  } else {
    const Eigen::Vector3d& p = plan.push.point_L;
    const Eigen::Vector3d& force = plan.push.force_W;
    f << fmt::format("pushes:\n  - {{link: {}, point: [{:.6f}, {:.6f}, {:.6f}], force: [{:.6f}, {:.6f}, 0.0], start: {:.6f}, "
                     "duration: {:.6f}, profile: half_sine}}\n",
                     plan.push.link, p.x(), p.y(), p.z(), force.x(), force.y(), plan.push.start, plan.push.duration);
  }
  return scenario;
}

/// Waits up to 20 s for every controller's HEALTH (each subscribed before the simulator publishes
/// tick 0); otherwise says which did not start, with the end of its log.
void wait_for_controllers(lcm::LCM& lcm, const Listener& listener, const std::vector<std::string>& nodes, const std::string& work) {
  const auto ready_deadline = std::chrono::steady_clock::now() + 20s;
  auto all_ready = [&] {
    return std::all_of(nodes.begin(), nodes.end(), [&](const std::string& n) { return listener.seen(n); });
  };
  while (!all_ready() && std::chrono::steady_clock::now() < ready_deadline) lcm.handleTimeout(50);
  if (all_ready()) return;
  std::string msg = "the controllers did not start:";
  for (const auto& n : nodes) {
    if (listener.seen(n)) continue;
    msg += "\n  " + n + " (no HEALTH within 20 s); the end of " + work + "/" + n + ".log:";
    std::ifstream f(work + "/" + n + ".log");
    std::vector<std::string> lines;
    for (std::string line; std::getline(f, line);) lines.push_back(line);
    for (size_t i = lines.size() > 5 ? lines.size() - 5 : 0; i < lines.size(); ++i) msg += "\n    " + lines[i];
  }
  throw std::runtime_error(msg);
}

/// Drains what is still in flight. When the simulator has finished, until the evaluation has its
/// last tick (on a loaded machine this listener may trail the lockstep chain by a second), or its
/// time stops advancing (HEALTH keeps arriving, so silence never comes).
void drain(lcm::LCM& lcm, const TrialEvaluator& eval, bool sim_running, double sim_duration) {
  if (sim_running) {
    for (int i = 0; i < 5; ++i) lcm.handleTimeout(10);
    return;
  }
  const double last_tick_time = sim_duration - 1.5e-3;
  auto progress_at = std::chrono::steady_clock::now();
  double seen = eval.last_time();
  while (eval.last_time() < last_tick_time && std::chrono::steady_clock::now() - progress_at < 500ms) {
    lcm.handleTimeout(50);
    if (eval.last_time() > seen) {
      seen = eval.last_time();
      progress_at = std::chrono::steady_clock::now();
    }
  }
}

}  // namespace

TrialResult run_trial(const TrialSpec& spec, const std::function<void(const std::string&)>& progress) {
  if (spec.in_process) return run_trial_in_process(spec, progress);
  if (spec.truth_state) throw std::invalid_argument("--truth-state needs --in-process (the processes run the estimator)");
  const auto wall0 = std::chrono::steady_clock::now();
  const TrialPlan plan = plan_trial(spec);
  const double t_push = plan.push.start;
  const double t_end = t_push + plan.push.duration;

  std::string work = spec.work_dir;
  if (work.empty()) {
    work = (fs::temp_directory_path() / fmt::format("hpr-trial-{}-{}", ::getpid(), wall0.time_since_epoch().count())).string();
  }
  fs::create_directories(work);
  const std::string scenario = write_scenario(spec, plan, work);
  std::vector<std::string> common = {"--config", plan.config};
  for (const auto& o : plan.overrides) {
    common.emplace_back("--set");
    common.push_back(o);
  }
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = common;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };

  launch::ProcessGroup group(spec.lcm_url.empty() ? launch::unique_lcm_url() : spec.lcm_url);
  const std::unique_ptr<lcm::LCM> lcm_handle = node::open_lcm(group.lcm_url());
  lcm::LCM& lcm = *lcm_handle;
  TrialEvaluator eval(*plan.robot, spec.support, t_push, t_end);
  eval.allow_steps(steps_enabled(spec));
  Listener listener(lcm, eval);
  if (!spec.log_file.empty()) {
    fs::create_directories(fs::absolute(spec.log_file).parent_path());
    // The recorder is not part of the lockstep chain, which runs at full speed: lcm_recorder queues
    // what it has not written yet rather than dropping it.
    group.start("lcm_recorder", {spec.log_file, "--force", "--quiet", "--lcm-url", group.lcm_url()}, {}, work + "/lcm_recorder.log");
  }
  std::vector<std::string> nodes = {"estimator", "planner", "wbc"};
  group.start("estimator", with({}), {}, work + "/estimator.log");
  group.start("planner", with({}), {}, work + "/planner.log");
  if (spec.strategy == Strategy::kCam) {
    group.start("wbc", with({}), {}, work + "/wbc.log");
    group.start("reference_gen", with({}), {}, work + "/reference_gen.log");
    group.start("motion_opt", with({}), {}, work + "/motion_opt.log");
    nodes.insert(nodes.end(), {"reference_gen", "motion_opt"});
  } else {
    group.start("wbc", with({"--set", "wbc.wait_for_wholebody=false"}), {}, work + "/wbc.log");
  }
  wait_for_controllers(lcm, listener, nodes, work);
  const pid_t sim = group.start(plan.sim_process,
                                with({"--set", "sim.mode=lockstep", "--set", fmt::format("sim.duration={:.6f}", plan.sim_duration),
                                      "--set", "sim.scenario=" + scenario}),
                                {}, work + "/" + plan.sim_process + ".log");
  TrialWatch watch(spec, eval, t_push, t_end, progress, wall0);
  while (group.running(sim)) {
    lcm.handleTimeout(50);
    if (watch.stop()) break;
  }
  drain(lcm, eval, group.running(sim), plan.sim_duration);
  group.stop_all(2000ms);  // the logger with SIGINT, so that it flushes
  TrialResult r = watch.result();
  r.log_file = spec.log_file;
  if (spec.work_dir.empty()) fs::remove_all(work);
  return r;
}

const char* const kPushOptionsUsage =
    R"(  --robot NAME|FILE     configuration (default toro; NAME looks in the config folder)
  --peak N              peak force of the half-sine push [N] (default 65)
  --link LINK           link pushed (default: the base link)
  --height M            height of the push point above the ground in the standing posture [m]
  --alpha A, --beta B   reference generator parameters (23), (27) for every axis
  --push-time S         simulation time of the push (default: 1 s after the support is settled)
  --after S             simulated time after the push ends (default 5)
  --set KEY=VALUE       configuration override for every process (repeatable)
  --overlay FILE         configuration overrides from a YAML file in the configuration's layout
                        (e.g. push_tune's tuned.yaml, config/overlays/paper.yaml); repeated, a later
                        file wins over an earlier one and every --set over them all
  --engine bullet|mujoco  the physics engine of the simulation (sets sim.engine; default: the
                        configuration's, bullet unless it says otherwise)
  --in-process          the stack's libraries stepping in one thread (the in-process pipeline)
                        instead of the processes over LCM: many times faster, no log
  --truth-state         (with --in-process) every controller sees the simulator's true state
                        instead of the estimate: tells estimation errors from control ones
)";

bool read_push_option(ArgReader& args, TrialSpec& spec) {
  if (args.is("--robot")) {
    spec.config = args.value();
  } else if (args.is("--peak")) {
    spec.peak = args.number();
  } else if (args.is("--link")) {
    spec.link = args.value();
  } else if (args.is("--height")) {
    spec.height = args.number();
  } else if (args.is("--alpha")) {
    spec.alpha = args.number();
  } else if (args.is("--beta")) {
    spec.beta = args.number();
  } else if (args.is("--push-time")) {
    spec.push_time = args.number();
  } else if (args.is("--after")) {
    spec.after = args.number();
  } else if (args.is("--set")) {
    spec.overrides.push_back(args.value());
  } else if (args.is("--engine")) {
    const std::string engine = args.value();
    if (engine != "bullet" && engine != "mujoco") throw UsageError("--engine " + engine + ": expected bullet or mujoco");
    spec.overrides.push_back("sim.engine=" + engine);
  } else if (args.is("--in-process")) {
    spec.in_process = true;
  } else if (args.is("--truth-state")) {
    spec.truth_state = true;
  } else if (args.is("--overlay")) {
    const auto o = overlay_overrides(args.value());
    spec.overlay_keys = std::min(spec.overlay_keys, spec.overrides.size());
    spec.overrides.insert(spec.overrides.begin() + static_cast<std::ptrdiff_t>(spec.overlay_keys), o.begin(), o.end());
    spec.overlay_keys += o.size();
  } else {
    return false;
  }
  return true;
}

namespace {

void flatten(const YAML::Node& node, const std::string& prefix, const std::string& path, std::vector<std::string>& out) {
  if (node.IsMap()) {
    for (const auto& kv : node) flatten(kv.second, prefix.empty() ? kv.first.as<std::string>() : prefix + "." + kv.first.as<std::string>(), path, out);
  } else if (node.IsScalar() || node.IsSequence()) {
    if (prefix.find('.') == std::string::npos) {
      throw std::runtime_error(fmt::format("{}:{}: '{}' is not inside a section", path, node.Mark().line + 1, prefix));
    }
    YAML::Emitter e;
    e << YAML::Flow << node;
    out.push_back(prefix + "=" + e.c_str());
  } else {
    throw std::runtime_error(fmt::format("{}:{}: '{}' has no value", path, node.Mark().line + 1, prefix));
  }
}

}  // namespace

std::vector<std::string> overlay_overrides(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("overlay " + path + ": " + e.what());
  }
  if (!root.IsMap()) throw std::runtime_error("overlay " + path + ": not a mapping of configuration sections");
  std::vector<std::string> out;
  flatten(root, "", path, out);
  return out;
}

}  // namespace hpr::experiments
