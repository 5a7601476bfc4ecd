// push_sweep and push_tune on a real Slurm cluster of one node started for the test
// (tools/slurm-local: munged, slurmctld and slurmd in the foreground, a generated slurm.conf):
// the same trials, verdicts and tables as the local executor; a run stopped by Ctrl-C cancels its
// array and, resumed, finishes with those results; a finished run resumed submits nothing and
// runs no trial; a task that fails is submitted once more and its finished trials are kept; a
// task that fails twice is reported as failed, by case, never as a fall. Skipped, saying why,
// where the Debian packages slurm-wlm and munge are not installed.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "process_group.hpp"
#include "shell.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using hpr::test::bin_dir;
using hpr::test::quote;
using hpr::test::read_file;
using hpr::test::source_dir;

/// Runs a shell command line; stdout and stderr together.
hpr::test::CommandResult sh(const std::string& line) { return hpr::test::run_command({"sh", "-c", line + " 2>&1"}); }

class SlurmCluster : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* exe : {"slurmctld", "slurmd", "munged", "sbatch"}) {
      if (sh(std::string("command -v ") + exe + " || test -x /usr/sbin/" + exe).exit_code != 0) {
        GTEST_SKIP() << exe << " is not installed (Debian packages slurm-wlm and munge; tools/install-deps installs them)";
      }
    }
    dir_ = hpr::test::temp_dir("slurm");
    const auto up = sh(quote(source_dir() + "/tools/slurm-local") + " start " + quote(dir_ + "/cluster"));
    ASSERT_EQ(up.exit_code, 0) << up.out;
    ::setenv("SLURM_CONF", (dir_ + "/cluster/slurm.conf").c_str(), 1);
    started_ = true;
  }
  void TearDown() override {
    if (!started_) return;
    const auto down = sh(quote(source_dir() + "/tools/slurm-local") + " stop " + quote(dir_ + "/cluster"));
    EXPECT_EQ(down.exit_code, 0) << down.out;
    ::unsetenv("SLURM_CONF");
  }

  /// push_sweep with `args` into `out`; its output (progress, notes and table).
  hpr::test::CommandResult sweep(const std::string& args, const std::string& out) const {
    return sh(quote(bin_dir() + "/push_sweep") + " " + args + " --out " + quote(out));
  }

  std::string dir_;
  bool started_ = false;
};

/// The paper's configuration, where the pushes below end in a fall (the default holds them all).
const std::string kPaper = " --overlay " + source_dir() + "/config/overlays/paper.yaml";
/// A small sweep: one direction, both strategies, 4 N s resolution (two cases, about 10 trials).
constexpr int kSweepCases = 2;
const std::string kSweep = "--robot toro --in-process --angles 180 --strategies cam,ankle --start 20 --max-impulse 60 --resolution 4" + kPaper;
/// One case (about 6 trials).
const std::string kOneCase = "--robot toro --in-process --angles 180 --strategies cam --start 20 --max-impulse 60 --resolution 4" + kPaper;

json results_of(const std::string& out) {
  const json j = json::parse(read_file(out + "/sweep.json"));
  return j.at("results");
}

/// The table push_sweep prints (from its header line to "table:").
std::string table_of(const std::string& output) {
  const auto from = output.find("support strategy");
  const auto to = output.find("table:", from);
  return from == std::string::npos || to == std::string::npos ? "" : output.substr(from, to - from);
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST_F(SlurmCluster, ASweepStoppedByCtrlCAndResumedGivesTheLocalResultsAndAFinishedOneRunsNothing) {
  const std::string local = dir_ + "/local", out = dir_ + "/cluster-sweep", log = dir_ + "/interrupted.log";
  const auto l = sweep(kSweep + " --jobs 2", local);
  ASSERT_EQ(l.exit_code, 0) << l.out;
  const json lr = results_of(local);
  ASSERT_EQ(lr.size(), static_cast<std::size_t>(kSweepCases));
  int trials = 0;
  for (const auto& r : lr) trials += static_cast<int>(r.at("trials").size());

  // The array runs, then Ctrl-C: push_sweep cancels it and exits 130.
  const std::string args = kSweep + " --executor slurm";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string line = "exec " + quote(bin_dir() + "/push_sweep") + " " + args + " --out " + quote(out) + " > " + quote(log) + " 2>&1";
    ::execl("/bin/sh", "sh", "-c", line.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  bool running = false;
  for (int i = 0; i < 600 && !running; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    running = read_file(log).find("RUNNING") != std::string::npos;
  }
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  const std::string interrupted = read_file(log);
  ASSERT_TRUE(running) << interrupted;
  EXPECT_NE(interrupted.find("slurm: job array"), std::string::npos) << interrupted;
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130) << interrupted;
  EXPECT_NE(interrupted.find("cancelled"), std::string::npos) << interrupted;
  // Nothing of it is left in the queue.
  bool empty = false;
  for (int i = 0; i < 100 && !empty; ++i) {
    empty = sh("squeue --noheader").out.empty();
    if (!empty) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(empty) << sh("squeue").out;

  // Resumed: the trials finished before Ctrl-C are answered from the shared folder, the others run
  // as array tasks (each case a task of its own, which logs its trials), and the sweep ends with
  // the local executor's results and table, one progress line per trial.
  const auto resumed = sweep(args + " --resume", out);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.out;
  EXPECT_GE(count(resumed.out, "[stored]"), count(interrupted, "N s: ")) << interrupted << "\n" << resumed.out;
  EXPECT_EQ(count(resumed.out, " N s: "), trials) << "one progress line per trial:\n" << resumed.out;
  const json cr = results_of(out);
  EXPECT_EQ(cr, lr) << "slurm:\n" << cr.dump(1) << "\nlocal:\n" << lr.dump(1);
  EXPECT_EQ(table_of(resumed.out), table_of(l.out));
  EXPECT_FALSE(table_of(l.out).empty()) << l.out;
  // The resumed run's array (round 0002) ran what was left, each case as a task that logged it;
  // without one, Ctrl-C came after the last trial and every trial was stored.
  if (fs::exists(out + "/slurm/rounds/0002")) {
    int tasks = 0;
    for (const auto& task : fs::directory_iterator(out + "/slurm/rounds/0002")) {
      if (task.path().extension() != ".log") continue;
      ++tasks;
      const std::string text = read_file(task.path().string());
      EXPECT_NE(text.find("largest recovered impulse"), std::string::npos) << task.path() << ": " << text;
    }
    EXPECT_GE(tasks, 1);
  } else {
    EXPECT_EQ(count(resumed.out, "[stored]"), trials) << resumed.out;
  }

  // Finished and resumed once more: every trial is answered from the shared folder, no array.
  const auto again = sweep(args + " --resume", out);
  ASSERT_EQ(again.exit_code, 0) << again.out;
  EXPECT_EQ(again.out.find("job array"), std::string::npos) << again.out;
  EXPECT_EQ(count(again.out, "[stored]"), trials) << again.out;
  EXPECT_EQ(results_of(out), lr);
}

TEST_F(SlurmCluster, AFailedTaskIsSubmittedOnceMoreAndKeepsTheTrialsItFinished) {
  // The task's first run stores only its first two trials and fails (a node that died after two
  // trials: the run goes to a store of its own, two of its trials are copied to the shared one);
  // the second run must take those two from the store and run the others.
  const std::string wrapper = dir_ + "/fail-once.sh", mark = dir_ + "/failed-once";
  std::ofstream(wrapper) << "#!/bin/sh\n"
                         << "if [ -e " << quote(mark) << " ]; then exec " << quote(bin_dir() + "/push_task") << " \"$@\"; fi\n"
                         << "touch " << quote(mark) << "\n"
                         << "store=''; prev=''\n"
                         << "for a in \"$@\"; do\n"
                         << "  shift\n"
                         << "  if [ \"$prev\" = --store ]; then store=$a; set -- \"$@\" \"$a.first\"; else set -- \"$@\" \"$a\"; fi\n"
                         << "  prev=$a\n"
                         << "done\n"
                         << quote(bin_dir() + "/push_task") << " \"$@\" || exit 9\n"
                         << "for f in \"$store.first\"/*.jsonl; do head -n 3 \"$f\" > \"$store/$(basename \"$f\")\"; done\n"
                         << "exit 3\n";
  fs::permissions(wrapper, fs::perms::owner_all);
  const auto l = sweep(kOneCase, dir_ + "/local");
  ASSERT_EQ(l.exit_code, 0) << l.out;
  const std::string out = dir_ + "/fail-once";
  const auto c = sweep(kOneCase + " --executor slurm --task-exe " + quote(wrapper), out);
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(c.out.find("submitting it again"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("FAILED"), std::string::npos) << "the first run's state is named:\n" << c.out;
  EXPECT_EQ(results_of(out), results_of(dir_ + "/local"));
  // The resubmitted task answered two trials from the store and ran the others.
  const std::string log = read_file(out + "/slurm/rounds/0001/task-0.log");
  EXPECT_EQ(count(log, "[stored]"), 2) << log;
}

TEST_F(SlurmCluster, ATaskThatFailsTwiceIsReportedAsFailedNeverAsAFall) {
  const std::string wrapper = dir_ + "/fail.sh";
  std::ofstream(wrapper) << "#!/bin/sh\necho 'no robot here' >&2\nexit 5\n";
  fs::permissions(wrapper, fs::perms::owner_all);
  const std::string out = dir_ + "/fail";
  const auto c = sweep(kOneCase + " --executor slurm --task-exe " + quote(wrapper), out);
  EXPECT_EQ(c.exit_code, 4) << c.out;
  const json r = results_of(out);
  ASSERT_EQ(r.size(), 1U);
  EXPECT_TRUE(r[0].value("failed", false)) << r.dump(1);
  EXPECT_NE(r[0].at("failure").get<std::string>().find("failed twice"), std::string::npos) << r.dump(1);
  EXPECT_NE(r[0].at("failure").get<std::string>().find("exit code 5"), std::string::npos) << r.dump(1);
  EXPECT_TRUE(r[0].at("trials").empty());
  EXPECT_TRUE(r[0].at("max_recovered_Ns").is_null()) << r.dump(1);
  EXPECT_NE(table_of(c.out).find("failed"), std::string::npos) << c.out;
  EXPECT_NE(read_file(out + "/slurm/rounds/0001/task-0.log").find("no robot here"), std::string::npos);
}

TEST_F(SlurmCluster, ATuningRunGivesTheLocalEvaluations) {
  const std::string args = "--robot toro --params alpha --angles 180 --evaluations 2 --algorithm sbplx --resolution 8" + kPaper;
  const auto l = sh(quote(bin_dir() + "/push_tune") + " " + args + " --jobs 2 --out " + quote(dir_ + "/tune-local"));
  ASSERT_EQ(l.exit_code, 0) << l.out;
  const auto c = sh(quote(bin_dir() + "/push_tune") + " " + args + " --executor slurm --out " + quote(dir_ + "/tune-slurm"));
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(c.out.find("slurm: job array"), std::string::npos) << c.out;
  const auto evaluations = [](const std::string& path) {
    std::vector<json> out;
    std::istringstream in(read_file(path));
    for (std::string line; std::getline(in, line);) {
      if (line.empty()) continue;
      json j = json::parse(line);
      j.erase("wall_s");
      out.push_back(j);
    }
    return out;
  };
  const auto le = evaluations(dir_ + "/tune-local/results.jsonl"), ce = evaluations(dir_ + "/tune-slurm/results.jsonl");
  ASSERT_GE(le.size(), 2U);
  EXPECT_EQ(ce, le);
  EXPECT_EQ(read_file(dir_ + "/tune-slurm/tuned.yaml"), read_file(dir_ + "/tune-local/tuned.yaml"));
}

// A node that runs another build than the submitting machine's would key its trials by another
// commit, where the submitter never looks: push_task refuses, naming both commits.
TEST(SlurmExecutor, ATaskOfAnotherBuildRefusesToRunNamingBothCommits) {
  const std::string dir = hpr::test::temp_dir("slurm-commit");
  std::ofstream(dir + "/searches.jsonl") << "{}\n";
  const auto r = sh(quote(bin_dir() + "/push_task") + " --searches " + quote(dir + "/searches.jsonl") + " --task 0 --store " +
                    quote(dir + "/trials") + " --commit 0123456789ab");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("0123456789ab"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("built from"), std::string::npos) << r.out;
}

// The executors are the experiment tools' alone: no process that runs on a robot carries them.
TEST(SlurmExecutor, NoProcessOfTheControlPathCarriesIt) {
  const std::string marker = "sbatch";
  EXPECT_NE(read_file(bin_dir() + "/push_sweep").find(marker), std::string::npos) << "the marker is in the tool that submits";
  for (const char* exe : {"estimator", "planner", "wbc", "reference_gen", "motion_opt", "controllers", "hal", "sim_bullet", "drive_emulator"}) {
    const std::string binary = read_file(bin_dir() + "/" + exe);
    ASSERT_FALSE(binary.empty()) << exe;
    EXPECT_EQ(binary.find(marker), std::string::npos) << exe << " links the Slurm executor";
  }
}

}  // namespace
