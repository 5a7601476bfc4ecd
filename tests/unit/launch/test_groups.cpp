// Group files: the shipped file loads, includes and start order, and every malformed entry is
// rejected with a message naming the file, the key and the value.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "hpr/common/config.hpp"
#include "hpr/launch/groups.hpp"
#include "hpr/graph/data_flow.hpp"
#include "scratch_dir.hpp"

namespace {

using hpr::ConfigError;
using hpr::launch::GroupsFile;

std::string write(const std::string& text) {
  static int n = 0;
  static const hpr::test::ScratchDir dir("groups");
  const std::string path = dir.path() / (std::to_string(n++) + ".yaml");
  std::ofstream(path) << text;
  return path;
}

/// The message of the ConfigError that loading `text` throws ("" when it loads).
std::string error_of(const std::string& text) {
  try {
    GroupsFile::load(write(text));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

std::vector<std::string> names(const hpr::launch::GroupSpec& g) {
  std::vector<std::string> out;
  for (const auto& p : g.processes) out.push_back(p.name);
  return out;
}

// Every group that runs a robot (a backend with the controllers, as processes or composed) gets
// each required input of its processes from one of them (the stack's declared data flow).
TEST(Groups, EveryRobotGroupIsAClosedDataFlow) {
  const GroupsFile f = GroupsFile::load(std::string(HPR_SOURCE_DIR) + "/config/groups.yaml");
  for (const char* g : {"sim", "sim-lockstep", "sim-truth-lockstep", "sim-composed", "sim-composed-lockstep", "hil", "hil-lockstep",
                        "hil-canopen", "hil-canopen-lockstep", "hardware", "hardware-composed", "sim-view", "sim-mujoco",
                        "sim-mujoco-lockstep", "sim-mujoco-composed", "sim-mujoco-composed-lockstep"}) {
    std::vector<std::string> commands;
    for (const auto& p : f.group(g).processes) commands.push_back(p.command);
    EXPECT_EQ(hpr::graph::unmet_inputs(commands), std::vector<std::string>{}) << g;
  }
  // The composed groups run the controllers in one process, critical and watched as the wbc is.
  for (const char* g : {"sim-composed", "sim-composed-lockstep", "hardware-composed", "sim-mujoco-composed", "sim-mujoco-composed-lockstep"}) {
    const auto* c = f.group(g).find("controllers");
    ASSERT_NE(c, nullptr) << g;
    EXPECT_TRUE(c->critical);
    EXPECT_EQ(f.group(g).find("wbc"), nullptr) << g;
  }
  EXPECT_EQ(hpr::graph::unmet_inputs({"estimator", "planner", "wbc", "reference_gen", "motion_opt"}).size(), 1U);
  // Without the planner, motion_opt and the wbc have no plan to follow.
  EXPECT_EQ(hpr::graph::unmet_inputs({"sim_bullet", "estimator", "wbc", "reference_gen", "motion_opt"}).size(), 2U);
  // The true state needs a simulator: on the hal's sensors it lacks SIM_TRUTH.
  EXPECT_EQ(hpr::graph::unmet_inputs({"hal", "truth_state", "planner", "wbc"}),
            std::vector<std::string>{"truth_state reads SIM_TRUTH (the simulator's base, CoM and contacts of the same tick), which none "
                                     "of them writes"});
}

TEST(Groups, ShippedFileHasEveryBackendWithTheSameControlProcesses) {
  const GroupsFile f = GroupsFile::load(std::string(HPR_SOURCE_DIR) + "/config/groups.yaml");
  for (const char* g : {"sim", "sim-mujoco", "hil", "hardware"}) {
    const auto& group = f.group(g);
    for (const char* c : {"estimator", "planner", "wbc", "reference_gen", "motion_opt"}) {
      const auto* p = group.find(c);
      ASSERT_NE(p, nullptr) << g << " lacks " << c;
      // Swapping the backend never changes the control processes' command line.
      EXPECT_EQ(p->args, f.group("control").find(c)->args) << g << "/" << c;
      EXPECT_EQ(p->args.back(), std::string(HPR_SOURCE_DIR) + "/config/toro.yaml");
    }
    EXPECT_TRUE(group.find("wbc")->critical);
    EXPECT_TRUE(group.find("planner")->critical);
    // The critical nodes are watched for hangs closely enough to damp within 100 ms.
    for (const char* c : {"estimator", "planner", "wbc"}) {
      EXPECT_GT(group.find(c)->hung_after_s, 0.0) << g << "/" << c;
      EXPECT_LE(group.find(c)->hung_after_s, 0.05) << g << "/" << c;
    }
  }
  EXPECT_NE(f.group("sim").find("sim_bullet"), nullptr);
  EXPECT_NE(f.group("sim-mujoco").find("sim_mujoco"), nullptr);
  EXPECT_EQ(f.group("sim-mujoco").find("sim_bullet"), nullptr);
  // The lockstep groups override the control processes' real-time priorities, the real-time ones keep them.
  EXPECT_EQ(f.group("sim").find("wbc")->rt_priority, 70);
  for (const char* g : {"sim-lockstep", "hil-lockstep", "hil-canopen-lockstep", "sim-mujoco-lockstep", "sim-mujoco-composed-lockstep"}) {
    for (const auto& p : f.group(g).processes) EXPECT_EQ(p.rt_priority, 0) << g << "/" << p.name;
  }
  EXPECT_NE(f.group("hil").find("drive_emulator"), nullptr);
  EXPECT_NE(f.group("hardware").find("hal"), nullptr);
  // The backend starts first; each process after what it depends on.
  EXPECT_EQ(names(f.group("hil")), (std::vector<std::string>{"drive_emulator", "hal", "estimator", "planner", "wbc", "reference_gen", "motion_opt"}));
  EXPECT_THROW((void)f.group("nonexistent"), std::invalid_argument);
}

TEST(Groups, VariablesDefaultsAndOverrides) {
  const std::string path = write(R"(
vars: {robot: toro}
defaults: {stop_timeout: 1.5, restart: on-failure}
groups:
  g:
    processes:
      a: {command: a, args: ["${config_dir}/${robot}.yaml"], env: {X: "${robot}"}, stop_signal: SIGINT, cpus: [0, 1], rt_priority: 50}
      b: {command: b, restart: never, ready: start, depends_on: [a]}
)");
  const GroupsFile f = GroupsFile::load(path, {{"robot", "h1_2"}});
  const auto& a = *f.group("g").find("a");
  EXPECT_EQ(a.args.at(0), std::filesystem::path(path).parent_path().string() + "/h1_2.yaml");
  EXPECT_EQ(a.env.at("X"), "h1_2");
  EXPECT_EQ(a.stop_signal, SIGINT);
  EXPECT_DOUBLE_EQ(a.stop_timeout_s, 1.5);
  EXPECT_EQ(a.restart, hpr::launch::RestartPolicy::kOnFailure);
  EXPECT_EQ(a.cpus, (std::vector<int>{0, 1}));
  EXPECT_EQ(a.rt_priority, 50);
  const auto& b = *f.group("g").find("b");
  EXPECT_EQ(b.restart, hpr::launch::RestartPolicy::kNever);
  EXPECT_EQ(b.ready_on, hpr::launch::ReadyOn::kStart);
  EXPECT_EQ(b.health_node, "b");
}

TEST(Groups, StartOrderFollowsDependenciesAcrossIncludes) {
  const GroupsFile f = GroupsFile::load(write(R"(
groups:
  base:
    processes:
      z: {command: z, depends_on: [y]}
      y: {command: y}
  top:
    include: [base]
    processes:
      x: {command: x, depends_on: [z], host: h2}
)"));
  EXPECT_EQ(names(f.group("base")), (std::vector<std::string>{"y", "z"}));
  EXPECT_EQ(names(f.group("top")), (std::vector<std::string>{"y", "z", "x"}));
  EXPECT_EQ(f.group("top").hosts(), std::vector<std::string>{"h2"});
  EXPECT_TRUE(f.group("top").runs_on(*f.group("top").find("y"), "h1"));
  EXPECT_FALSE(f.group("top").runs_on(*f.group("top").find("x"), "h1"));
}

TEST(Groups, MalformedEntriesNameFileKeyAndValue) {
  const std::string head = "groups:\n  g:\n    processes:\n";
  struct Case {
    std::string body, expect;
  };
  const std::vector<Case> cases = {
      {"      a: {command: a, restart: sometimes}\n", "groups.g.processes.a.restart = sometimes"},
      {"      a: {command: a, rt_priority: 120}\n", "groups.g.processes.a.rt_priority = 120"},
      {"      a: {command: a, stop_signal: SIGFOO}\n", "groups.g.processes.a.stop_signal = SIGFOO"},
      {"      a: {command: a, comand: b}\n", "groups.g.processes.a.comand"},
      {"      a: {command: a, depends_on: [nope]}\n", "groups.g.processes.a.depends_on = nope"},
      {"      a: {command: a, depends_on: [b]}\n      b: {command: b, depends_on: [a]}\n", "cycle"},
      {"      a: {command: a, args: [\"${undefined_var}\"]}\n", "${undefined_var}"},
      {"      a: {command: a, stop_timeout: -1}\n", "groups.g.processes.a.stop_timeout = -1"},
      {"      a: {command: a, cpus: [0.5]}\n", "groups.g.processes.a.cpus"},
      {"      a: {args: [x]}\n", "groups.g.processes.a.command"},
      {"      a: {command: a, hung_after: -1}\n", "groups.g.processes.a.hung_after = -1"},
      {"      a: {command: a, hung_after: 0.001}\n", "groups.g.processes.a.hung_after = 0.001: must be 0"},
      {"      a: {command: a, ready: start, hung_after: 0.1}\n", "groups.g.processes.a.hung_after = 0.1: needs ready: health"},
      {"    overrides: {rt_priorty: 0}\n    processes:\n      a: {command: a}\n", "groups.g.overrides.rt_priorty"},
  };
  for (const auto& c : cases) {
    const std::string msg = error_of(head + c.body);
    EXPECT_NE(msg.find(c.expect), std::string::npos) << "case:\n" << c.body << "message: " << msg;
    EXPECT_NE(msg.find(".yaml"), std::string::npos) << "the file is named: " << msg;
  }
  EXPECT_NE(error_of("groups:\n  g: {include: [missing]}\n").find("no group named 'missing'"), std::string::npos);
  EXPECT_NE(error_of("groups:\n  g: {include: [h]}\n  h: {include: [g]}\n").find("cycle"), std::string::npos);
  EXPECT_NE(error_of("grops: {}\n").find("grops"), std::string::npos);
}

}  // namespace
